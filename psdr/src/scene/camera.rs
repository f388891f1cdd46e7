//! Pinhole camera: vertical field of view, square pixels.

use glam::{Mat4, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub origin: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit up vector, orthogonal to `forward`.
    pub up: Vec3,
    pub fov_y_deg: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// Builds a camera from a look-at triple. `up` need not be orthogonal to the view direction.
    pub fn look_at(origin: Vec3, target: Vec3, up: Vec3, fov_y_deg: f32, width: u32, height: u32) -> Self {
        let forward = (target - origin).normalize();
        let right = forward.cross(up).normalize();
        Camera { origin, forward, up: right.cross(forward), fov_y_deg, width, height }
    }

    /// Builds a camera from a camera-to-world matrix in the OpenGL convention (looks down -z, +y up).
    pub fn from_matrix(to_world: Mat4, fov_y_deg: f32, width: u32, height: u32) -> Self {
        let origin = to_world.transform_point3(Vec3::ZERO);
        let forward = to_world.transform_vector3(-Vec3::Z).normalize();
        let up = to_world.transform_vector3(Vec3::Y);
        let right = forward.cross(up).normalize();
        Camera { origin, forward, up: right.cross(forward), fov_y_deg, width, height }
    }

    pub fn right(&self) -> Vec3 {
        self.forward.cross(self.up)
    }

    pub fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// tan(fov_y / 2): half the image-plane height at distance 1.
    pub fn tan_half_fov(&self) -> f32 {
        (self.fov_y_deg.to_radians() * 0.5).tan()
    }
}
