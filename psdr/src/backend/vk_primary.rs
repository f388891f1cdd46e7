//! The pose kernels' inputs as they read them (shaders/grad/boundary/primary.glsl): pose entries with their affine
//! velocity fields and vertex blocks, the corners' welded ids, and the silhouette edges `PrimaryEdges::build`
//! chose, as words.

use crate::grad::{PoseLayout, PrimaryEdges};
use crate::render::SceneData;
use glam::Vec3;

/// Pose entries as the kernels read them (POSE_WORDS each): object, offset, then the affine field's a, G's
/// columns and t as float bits; then one vertex block per object whose vertices are parameters: the object
/// tagged VERTEX_BLOCK, the offset of its vertex 0 axis 0, and R (e_a S) for the three axes in a and G's first
/// two columns. Returns the words and their entry count.
pub(super) fn pose_words(pose: &PoseLayout) -> (Vec<u32>, u32) {
    let mut words = Vec::with_capacity(pose.entries.len() * 17);
    let mut count = 0;
    for &(o, c, at) in &pose.entries {
        let Some(f) = pose.affine_velocity(o, c) else { continue };
        words.extend([o, at as u32]);
        for v in [f.a, f.g.x_axis, f.g.y_axis, f.g.z_axis, f.t] {
            words.extend(v.to_array().map(f32::to_bits));
        }
        count += 1;
    }
    for (o, at, axes) in pose.vertex_blocks() {
        words.extend([o | VERTEX_BLOCK, at as u32]);
        for v in [axes[0], axes[1], axes[2], Vec3::ZERO, Vec3::ZERO] {
            words.extend(v.to_array().map(f32::to_bits));
        }
        count += 1;
    }
    (words, count)
}

/// The object word's tag of a vertex block (VERTEX_BLOCK in shaders/grad/boundary/primary.glsl).
const VERTEX_BLOCK: u32 = 0x8000_0000;

/// The welded vertex ids of every triangle's corners (3 per `SceneData` triangle), for the vertex blocks.
pub(super) fn corner_ids(d: &SceneData, pose: &PoseLayout) -> Vec<u32> {
    if !pose.has_vertices() {
        return vec![];
    }
    (0..d.triangles.len() as u32).flat_map(|ti| pose.corners(d, ti)).collect()
}

/// Silhouette edges as the kernel reads them (EDGE_WORDS each): a, object, b, the first end's welded id, pa, pb,
/// the whole mesh edge's first point, the second end's id, its second point, unused.
pub(super) fn edge_words(edges: &PrimaryEdges) -> Vec<u32> {
    let mut words = Vec::with_capacity(edges.edges.len() * 20);
    for e in &edges.edges {
        words.extend(e.a.to_array().map(f32::to_bits));
        words.push(e.object);
        words.extend(e.b.to_array().map(f32::to_bits));
        words.push(e.ends[0]);
        words.extend([e.pa[0], e.pa[1], e.pb[0], e.pb[1]].map(f32::to_bits));
        words.extend(e.mesh[0].to_array().map(f32::to_bits));
        words.push(e.ends[1]);
        words.extend(e.mesh[1].to_array().map(f32::to_bits));
        words.push(0);
    }
    words
}
