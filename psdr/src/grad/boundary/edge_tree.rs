//! A bounding volume hierarchy over mesh edges with cones of their faces' normals and the edges' total length,
//! so that a path vertex draws an edge that can be a silhouette or a shading crease from it without visiting
//! every edge of the scene (a furniture mesh has tens of thousands, and between flat faces every edge is a
//! crease, so culling alone leaves thousands): `sample` descends the tree by importance (length over distance,
//! zero where culled) in the tree's depth; `visit` enumerates what culling keeps. Culling is conservative:
//! every edge the exact tests in boundary/secondary.rs keep is visited, and has a positive probability.

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

/// The most edges in one leaf (the descent weighs a leaf's edges once, into a buffer of this size).
pub const LEAF_EDGES: usize = 8;

/// Words per node in `EdgeTree::append_gpu_words`.
pub const NODE_WORDS: usize = 16;

pub struct EdgeTree {
    nodes: Vec<BvhNode>,
    cones: Vec<Cone>,
    /// Total length of the edges below each node, each times its `strength` (the importance's numerator).
    lengths: Vec<f32>,
    /// Edge index (into the slice the tree was built over, plus `offset`) of each leaf slot.
    order: Vec<u32>,
}

impl EdgeTree {
    /// The tree over `edges`; visited indices are `offset + position in edges`.
    pub fn build(edges: &[MeshEdge], offset: usize) -> EdgeTree {
        if edges.is_empty() {
            return EdgeTree { nodes: vec![], cones: vec![], lengths: vec![], order: vec![] };
        }
        let aabbs: Vec<Aabb> = edges.iter().map(|e| Aabb::new(e.a.min(e.b).into(), e.a.max(e.b).into())).collect();
        let params = BvhBuildParams { max_prims_per_leaf: LEAF_EDGES as u32, ..BvhBuildParams::medium_build() };
        let bvh = build_bvh2(&aabbs, params, &mut Duration::default());
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
        let mut lengths = vec![0.0f32; bvh.nodes.len()];
        for i in post {
            let n = &bvh.nodes[i];
            if n.prim_count > 0 {
                let slots = &bvh.primitive_indices[n.first_index as usize..(n.first_index + n.prim_count) as usize];
                let below = || slots.iter().map(|&s| &edges[s as usize]);
                lengths[i] = below().map(|e| (e.b - e.a).length() * e.strength()).sum();
                let normals = || below().flat_map(|e| e.faces.iter().map(|f| f.normal));
                sums[i] = normals().sum();
                let axis = sums[i].normalize_or_zero();
                let spread = normals().map(|n| (n - axis).length()).fold(0.0, f32::max);
                let boundary = below().any(|e| e.faces.len() != 2);
                cones[i] = Cone { axis, spread, boundary, crease: below().any(MeshEdge::is_crease) };
            } else {
                let (l, r) = (n.first_index as usize, n.first_index as usize + 1);
                sums[i] = sums[l] + sums[r];
                lengths[i] = lengths[l] + lengths[r];
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
        EdgeTree { nodes: bvh.nodes, cones, lengths, order }
    }

    /// True when no edge below node `i` can be kept by the exact tests seen from `x` (plane normal `ng`): all
    /// below the tangent plane, or on faces all facing away from x (and no boundary) or all facing it (and no
    /// boundary or crease). Conservative: an edge the exact tests keep never lies under a culled node.
    fn culled(&self, i: usize, x: Vec3, ng: Vec3) -> bool {
        let n = &self.nodes[i];
        let (lo, hi) = (n.min, n.max);
        let slack = 1e-5 * (1.0 + x.abs().max_element());
        // Entirely below the tangent plane: no endpoint above it.
        if ng.dot(x) > max_dot(ng, lo, hi) + slack {
            return true;
        }
        // The sign of n·(x − p) over faces below: |n − axis| ≤ spread, p in the box.
        let c = &self.cones[i];
        let reach = (x - lo).abs().max((x - hi).abs()).length() * c.spread;
        let (lower, upper) = (c.axis.dot(x) - max_dot(c.axis, lo, hi), c.axis.dot(x) - min_dot(c.axis, lo, hi));
        let all_back = upper + reach < -slack;
        let all_front = lower - reach > slack;
        (all_back && !c.boundary) || (all_front && !c.boundary && !c.crease)
    }

    /// How much node `i` is worth sampling from x: the strength-weighted length of its edges over their distance
    /// (the arc length they would span, roughly, as strong as they are), with the distance kept above a quarter of the node's size (x inside
    /// or next to the box); zero when culled.
    fn importance(&self, i: usize, x: Vec3, ng: Vec3) -> f32 {
        if self.culled(i, x, ng) {
            return 0.0;
        }
        let n = &self.nodes[i];
        let (lo, hi) = (n.min, n.max);
        let outside = (lo - x).max(x - hi).max(Vec3::ZERO).length();
        self.lengths[i] / outside.max(0.25 * (hi - lo).length()).max(1e-6)
    }

    /// The whole tree's importance from x (to choose between trees).
    /// The tree as the GPU reads it (shaders/grad/boundary/edge_tree.glsl), appended to `nodes` (NODE_WORDS a
    /// node: min, first index, max, primitive count, cone axis, spread, flags 1 boundary / 2 crease, length)
    /// and `order` (edge indices), child and leaf indices made global; returns the root's index, or NONE.
    pub fn append_gpu_words(&self, nodes: &mut Vec<u32>, order: &mut Vec<u32>) -> u32 {
        if self.nodes.is_empty() {
            return u32::MAX;
        }
        let (node_base, order_base) = ((nodes.len() / NODE_WORDS) as u32, order.len() as u32);
        for (i, n) in self.nodes.iter().enumerate() {
            let c = &self.cones[i];
            let first = if n.prim_count > 0 { n.first_index + order_base } else { n.first_index + node_base };
            let flags = u32::from(c.boundary) | (u32::from(c.crease) << 1);
            nodes.extend(n.min.to_array().map(f32::to_bits));
            nodes.push(first);
            nodes.extend(n.max.to_array().map(f32::to_bits));
            nodes.push(n.prim_count);
            nodes.extend(c.axis.to_array().map(f32::to_bits));
            nodes.push(c.spread.to_bits());
            nodes.extend([flags, self.lengths[i].to_bits(), 0, 0]);
        }
        order.extend_from_slice(&self.order);
        node_base
    }

    pub fn root_importance(&self, x: Vec3, ng: Vec3) -> f32 {
        if self.nodes.is_empty() {
            0.0
        } else {
            self.importance(0, x, ng)
        }
    }

    /// Draws one edge for a vertex at `x` (tangent plane normal `ng`) by descending the tree: at each inner node
    /// a child with probability proportional to its `importance`, at the leaf one of its edges with probability
    /// proportional to `weight(edge index)` (the exact weight: zero for edges that cannot contribute). `u` in
    /// [0, 1) is rescaled at each choice. Returns the edge and the probability of having drawn it, or None when
    /// the descent ends where nothing contributes (no sample, unbiased: those edges' contributions are zero).
    /// Every edge the exact tests keep has a positive probability (culling is conservative), and a draw costs
    /// the tree's depth, not the number of edges.
    pub fn sample(&self, x: Vec3, ng: Vec3, mut u: f64, weight: impl Fn(usize) -> f32) -> Option<(usize, f32)> {
        if self.nodes.is_empty() {
            return None;
        }
        let (mut i, mut p) = (0usize, 1.0f64);
        loop {
            let n = &self.nodes[i];
            if n.prim_count > 0 {
                // Each edge's weight once (the weight is the costly part of a draw).
                let first = n.first_index as usize;
                let mut w = [0.0f64; LEAF_EDGES];
                let mut total = 0.0;
                for (j, wj) in w.iter_mut().enumerate().take(n.prim_count as usize) {
                    *wj = weight(self.order[first + j] as usize) as f64;
                    total += *wj;
                }
                if total.is_nan() || total <= 0.0 {
                    return None;
                }
                let mut acc = 0.0;
                let mut last = None;
                for (j, &wj) in w.iter().enumerate().take(n.prim_count as usize) {
                    if wj <= 0.0 {
                        continue;
                    }
                    last = Some((self.order[first + j] as usize, wj));
                    acc += wj;
                    if u * total < acc {
                        break;
                    }
                }
                let (e, w) = last?;
                return Some((e, (p * w / total) as f32));
            }
            let (l, r) = (n.first_index as usize, n.first_index as usize + 1);
            let (wl, wr) = (self.importance(l, x, ng) as f64, self.importance(r, x, ng) as f64);
            if (wl + wr).is_nan() || wl + wr <= 0.0 {
                return None;
            }
            let pl = wl / (wl + wr);
            if u < pl {
                (i, p, u) = (l, p * pl, u / pl);
            } else {
                (i, p, u) = (r, p * (1.0 - pl), ((u - pl) / (1.0 - pl)).min(1.0 - f64::EPSILON));
            }
        }
    }

    /// Calls `visit(edge index)` for every edge except those that provably lie below the plane through `x` with
    /// normal `ng`, or can be neither a silhouette nor a crease seen from `x` (what `sample` can reach; the
    /// tests check culling against the exact tests with it).
    #[cfg(test)]
    pub fn visit(&self, x: Vec3, ng: Vec3, stack: &mut Vec<u32>, mut visit: impl FnMut(usize)) {
        if self.nodes.is_empty() {
            return;
        }
        stack.clear();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i as usize];
            if self.culled(i as usize, x, ng) {
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
    use crate::grad::boundary::mesh_edges::{example_room_with_ball, mesh_edges};
    use crate::render::sampler::Sampler;
    use crate::scene::load_scene;

    /// Every edge the exact tests keep (an endpoint above the plane; a silhouette, or a crease whose faces both
    /// face x) is visited, for random points and planes around the example room with a finely tessellated
    /// sphere added (smooth, so most edges are culled), and culling actually removes most edges.
    #[test]
    fn visits_every_edge_the_exact_test_keeps() {
        let scene = example_room_with_ball(24, 48, false);
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

    /// Every edge's probability of being drawn, by walking every branch of the descent.
    fn edge_probabilities(tree: &EdgeTree, x: Vec3, ng: Vec3, w: &dyn Fn(usize) -> f32, n: usize) -> Vec<f64> {
        let mut out = vec![0.0; n];
        let mut stack = vec![(0usize, 1.0f64)];
        while let Some((i, p)) = stack.pop() {
            let node = &tree.nodes[i];
            if node.prim_count > 0 {
                let slots = node.first_index as usize..(node.first_index + node.prim_count) as usize;
                let total: f64 = slots.clone().map(|s| w(tree.order[s] as usize) as f64).sum();
                for s in slots.filter(|_| total > 0.0) {
                    let e = tree.order[s] as usize;
                    out[e] += p * w(e) as f64 / total;
                }
                continue;
            }
            let (l, r) = (node.first_index as usize, node.first_index as usize + 1);
            let (wl, wr) = (tree.importance(l, x, ng) as f64, tree.importance(r, x, ng) as f64);
            if wl + wr > 0.0 {
                stack.push((l, p * wl / (wl + wr)));
                stack.push((r, p * wr / (wl + wr)));
            }
        }
        out
    }

    /// The draw is a proper distribution over the edges the exact tests keep: every kept edge has a positive
    /// probability (culling is conservative), the probabilities sum to at most 1, each draw states its edge's
    /// probability (the descent's, within f32 rounding), over a fine stratified grid of u each edge is drawn
    /// as often as its probability says (within 2 % where drawn often), and the estimate of Σ weight by
    /// weight(e) / p(e) matches the enumerated sum (unbiased; within 1 %).
    #[test]
    fn sampling_probabilities_are_the_draws_frequencies() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/room/scene.json");
        let scene = load_scene(std::path::Path::new(path)).unwrap();
        let edges = mesh_edges(&scene, |_| true);
        let tree = EdgeTree::build(&edges, 0);
        for k in 0..6 {
            let s = Sampler { seed: 11, pixel: k, sample: 0 };
            let x = Vec3::new(3.0 * s.get(0) - 1.5, 0.2 + 2.2 * s.get(1), 4.0 * s.get(2) - 2.0);
            let ng = Vec3::new(s.get(3) - 0.5, s.get(4) - 0.5, s.get(5) - 0.5).normalize();
            let w = |i: usize| {
                let e = &edges[i];
                let above = ng.dot(e.a - x) > 0.0 || ng.dot(e.b - x) > 0.0;
                let creased = e.is_crease() && e.faces.iter().all(|f| f.normal.dot(x - e.a) > 0.0);
                if above && (e.is_silhouette_from(x) || creased) {
                    (e.b - e.a).length() / (0.5 * (e.a + e.b) - x).length()
                } else {
                    0.0
                }
            };
            let exact = edge_probabilities(&tree, x, ng, &w, edges.len());
            let total: f64 = (0..edges.len()).map(|i| w(i) as f64).sum();
            assert!(exact.iter().sum::<f64>() <= 1.0 + 1e-9);
            for i in (0..edges.len()).filter(|&i| w(i) > 0.0) {
                assert!(exact[i] > 0.0, "point {k}: edge {i} is kept but cannot be drawn");
            }
            let n = 200_000;
            let mut hits = vec![0usize; edges.len()];
            let mut estimate = 0.0f64;
            for j in 0..n {
                if let Some((e, p)) = tree.sample(x, ng, (j as f64 + 0.5) / n as f64, w) {
                    assert!((p as f64 / exact[e] - 1.0).abs() < 1e-4, "edge {e}: states {p}, is {}", exact[e]);
                    hits[e] += 1;
                    estimate += w(e) as f64 / p as f64;
                }
            }
            estimate /= n as f64;
            assert!((estimate / total - 1.0).abs() < 0.01, "point {k}: estimate {estimate} vs sum {total}");
            for i in (0..edges.len()).filter(|&i| hits[i] >= 2000) {
                let freq = hits[i] as f64 / n as f64;
                assert!((freq / exact[i] - 1.0).abs() < 0.02, "edge {i}: drawn {freq}, probability {}", exact[i]);
            }
        }
    }
}
