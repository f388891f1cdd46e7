//! Instance pose: world = translation * rotation * scale * object.

use glam::{Mat3, Mat4, Quat, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub translation: Vec3,
    pub rotation: Quat,
    pub scale: Vec3,
}

impl Default for Pose {
    fn default() -> Self {
        Pose { translation: Vec3::ZERO, rotation: Quat::IDENTITY, scale: Vec3::ONE }
    }
}

impl Pose {
    pub fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }

    /// Matrix that maps object-space normals to world space (inverse transpose of the linear part).
    pub fn normal_matrix(&self) -> Mat3 {
        Mat3::from_mat4(self.matrix()).inverse().transpose()
    }

    /// True when the pose mirrors space, which flips triangle winding.
    pub fn is_mirroring(&self) -> bool {
        self.scale.x * self.scale.y * self.scale.z < 0.0
    }
}
