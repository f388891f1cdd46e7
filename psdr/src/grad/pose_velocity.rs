//! Pose parameters as velocity fields: how a world-space point of an object moves per unit change of the
//! parameter (∂x/∂θ). Boundary and interior terms of geometric parameters both need exactly this.

use super::ParamPath;
use crate::error::{Error, Result};
use crate::scene::Scene;
use glam::{Mat3, Quat, Vec3};

/// One differentiable pose component of one object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PoseComponent {
    /// Translation along world axis 0, 1, 2.
    Translation(usize),
    /// Rotation about the world up axis (+y) through the object's origin (ParamPath::Yaw).
    Yaw,
    /// Scale along the object's own axis 0, 1, 2.
    Scale(usize),
}

/// The pose components a set of parameter paths asks for, with their offsets in the gradient vector.
#[derive(Clone, Debug)]
pub struct PoseLayout {
    /// (object index, component, offset in the gradient vector).
    pub entries: Vec<(u32, PoseComponent, usize)>,
    pub len: usize,
    translation: Vec<Vec3>,
    rotation: Vec<Quat>,
    scale: Vec<Vec3>,
}

impl PoseLayout {
    pub fn new(scene: &Scene, params: &[ParamPath]) -> Result<PoseLayout> {
        let mut l = PoseLayout {
            entries: vec![],
            len: 0,
            translation: scene.objects.iter().map(|o| o.pose.translation).collect(),
            rotation: scene.objects.iter().map(|o| o.pose.rotation).collect(),
            scale: scene.objects.iter().map(|o| o.pose.scale).collect(),
        };
        for p in params {
            let object = |name: &str| {
                scene
                    .object_index(name)
                    .map(|i| i as u32)
                    .ok_or_else(|| Error::Invalid(format!("{p}: no object named '{name}'")))
            };
            match p {
                ParamPath::Translation(n) => {
                    let o = object(n)?;
                    (0..3).for_each(|a| l.entries.push((o, PoseComponent::Translation(a), l.len + a)));
                    l.len += 3;
                }
                ParamPath::Yaw(n) => {
                    l.entries.push((object(n)?, PoseComponent::Yaw, l.len));
                    l.len += 1;
                }
                ParamPath::Scale(n) => {
                    let o = object(n)?;
                    if l.scale[o as usize].min_element().abs() < 1e-12 {
                        return Err(Error::Invalid(format!("{p}: a zero scale has no derivative")));
                    }
                    (0..3).for_each(|a| l.entries.push((o, PoseComponent::Scale(a), l.len + a)));
                    l.len += 3;
                }
                _ => {
                    return Err(Error::Invalid(format!(
                        "{p}: geometric gradients of depth and masks cover object translation, yaw and scale so far"
                    )))
                }
            }
        }
        Ok(l)
    }

    /// True when some entry moves `object`.
    pub fn moves(&self, object: u32) -> bool {
        self.entries.iter().any(|e| e.0 == object)
    }

    /// ∂u/∂x, the constant Jacobian of the (affine) velocity field of one component.
    pub fn velocity_gradient(&self, object: u32, c: PoseComponent) -> Mat3 {
        let o = object as usize;
        match c {
            PoseComponent::Translation(_) => Mat3::ZERO,
            // G v = ŷ × v.
            PoseComponent::Yaw => Mat3::from_cols(-Vec3::Z, Vec3::ZERO, Vec3::X),
            PoseComponent::Scale(a) => {
                let r = Mat3::from_quat(self.rotation[o]);
                r * Mat3::from_diagonal(Vec3::AXES[a] / self.scale[o][a]) * r.transpose()
            }
        }
    }

    /// ∂n/∂θ of a unit normal carried by the motion (normals transform with the inverse transpose).
    pub fn normal_velocity(&self, object: u32, c: PoseComponent, n: Vec3) -> Vec3 {
        let gt_n = self.velocity_gradient(object, c).transpose() * n;
        -gt_n + n * n.dot(gt_n)
    }

    /// ∂x/∂θ of the world-space point `x` of `object` for one component.
    pub fn velocity(&self, object: u32, c: PoseComponent, x: Vec3) -> Vec3 {
        let o = object as usize;
        match c {
            PoseComponent::Translation(a) => Vec3::AXES[a],
            // x = T + Ry(ψ) R' S x_obj  ⇒  ∂x/∂ψ = ŷ × (x − T).
            PoseComponent::Yaw => Vec3::Y.cross(x - self.translation[o]),
            // x = T + R S x_obj  ⇒  ∂x/∂s_a = R e_a (x_obj)_a, with x_obj = S⁻¹ R⁻¹ (x − T).
            PoseComponent::Scale(a) => {
                let local = self.rotation[o].inverse() * (x - self.translation[o]);
                self.rotation[o] * (Vec3::AXES[a] * (local[a] / self.scale[o][a]))
            }
        }
    }
}
