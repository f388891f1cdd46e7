//! The primary boundary's inputs as the Vulkan kernels read them (shaders/grad/boundary/primary.glsl): pose
//! entries with their affine velocity fields, and the silhouette edges `PrimaryEdges::build` chose, as words.

use crate::grad::boundary::primary::PrimaryEdges;
use crate::grad::PoseLayout;

/// Pose entries as the kernel reads them (POSE_WORDS each): object, offset, then the affine field's a, G's
/// columns and t as float bits. `None` when some entry is not affine (a vertex).
pub(super) fn pose_words(pose: &PoseLayout) -> Option<Vec<u32>> {
    let mut words = Vec::with_capacity(pose.entries.len() * 17);
    for &(o, c, at) in &pose.entries {
        let f = pose.affine_velocity(o, c)?;
        words.extend([o, at as u32]);
        for v in [f.a, f.g.x_axis, f.g.y_axis, f.g.z_axis, f.t] {
            words.extend(v.to_array().map(f32::to_bits));
        }
    }
    Some(words)
}

/// Silhouette edges as the kernel reads them (EDGE_WORDS each): a, object, b, unused, pa, pb.
pub(super) fn edge_words(edges: &PrimaryEdges) -> Vec<u32> {
    let mut words = Vec::with_capacity(edges.edges.len() * 12);
    for e in &edges.edges {
        words.extend(e.a.to_array().map(f32::to_bits));
        words.push(e.object);
        words.extend(e.b.to_array().map(f32::to_bits));
        words.push(0);
        words.extend([e.pa[0], e.pa[1], e.pb[0], e.pb[1]].map(f32::to_bits));
    }
    words
}
