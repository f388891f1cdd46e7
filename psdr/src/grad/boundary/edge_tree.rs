//! A bounding volume hierarchy over mesh edges with cones of their faces' normals, so that a path vertex finds
//! the edges that can be silhouettes or shading creases from it without visiting every edge of the scene
//! (a furniture mesh has tens of thousands). Culling is conservative: every edge the exact tests in
//! `secondary_edges` would keep is visited, so the edge distribution built from the visited ones is the same.

use crate::grad::boundary::mesh_edges::MeshEdge;
use glam::Vec3;
use obvhs::bvh2::node::Bvh2Node as BvhNode;
use obvhs::{aabb::Aabb, bvh2::builder::build_bvh2, BvhBuildParams};
use std::time::Duration;

/// The faces' normals below a node: every normal n satisfies |n − axis| ≤ spread.
#[derive(Clone, Copy, Debug)]
struct Cone {
    axis: Vec3,
    spread: f32,
    /// Some edge below is a mesh boundary or non-manifold (a silhouette from everywhere).
    boundary: bool,
    /// Some edge below is a shading crease (kept wherever its faces face the vertex).
    crease: bool,
}

pub struct EdgeTree {
    nodes: Vec<BvhNode>,
    cones: Vec<Cone>,
    /// Edge index (into the slice the tree was built over, plus `offset`) of each leaf slot.
    order: Vec<u32>,
}

impl EdgeTree {
    /// The tree over `edges`; visited indices are `offset + position in edges`.
    pub fn build(edges: &[MeshEdge], offset: usize) -> EdgeTree {
        if edges.is_empty() {
            return EdgeTree { nodes: vec![], cones: vec![], order: vec![] };
        }
        let aabbs: Vec<Aabb> = edges.iter().map(|e| Aabb::new(e.a.min(e.b).into(), e.a.max(e.b).into())).collect();
        let bvh = build_bvh2(&aabbs, BvhBuildParams::medium_build(), &mut Duration::default());
        let order: Vec<u32> = bvh.primitive_indices.iter().map(|&i| i + offset as u32).collect();
        // Post-order (children before parents), then each node's cone from its edges or its children's cones.
        let mut post = Vec::with_capacity(bvh.nodes.len());
        let mut stack = vec![(0u32, false)];
        while let Some((i, children_done)) = stack.pop() {
            let n = &bvh.nodes[i as usize];
            if children_done || n.prim_count > 0 {
                post.push(i as usize);
            } else {
                stack.push((i, true));
                stack.push((n.first_index + 1, false));
                stack.push((n.first_index, false));
            }
        }
        let empty = Cone { axis: Vec3::ZERO, spread: 0.0, boundary: false, crease: false };
        let mut cones = vec![empty; bvh.nodes.len()];
        let mut sums = vec![Vec3::ZERO; bvh.nodes.len()];
        for i in post {
            let n = &bvh.nodes[i];
            if n.prim_count > 0 {
                let slots = &bvh.primitive_indices[n.first_index as usize..(n.first_index + n.prim_count) as usize];
                let below = || slots.iter().map(|&s| &edges[s as usize]);
                let normals = || below().flat_map(|e| e.faces.iter().map(|f| f.normal));
                sums[i] = normals().sum();
                let axis = sums[i].normalize_or_zero();
                let spread = normals().map(|n| (n - axis).length()).fold(0.0, f32::max);
                let boundary = below().any(|e| e.faces.len() != 2);
                cones[i] = Cone { axis, spread, boundary, crease: below().any(MeshEdge::is_crease) };
            } else {
                let (l, r) = (n.first_index as usize, n.first_index as usize + 1);
                sums[i] = sums[l] + sums[r];
                let axis = sums[i].normalize_or_zero();
                // |n − axis| ≤ |n − axis_child| + |axis_child − axis|.
                let spread =
                    [l, r].map(|c| cones[c].spread + (cones[c].axis - axis).length()).into_iter().fold(0.0, f32::max);
                let (cl, cr) = (cones[l], cones[r]);
                cones[i] = Cone { axis, spread, boundary: cl.boundary || cr.boundary, crease: cl.crease || cr.crease };
            }
            // Rounding slack; a zero axis (normals cancelling) leaves every direction possible.
            cones[i].spread = if cones[i].axis == Vec3::ZERO { 2.0 } else { cones[i].spread * (1.0 + 1e-5) + 1e-6 };
        }
        EdgeTree { nodes: bvh.nodes, cones, order }
    }

    /// Calls `visit(edge index)` for every edge except those that provably lie below the plane through `x` with
    /// normal `ng`, or can be neither a silhouette nor a crease seen from `x`.
    pub fn visit(&self, x: Vec3, ng: Vec3, stack: &mut Vec<u32>, mut visit: impl FnMut(usize)) {
        if self.nodes.is_empty() {
            return;
        }
        stack.clear();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i as usize];
            let (lo, hi) = (n.min, n.max);
            // Entirely below the tangent plane: no endpoint above it.
            if ng.dot(x) > max_dot(ng, lo, hi) + 1e-5 * (1.0 + x.abs().max_element()) {
                continue;
            }
            // The sign of n·(x − p) over faces below: |n − axis| ≤ spread, p in the box.
            let c = &self.cones[i as usize];
            let reach = (x - lo).abs().max((x - hi).abs()).length() * c.spread;
            let (lower, upper) = (c.axis.dot(x) - max_dot(c.axis, lo, hi), c.axis.dot(x) - min_dot(c.axis, lo, hi));
            let slack = 1e-5 * (1.0 + x.abs().max_element());
            let all_back = upper + reach < -slack;
            let all_front = lower - reach > slack;
            if (all_back && !c.boundary) || (all_front && !c.boundary && !c.crease) {
                continue;
            }
            if n.prim_count > 0 {
                for slot in n.first_index..n.first_index + n.prim_count {
                    visit(self.order[slot as usize] as usize);
                }
            } else {
                stack.push(n.first_index + 1);
                stack.push(n.first_index);
            }
        }
    }
}

/// max over the box of a·p.
fn max_dot(a: Vec3, lo: Vec3, hi: Vec3) -> f32 {
    (a * lo).max(a * hi).element_sum()
}

/// min over the box of a·p.
fn min_dot(a: Vec3, lo: Vec3, hi: Vec3) -> f32 {
    (a * lo).min(a * hi).element_sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grad::boundary::mesh_edges::mesh_edges;
    use crate::render::sampler::Sampler;
    use crate::scene::{load_scene, sphere_mesh, Object, Pose};

    /// Every edge the exact tests keep (an endpoint above the plane; a silhouette, or a crease whose faces both
    /// face x) is visited, for random points and planes around the example room with a finely tessellated
    /// sphere added (smooth, so most edges are culled), and culling actually removes most edges.
    #[test]
    fn visits_every_edge_the_exact_test_keeps() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/room/scene.json");
        let mut scene = load_scene(std::path::Path::new(path)).unwrap();
        let pose = Pose { translation: Vec3::new(0.3, 1.0, -0.5), ..Pose::default() };
        let mut ball = sphere_mesh(0.3, 24, 48, false);
        ball.material = 0;
        scene.objects.push(Object { name: "ball".into(), parts: vec![ball], pose, emitter: None });
        let edges = mesh_edges(&scene, |_| true);
        let tree = EdgeTree::build(&edges, 0);
        let (mut stack, mut visited_total, mut kept_total) = (vec![], 0usize, 0usize);
        for k in 0..200 {
            let s = Sampler { seed: 7, pixel: k, sample: 0 };
            let x = Vec3::new(4.0 * s.get(0) - 2.0, 2.6 * s.get(1), 5.0 * s.get(2) - 2.5);
            let ng = Vec3::new(s.get(3) - 0.5, s.get(4) - 0.5, s.get(5) - 0.5).normalize();
            let mut visited = vec![false; edges.len()];
            tree.visit(x, ng, &mut stack, |i| visited[i] = true);
            for (i, e) in edges.iter().enumerate() {
                let above = ng.dot(e.a - x) > 0.0 || ng.dot(e.b - x) > 0.0;
                let creased = e.is_crease() && e.faces.iter().all(|f| f.normal.dot(x - e.a) > 0.0);
                if above && (e.is_silhouette_from(x) || creased) {
                    assert!(visited[i], "edge {i} kept by the exact test but culled (x {x}, ng {ng})");
                    kept_total += 1;
                }
            }
            visited_total += visited.iter().filter(|&&v| v).count();
        }
        eprintln!("visited {visited_total}, kept {kept_total}, of {} per point x 200", edges.len());
        assert!(kept_total > 0);
        assert!(visited_total * 3 < edges.len() * 200, "culling must remove most edges: {visited_total}");
    }
}
