//! Secondary boundary terms: discontinuities seen from path vertices (shadows of moving objects for direct
//! light, the same edges deeper in the path for indirect light, and, for vertices riding on a moving object,
//! every edge of the scene, emitter borders included). At a path vertex x the scattering integral
//! ∫ f(ω) cos L_in(ω) dω jumps across the directions of silhouette edges and of shading creases as seen from x
//! (the interior replay holds directions fixed, so creases count, as for the camera); when an edge moves
//! relative to x, the integral changes by
//!     ∫_edge [h(ω⁻) − h(ω⁺)] (dω_e/dθ · n̂) dℓ,     h = f · cos · L_in,
//! where ω_e is the edge point's direction, n̂ the unit normal of the edge's arc on the sphere of directions and
//! dℓ its arc length. We pick one silhouette edge with probability proportional to its approximate arc length,
//! a point uniformly along it, and estimate L_in on both sides with two paths sharing their random numbers.
//! Every vertex that scatters gets these samples, so shadows (direct) and occluders seen after bounces
//! (indirect) are both covered, to the path's full depth. Vertices on turning surfaces with shading normals
//! also get samples of their moving horizon (`horizon_boundary`).

use crate::grad::boundary::edge_tree::EdgeTree;
use crate::grad::boundary::horizon::{face_normal_velocity, has_horizon_jump, horizon_boundary, HorizonVertex};
use crate::grad::boundary::mesh_edges::{mesh_edges, MeshEdge};
use crate::grad::path::record::{record_from, PathRecord};
use crate::grad::path::velocity::PoseLayout;
use crate::render::bsdf::bsdf_eval;
use crate::render::layout::FrameParams;
use crate::render::sampler::Sampler;
use crate::render::shading::{offset_origin, surface_point};
use crate::render::SceneData;
use crate::scene::Scene;
use glam::Vec3;

/// Angular offset of the two side directions from an edge (radians).
const SIDE_EPS: f32 = 1e-4;
/// Seed tweaks separating secondary edge and horizon samples from pixel samples.
const SECONDARY_SEED: u32 = 0xbb67_ae85;
const HORIZON_SEED: u32 = 0x3c6e_f372;

/// All welded mesh edges, those of moving objects first (built once per scene and pose set). A vertex on a
/// static surface sees only moving edges move; a vertex riding on a moving object sees every edge move
/// relative to itself.
pub struct SecondaryEdges {
    edges: Vec<MeshEdge>,
    moving: usize,
    /// Culling trees over the moving edges and over the others.
    moving_tree: EdgeTree,
    static_tree: EdgeTree,
}

impl SecondaryEdges {
    pub fn build(scene: &Scene, moving: impl Fn(u32) -> bool) -> SecondaryEdges {
        let mut edges = mesh_edges(scene, &moving);
        let n = edges.len();
        edges.extend(mesh_edges(scene, |o| !moving(o)));
        let (moving_tree, static_tree) = (EdgeTree::build(&edges[..n], 0), EdgeTree::build(&edges[n..], n));
        SecondaryEdges { edges, moving: n, moving_tree, static_tree }
    }

    pub fn is_empty(&self) -> bool {
        self.moving == 0
    }
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
    let mut sub = PathRecord::default();
    let (mut weights, mut chosen, mut stack) = (vec![], vec![], vec![]);
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
                horizon_boundary(d, &sub_fp, &hv, sampler, count, &mut sub, grad);
            }
        }
        // Candidate edges and their approximate arc lengths on the sphere around p (upper hemisphere only).
        weights.clear();
        chosen.clear();
        let mut total = 0.0f32;
        // A vertex moves when its triangle or any earlier vertex does (ray form).
        let x_moves = path.velocities[..path.active.len()].iter().any(|v| v[k] != Vec3::ZERO);
        let mut weigh = |i: usize| {
            let e = &edges.edges[i];
            let above = sp.ng.dot(e.a - sp.p) > 0.0 || sp.ng.dot(e.b - sp.p) > 0.0;
            let creased = e.is_crease() && e.faces.iter().all(|f| f.normal.dot(sp.p - e.a) > 0.0);
            if above && (e.is_silhouette_from(sp.p) || creased) {
                let mid = 0.5 * (e.a + e.b) - sp.p;
                let r = mid.length();
                let om = mid / r;
                let ab = e.b - e.a;
                let w = (ab - om * om.dot(ab)).length() / r;
                if w > 0.0 {
                    total += w;
                    weights.push(total);
                    chosen.push(i);
                }
            }
        };
        edges.moving_tree.visit(sp.p, sp.ng, &mut stack, &mut weigh);
        if x_moves {
            edges.static_tree.visit(sp.p, sp.ng, &mut stack, &mut weigh);
        }
        if total.is_nan() || total <= 0.0 {
            continue;
        }
        for j in 0..count {
            let es =
                Sampler { seed: s.seed ^ SECONDARY_SEED, pixel: s.pixel, sample: s.sample * 4096 + k as u32 * 64 + j };
            let target = es.get(0) * total;
            let ei = weights.partition_point(|&c| c <= target).min(weights.len() - 1);
            let e = &edges.edges[chosen[ei]];
            let p_edge = (weights[ei] - if ei == 0 { 0.0 } else { weights[ei - 1] }) / total;
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
            let mut side = |sign: f32| {
                let w = (om + n_hat * (sign * SIDE_EPS)).normalize();
                let f = bsdf_eval(&sp.bsdf, wi, sp.to_local(w));
                if f == Vec3::ZERO {
                    return Vec3::ZERO;
                }
                record_from(d, &sub_fp, &es, offset_origin(sp.p, sp.ng, w), w, &mut sub);
                f * sub.radiance()
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
