//! Secondary boundary terms: discontinuities seen from path vertices (shadows of moving objects for direct
//! light, the same edges deeper in the path for indirect light, and, for vertices riding on a moving object,
//! every edge of the scene, emitter borders included). At a path vertex x the scattering integral
//! ∫ f(ω) cos L_in(ω) dω jumps across the directions of silhouette edges and of shading creases as seen from x
//! (the interior replay holds directions fixed, so creases count, as for the camera); when an edge moves
//! relative to x, the integral changes by
//!     ∫_edge [h(ω⁻) − h(ω⁺)] (dω_e/dθ · n̂) dℓ,     h = f · cos · L_in,
//! where ω_e is the edge point's direction, n̂ the unit normal of the edge's arc on the sphere of directions and
//! dℓ its arc length. We draw one edge by descending the edge tree (`EdgeTree::sample`: children by total edge
//! length over distance, then the leaf's edges by their approximate arc length, both weighted by the edge's
//! strength: 1 for silhouettes, the normals' difference for creases, at least 0.02; zero for edges that cannot be
//! a silhouette or crease from x; a draw costs the tree's depth, not the edge count, which matters for furniture
//! whose flat faces make every edge a crease), a point uniformly along it, and estimate L_in on both sides with
//! two paths sharing their random numbers.
//! Every vertex that scatters gets these samples, so shadows (direct) and occluders seen after bounces
//! (indirect) are both covered, to the path's full depth, except one part sampled from the lights instead
//! (boundary/shadow.rs): at the first two vertices, the radiance emitted at the side paths' first hits across
//! edges of moving, non-emitting objects (`light_side_vertex`, `SecondaryEdges::leaves_emission`). Vertices
//! on turning surfaces with shading normals also get samples of their moving horizon (`horizon_boundary`).

use crate::grad::boundary::edge_tree::EdgeTree;
use crate::grad::boundary::horizon::{face_normal_velocity, has_horizon_jump, horizon_boundary, HorizonVertex};
use crate::grad::boundary::mesh_edges::{mesh_edges, EdgeShape, MeshEdge};
use crate::grad::path::record::PathRecord;
use crate::grad::path::velocity::PoseLayout;
use crate::render::bsdf::bsdf_eval;
use crate::render::bvh::trace_occluded;
use crate::render::layout::FrameParams;
use crate::render::path_trace::trace_from;
use crate::render::sampler::Sampler;
use crate::render::shading::{offset_origin, surface_point};
use crate::render::SceneData;
use crate::scene::Scene;
use glam::Vec3;

/// Angular offset of the two side directions from an edge (radians).
const SIDE_EPS: f32 = 1e-4;
/// The part of the way to an edge point that must be clear for the edge to count as seen from x (the rest
/// belongs to the edge's own faces).
const HIDDEN_MARGIN: f32 = 1e-3;
/// Seed tweaks separating secondary edge and horizon samples from pixel samples.
const SECONDARY_SEED: u32 = 0xbb67_ae85;
const HORIZON_SEED: u32 = 0x3c6e_f372;

/// All welded mesh edges, those of moving objects first (built once per scene and pose set). A vertex on a
/// static surface sees only moving edges move; a vertex riding on a moving object sees every edge move
/// relative to itself.
pub struct SecondaryEdges {
    edges: Vec<MeshEdge>,
    /// `edges` packed for the draws' weights.
    shapes: Vec<EdgeShape>,
    moving: usize,
    /// Culling trees over the moving edges and over the others.
    moving_tree: EdgeTree,
    static_tree: EdgeTree,
    /// Per object: it emits (its edges' shadows stay with this estimator; see `leaves_emission`).
    emitting: Vec<bool>,
    /// Some moving edge belongs to an emitting object.
    moving_emits: bool,
}

impl SecondaryEdges {
    /// The edges of the scene for the pose layout's moving objects.
    pub fn build(scene: &Scene, pose: &PoseLayout) -> SecondaryEdges {
        let moving = |o: u32| pose.moves(o);
        let mut edges = mesh_edges(scene, moving);
        let n = edges.len();
        edges.extend(mesh_edges(scene, |o| !moving(o)));
        let (moving_tree, static_tree) = (EdgeTree::build(&edges[..n], 0), EdgeTree::build(&edges[n..], n));
        let emitting: Vec<bool> = scene.objects.iter().map(|o| o.emitter.is_some()).collect();
        let shapes = edges.iter().map(EdgeShape::of).collect();
        let moving_emits = edges[..n].iter().any(|e| emitting[e.object as usize]);
        SecondaryEdges { edges, shapes, moving: n, moving_tree, static_tree, emitting, moving_emits }
    }

    pub fn is_empty(&self) -> bool {
        self.moving == 0
    }

    /// True when the radiance emitted at the side rays' first hits is left to the light-side shadow estimator
    /// (boundary/shadow.rs) for edge `i` seen from a vertex `light_side_vertex` accepts: edges of moving
    /// objects that do not emit.
    pub fn leaves_emission(&self, i: usize, light_side: bool) -> bool {
        light_side && i < self.moving && !self.emitting[self.edges[i].object as usize]
    }

    /// Some moving edge's emitted jumps stay with this estimator everywhere (it belongs to an emitter).
    pub fn moving_emits(&self) -> bool {
        self.moving_emits
    }

    /// The edges and trees as the GPU reads them (shaders/grad/boundary/secondary.glsl).
    pub fn gpu_words(&self) -> SecondaryWords {
        let mut edges = Vec::with_capacity(self.edges.len() * MESH_EDGE_WORDS);
        for (i, (e, sh)) in self.edges.iter().zip(&self.shapes).enumerate() {
            edges.extend(sh.a.to_array().map(f32::to_bits));
            edges.push(e.object);
            edges.extend(sh.b.to_array().map(f32::to_bits));
            let light_side = self.leaves_emission(i, true);
            edges.push(u32::from(sh.two_faces) | (u32::from(sh.crease) << 1) | (u32::from(light_side) << 2));
            edges.extend(sh.n1.to_array().map(f32::to_bits));
            edges.push(sh.strength.to_bits());
            edges.extend(sh.n2.to_array().map(f32::to_bits));
            edges.extend([e.ends[0], e.ends[1], 0, 0, 0]);
        }
        let (mut nodes, mut order) = (vec![], vec![]);
        let moving_root = self.moving_tree.append_gpu_words(&mut nodes, &mut order);
        let static_root = self.static_tree.append_gpu_words(&mut nodes, &mut order);
        let moving = self.moving as u32;
        SecondaryWords { edges, nodes, order, moving_root, static_root, moving, moving_emits: self.moving_emits }
    }
}

/// Words per edge in `SecondaryEdges::gpu_words`: a, object, b, flags (1 two faces, 2 crease, 4 seen from
/// vertices light_side_vertex accepts, the emitted part of its jump is the light-side estimator's), the first face's
/// normal, strength, the second face's normal, the ends' welded ids, unused.
pub const MESH_EDGE_WORDS: usize = 20;

/// `SecondaryEdges` as words for the GPU; roots are NONE for an empty tree.
pub struct SecondaryWords {
    pub edges: Vec<u32>,
    pub nodes: Vec<u32>,
    pub order: Vec<u32>,
    pub moving_root: u32,
    pub static_root: u32,
    pub moving: u32,
    pub moving_emits: bool,
}

/// Whether the light-side estimator (boundary/shadow.rs) samples the direct shadows of moving edges seen at
/// vertex `k` of a camera path: the camera's own hits and the vertices after them.
pub fn light_side_vertex(k: usize) -> bool {
    k <= 1
}

/// One recorded camera path and what the boundary sampler needs with it.
pub struct SecondaryPath<'a> {
    pub rec: &'a PathRecord,
    /// The pose entries that move the path's triangles; the path stands still for all others.
    pub active: &'a [usize],
    /// dx_k/dθ of each vertex for each active pose entry, in the order of `active` (ray-form vertices slide
    /// along their rays).
    pub velocities: &'a [Vec<Vec3>],
    pub sampler: &'a Sampler,
    /// The pixel's adjoint divided by spp.
    pub delta: Vec3,
}

/// Adds the secondary boundary contributions of one recorded path to `grad`, with `count` edge samples per
/// scattering vertex.
pub fn secondary_boundary(
    d: &SceneData,
    fp: &FrameParams,
    pose: &PoseLayout,
    edges: &SecondaryEdges,
    path: &SecondaryPath,
    count: u32,
    grad: &mut [f64],
) {
    let (rec, s, delta) = (path.rec, path.sampler, path.delta);
    if edges.is_empty() {
        return;
    }
    let mut moving = Vec::with_capacity(path.active.len() + 8);
    let mut turning = Vec::with_capacity(path.active.len());
    let mut prev_p = rec.origin;
    for (k, v) in rec.vertices.iter().enumerate() {
        let tri = &d.triangles[v.triangle as usize];
        let p = Vec3::from(tri.v0) + Vec3::from(tri.e1) * v.u + Vec3::from(tri.e2) * v.v;
        let incoming = if k == 0 { rec.dir } else { (p - prev_p).normalize() };
        prev_p = p;
        // Only vertices that scatter (the primal stops before the last allowed vertex).
        if k as u32 + 1 >= fp.max_depth {
            break;
        }
        let sp = surface_point(d, v.triangle, v.u, v.v, incoming);
        let wi = sp.to_local(-incoming);
        let sub_fp = FrameParams {
            max_depth: fp.max_depth - (k as u32 + 1),
            rr_depth: fp.rr_depth.saturating_sub(k as u32 + 1),
            ..*fp
        };
        let a = delta * v.throughput;
        if has_horizon_jump(d, v.triangle) {
            turning.clear();
            for &i in path.active {
                let dn = face_normal_velocity(d, pose, v.triangle, i, sp.ng);
                if dn != Vec3::ZERO {
                    turning.push((pose.entries[i].2, dn));
                }
            }
            if !turning.is_empty() {
                let hv = HorizonVertex { sp: &sp, wi, turning: &turning, adjoint: a };
                let sampler = |j| Sampler {
                    seed: s.seed ^ HORIZON_SEED,
                    pixel: s.pixel,
                    sample: s.sample * 4096 + k as u32 * 64 + j,
                };
                horizon_boundary(d, &sub_fp, &hv, sampler, count, grad);
            }
        }
        // A vertex moves when its triangle or any earlier vertex does (ray form); then every edge moves
        // relative to it, else only the moving ones.
        let x_moves = path.velocities[..path.active.len()].iter().any(|v| v[k] != Vec3::ZERO);
        // The exact weight of an edge: its approximate arc length on the sphere around p times its strength,
        // zero unless it can be a silhouette or a crease seen from p above its tangent plane.
        let weight = |i: usize| {
            let e = &edges.shapes[i];
            let above = sp.ng.dot(e.a - sp.p) > 0.0 || sp.ng.dot(e.b - sp.p) > 0.0;
            let creased = e.crease && e.n1.dot(sp.p - e.a) > 0.0 && e.n2.dot(sp.p - e.a) > 0.0;
            let silhouette = e.is_silhouette_from(sp.p);
            if !(above && (silhouette || creased)) {
                return 0.0;
            }
            let mid = 0.5 * (e.a + e.b) - sp.p;
            let r = mid.length();
            let om = mid / r;
            let ab = e.b - e.a;
            // A silhouette hides what is behind it; a crease only changes the shading, in proportion to how
            // much its faces' normals differ.
            let strength = if silhouette { 1.0 } else { e.strength };
            let w = (ab - om * om.dot(ab)).length() / r * strength;
            if w.is_finite() {
                w
            } else {
                0.0
            }
        };
        // Where the side paths end at their first hits (only emission left) and the light-side estimator owns
        // what moving edges change there, only static edges are left to sample (when x moves).
        let light_side = light_side_vertex(k);
        let moving_left = light_side && sub_fp.max_depth <= 1 && !edges.moving_emits();
        // The trees to draw from, by their importance from p.
        let wm = if moving_left { 0.0 } else { edges.moving_tree.root_importance(sp.p, sp.ng) };
        let ws = if x_moves { edges.static_tree.root_importance(sp.p, sp.ng) } else { 0.0 };
        // (NaN importances, from degenerate edges, count as nothing to draw.)
        if (wm + ws).is_nan() || wm + ws <= 0.0 {
            continue;
        }
        let p_moving = wm / (wm + ws);
        for j in 0..count {
            let es =
                Sampler { seed: s.seed ^ SECONDARY_SEED, pixel: s.pixel, sample: s.sample * 4096 + k as u32 * 64 + j };
            let u = es.get(0) as f64;
            let drawn = if u < p_moving as f64 {
                edges.moving_tree.sample(sp.p, sp.ng, u / p_moving as f64, weight).map(|(e, p)| (e, p * p_moving))
            } else {
                let u = ((u - p_moving as f64) / (1.0 - p_moving as f64)).min(1.0 - f64::EPSILON);
                edges.static_tree.sample(sp.p, sp.ng, u, weight).map(|(e, p)| (e, p * (1.0 - p_moving)))
            };
            let Some((edge, p_edge)) = drawn else { continue };
            if p_edge.is_nan() || p_edge <= 0.0 {
                continue;
            }
            let e = &edges.edges[edge];
            let t = es.get(1);
            let q = e.a + (e.b - e.a) * t;
            let to = q - sp.p;
            let r = to.length();
            if r.is_nan() || r <= 0.0 {
                continue;
            }
            let om = to / r;
            let ab = e.b - e.a;
            let tau = (ab - om * om.dot(ab)) / r; // dω/dt along the edge
            let n_hat = om.cross(tau);
            let n_len = n_hat.length();
            if n_len.is_nan() || n_len <= 0.0 {
                continue;
            }
            let n_hat = n_hat / n_len;
            // An edge point hidden from x (something closer along the ray) has both sides see the occluder: no
            // jump to estimate, so its two side paths are not traced (one shadow ray instead).
            let o = offset_origin(sp.p, sp.ng, om);
            if trace_occluded(&d.nodes, &d.triangles, o, om, (q - o).length() * (1.0 - HIDDEN_MARGIN)) {
                continue;
            }
            let leave_emission = edges.leaves_emission(edge, light_side);
            let side = |sign: f32| {
                let w = (om + n_hat * (sign * SIDE_EPS)).normalize();
                let f = bsdf_eval(&sp.bsdf, wi, sp.to_local(w));
                if f == Vec3::ZERO {
                    return Vec3::ZERO;
                }
                let l = trace_from(d, &sub_fp, &es, offset_origin(sp.p, sp.ng, w), w, &mut ());
                f * if leave_emission { l.radiance - l.first_emission } else { l.radiance }
            };
            let jump = side(-1.0) - side(1.0);
            if jump == Vec3::ZERO {
                continue;
            }
            let scale = a.dot(jump) * tau.length() / (p_edge * count as f32);
            // Entries that move x or the edge point.
            moving.clear();
            moving.extend_from_slice(path.active);
            pose.entries_moving(e.object, &e.ends, &mut moving);
            let site = [(e.ends[0], 1.0 - t), (e.ends[1], t)];
            for (j, &i) in moving.iter().enumerate() {
                let (o, comp, at) = pose.entries[i];
                // Velocity of the edge point (a material point) relative to x (a sliding ray-form vertex).
                let edge_velocity = if e.object == o { pose.velocity(o, comp, q, &site) } else { Vec3::ZERO };
                let x_velocity = if j < path.active.len() { path.velocities[j][k] } else { Vec3::ZERO };
                let rel = edge_velocity - x_velocity;
                if rel == Vec3::ZERO {
                    continue;
                }
                let v_dir = (rel - om * om.dot(rel)) / r;
                grad[at] += (scale * v_dir.dot(n_hat)) as f64;
            }
        }
    }
}
