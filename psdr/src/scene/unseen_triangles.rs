//! Triangles no ray can tell apart from nothing or from another, dropped wherever meshes are made (read from an
//! OBJ, or scaled to metres for the model database: rounding can make a triangle flat or equal to another).

use super::MeshPart;
use glam::Vec3;

/// What `drop_unseen_triangles` did.
pub struct UnseenTriangles {
    pub dropped: usize,
    /// Per part as it was: kept (false: all its triangles were dropped, so the part was removed).
    pub parts_kept: Vec<bool>,
}

/// Drops zero-area triangles (a ray never hits them) and exact repeats of an earlier triangle of `parts`,
/// corners in the same cyclic order (a ray finds the first), then the parts left without triangles. Real
/// models carry them by the hundred (a plant with one triangle 249 times, a cooktop with half its triangles
/// doubled); they add nothing to an image but make the BVH a chain deeper than the traversal stack.
pub fn drop_unseen_triangles(parts: &mut Vec<MeshPart>) -> UnseenTriangles {
    let mut seen = std::collections::HashSet::new();
    let mut dropped = 0;
    for part in parts.iter_mut() {
        let positions = &part.positions;
        part.indices.retain(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            if (b - a).cross(c - a) == Vec3::ZERO {
                dropped += 1;
                return false;
            }
            // The same triangle starting at any corner: key it from its smallest corner.
            let bits = |v: Vec3| v.to_array().map(f32::to_bits);
            let corners = [bits(a), bits(b), bits(c)];
            let first = (0..3).min_by_key(|&k| corners[k]).unwrap_or(0);
            let key = [corners[first], corners[(first + 1) % 3], corners[(first + 2) % 3]];
            let new = seen.insert(key);
            dropped += usize::from(!new);
            new
        });
    }
    let parts_kept: Vec<bool> = parts.iter().map(|p| !p.indices.is_empty()).collect();
    parts.retain(|p| !p.indices.is_empty());
    UnseenTriangles { dropped, parts_kept }
}
