//! Smooth shading for flat-shaded meshes that approximate smooth surfaces ("auto smooth"): each triangle
//! corner's shading normal is the area-weighted mean of the normals of the triangles around that position whose
//! normals lie within `max_angle_deg` of its own; sharper edges stay creases. Between two flat faces every edge
//! is a shading crease, a discontinuity the boundary terms must sample (96 % of a Sweet Home 3D armchair's
//! edges); smoothed, the edges below the angle are continuous and only silhouettes and real creases remain,
//! which is what such a mesh models. Positions are unchanged; the part gets one vertex per corner.

use super::MeshPart;
use glam::{Vec2, Vec3};
use std::collections::HashMap;

/// `part` with shading normals smoothed across edges whose dihedral angle is below `max_angle_deg`.
pub fn auto_smooth(part: &MeshPart, max_angle_deg: f32) -> MeshPart {
    let cos_max = max_angle_deg.to_radians().cos();
    let p = &part.positions;
    // Area-weighted face normals (the cross product's length is twice the area).
    let faces: Vec<Vec3> = part
        .indices
        .iter()
        .map(|t| (p[t[1] as usize] - p[t[0] as usize]).cross(p[t[2] as usize] - p[t[0] as usize]))
        .collect();
    // Triangles around each position (exact positions: OBJ faces that share a corner share its coordinates).
    let key = |v: Vec3| v.to_array().map(f32::to_bits);
    let mut around: HashMap<[u32; 3], Vec<usize>> = HashMap::new();
    for (f, t) in part.indices.iter().enumerate() {
        for &i in t {
            around.entry(key(p[i as usize])).or_default().push(f);
        }
    }
    let (mut positions, mut normals, mut uvs, mut indices) = (vec![], vec![], vec![], vec![]);
    for (f, t) in part.indices.iter().enumerate() {
        let own = faces[f].normalize_or_zero();
        let base = positions.len() as u32;
        for &i in t {
            let v = p[i as usize];
            let mut n = Vec3::ZERO;
            for &g in &around[&key(v)] {
                if faces[g].normalize_or_zero().dot(own) >= cos_max {
                    n += faces[g];
                }
            }
            let n = n.normalize_or_zero();
            positions.push(v);
            normals.push(if n == Vec3::ZERO { own } else { n });
            if let Some(u) = &part.uvs {
                uvs.push(u[i as usize]);
            }
        }
        indices.push([base, base + 1, base + 2]);
    }
    MeshPart {
        name: part.name.clone(),
        material: part.material,
        positions,
        normals: Some(normals),
        uvs: part.uvs.as_ref().map(|_| uvs).filter(|u: &Vec<Vec2>| !u.is_empty()),
        indices,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{box_mesh, sphere_mesh};

    /// A flat-shaded sphere (faces 7.5 degrees apart) smoothed at 30 degrees gets the sphere's normals; a box's
    /// 90-degree edges stay creases (each face keeps its own normal).
    #[test]
    fn smooths_below_the_angle_and_keeps_sharper_edges() {
        let mut ball = sphere_mesh(1.0, 24, 48, false);
        ball.normals = None;
        let smooth = auto_smooth(&ball, 30.0);
        for (v, n) in smooth.positions.iter().zip(smooth.normals.as_ref().unwrap()) {
            assert!(n.dot(v.normalize()) > 0.995, "{v} {n}");
        }
        let mut b = box_mesh(Vec3::ONE, false);
        b.normals = None;
        let boxed = auto_smooth(&b, 30.0);
        for (t, f) in boxed.indices.iter().zip(&b.indices) {
            let p = &b.positions;
            let face = (p[f[1] as usize] - p[f[0] as usize]).cross(p[f[2] as usize] - p[f[0] as usize]).normalize();
            for &i in t {
                assert!((boxed.normals.as_ref().unwrap()[i as usize] - face).length() < 1e-6);
            }
        }
    }
}
