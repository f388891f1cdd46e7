//! The welded vertices of an object: mesh vertices that share an exact object-space position are one vertex.
//! OBJ files duplicate a vertex for every distinct (position, normal, uv) and parts never share vertices, so a
//! flat-shaded cube holds 24 vertices for its 8 corners. Vertex-position parameters and mesh adjacency both
//! work on the welded corners, so moving a corner moves every copy and never tears the surface open.

use super::Object;
use glam::Vec3;
use std::collections::HashMap;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Welding {
    /// Object-space position of each welded vertex, in order of first appearance (parts in order).
    pub positions: Vec<Vec3>,
    /// For each part, the welded id of each of its vertices.
    pub ids: Vec<Vec<u32>>,
}

pub fn weld(object: &Object) -> Welding {
    let mut w = Welding::default();
    let mut by_bits: HashMap<[u32; 3], u32> = HashMap::new();
    for part in &object.parts {
        let ids = part
            .positions
            .iter()
            .map(|p| {
                *by_bits.entry(p.to_array().map(f32::to_bits)).or_insert_with(|| {
                    w.positions.push(*p);
                    w.positions.len() as u32 - 1
                })
            })
            .collect();
        w.ids.push(ids);
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{box_mesh, Pose};

    /// A box primitive with per-face vertices welds to its 8 corners, and every copy maps to its corner.
    #[test]
    fn a_box_welds_to_eight_corners() {
        let part = box_mesh(Vec3::new(1.0, 2.0, 3.0), false);
        let object = Object { name: "b".into(), parts: vec![part.clone(), part], pose: Pose::default(), emitter: None };
        let w = weld(&object);
        assert_eq!(w.positions.len(), 8);
        for (p, ids) in object.parts.iter().zip(&w.ids) {
            for (v, &id) in p.positions.iter().zip(ids) {
                assert_eq!(*v, w.positions[id as usize]);
            }
        }
    }
}
