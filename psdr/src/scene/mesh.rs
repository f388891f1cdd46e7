//! Objects: named instances made of mesh parts (one material each), a pose, and an optional emitter.

use super::Pose;
use glam::{Vec2, Vec3};

/// A triangle mesh in object space with one material.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct MeshPart {
    /// Material group name from the OBJ file, or the primitive's name.
    pub name: String,
    pub material: usize,
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals; `None` means flat shading.
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    pub indices: Vec<[u32; 3]>,
}

/// An area light: every triangle of the object emits `radiance` (linear RGB, W/(m^2 sr)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emitter {
    pub radiance: Vec3,
    /// One-sided emitters emit on the side their geometric normal points to.
    pub two_sided: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    pub name: String,
    pub parts: Vec<MeshPart>,
    pub pose: Pose,
    pub emitter: Option<Emitter>,
}
