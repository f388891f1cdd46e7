//! The direct-shadow part of the secondary boundary, sampled from the light: where a moving object's silhouette
//! crosses a light as seen from a camera-visible point x, the light's radiance jumps. The path-vertex estimator
//! (boundary/secondary.rs) draws these shadow edges from x by geometry alone and finds them rarely: on the
//! furnished room, the 0.3 % of its samples whose side ray reached the light held 97 % of its variance. Here
//! the three-dimensional integral (the image plane and the edge) is sampled the other way round: a point q on a
//! moving edge (by length times the share of directions from which the edge is a silhouette), a point y on a
//! light (as next-event estimation picks it), and x, the first surface the line from y through q reaches
//! beyond q, must be seen by the camera. Almost every such sample lands on a shadow boundary.
//! The estimator owns exactly this part: camera-visible vertices (k = 0; on moving objects too, sliding along
//! the camera ray), edges of moving objects that do not emit, and the jump of the radiance *emitted* at the
//! first surface each side ray reaches; `secondary_boundary` leaves that part out there
//! (`SecondaryEdges::leaves_emission`) and keeps everything else.
//!     ∫_image ∫_edge a(p) [h⁻ − h⁺] (dω_q/dθ · n̂) |dω_q/dt| dt dA_image,   h = f cos L_e(first hit),
//! with dA_image = K cos θ_xc / (r_c² cos³ θ_c) dA_x (K the image's pixels per unit solid angle on its axis,
//! θ_xc between x's normal and the camera ray) and, for fixed q, dA_x = r_qx² cos θ_y / (r_qy² cos θ_xq) dA_y
//! (θ_xq between x's normal and the line through q): each sample weighs
//!     a(p) [h⁻ − h⁺] |dω_q/dt| (dω_q/dθ · n̂) K cos θ_xc r_qx² cos θ_y / (r_c² cos³ θ_c r_qy² cos θ_xq)
//! over p_edge p_y.

use crate::grad::accumulate_blocks;
use crate::grad::boundary::mesh_edges::{mesh_edges, MeshEdge};
use crate::grad::boundary::primary::project;
use crate::grad::path::velocity::PoseLayout;
use crate::render::bsdf::bsdf_eval;
use crate::render::bvh::trace_closest;
use crate::render::layout::FrameParams;
use crate::render::light::{emitted_radiance, sample_light};
use crate::render::sampler::Sampler;
use crate::render::shading::{offset_origin, surface_point};
use crate::render::SceneData;
use crate::scene::Scene;
use glam::Vec3;

/// Seed tweak separating these samples from every other stream.
const SHADOW_SEED: u32 = 0x510e_527f;
/// Relative distance beyond q (of the light's distance) within which a hit counts as q itself, not as x.
const EDGE_MARGIN: f32 = 1e-3;
/// Angular offset of the two side directions at x (as `secondary_boundary`'s), and the offset, relative to the
/// distance, of the ray from the light past q on the side away from the edge's faces.
const SIDE_EPS: f32 = 1e-4;

/// Light-side samples per camera path per secondary edge sample (sppse).
pub const SHADOW_SAMPLES_PER_PATH: f32 = 1.0;

/// The number of light-side samples for `sppse` secondary edge samples per vertex and `paths` camera paths.
pub fn shadow_sample_count(sppse: u32, paths: u32) -> u32 {
    (sppse as f32 * paths as f32 * SHADOW_SAMPLES_PER_PATH).min(u32::MAX as f32 / 2.0) as u32
}

/// The moving, non-emitting edges and their sampling distribution.
pub struct ShadowEdges {
    edges: Vec<MeshEdge>,
    /// Prefix sums of the edges' weights (length times the share of directions that see a silhouette).
    cdf: Vec<f64>,
}

impl ShadowEdges {
    pub fn build(scene: &Scene, pose: &PoseLayout) -> ShadowEdges {
        let owned = |o: u32| pose.moves(o) && scene.objects[o as usize].emitter.is_none();
        let edges = mesh_edges(scene, owned);
        let mut cdf = Vec::with_capacity(edges.len());
        let mut total = 0.0f64;
        for e in &edges {
            total += silhouette_weight(e) as f64;
            cdf.push(total);
        }
        ShadowEdges { edges, cdf }
    }

    fn total(&self) -> f64 {
        self.cdf.last().copied().unwrap_or(0.0)
    }

    /// The edge for u in [0, 1) and its probability.
    fn sample(&self, u: f32) -> Option<(usize, f64)> {
        let total = self.total();
        if total.is_nan() || total <= 0.0 {
            return None;
        }
        let target = u as f64 * total;
        let i = self.cdf.partition_point(|&c| c <= target).min(self.edges.len() - 1);
        let w = self.cdf[i] - if i == 0 { 0.0 } else { self.cdf[i - 1] };
        (w > 0.0).then_some((i, w / total))
    }
}

/// An edge's length times the share of directions from which it is a silhouette (one face turned toward the
/// viewer, the other away: the angle between the normals over π; every direction for a boundary edge). Zero
/// only for edges that are never silhouettes (coplanar faces), whose emitted-radiance jump is always zero.
pub fn silhouette_weight(e: &MeshEdge) -> f32 {
    let len = (e.b - e.a).length();
    let share = match e.faces.as_slice() {
        [f1, f2] => f1.normal.dot(f2.normal).clamp(-1.0, 1.0).acos() / std::f32::consts::PI,
        _ => 1.0,
    };
    let w = len * share;
    if w.is_finite() {
        w
    } else {
        0.0
    }
}

/// The side (±1 along `across`, perpendicular to the edge and the line through it) on which both of the edge's
/// faces lie, or None when they lie on both sides (no silhouette from the line) or `across` is degenerate.
fn faces_side(e: &MeshEdge, across: Vec3) -> Option<f32> {
    if across == Vec3::ZERO {
        return None;
    }
    let mut side = None;
    for f in &e.faces {
        let s = f.inward.dot(across);
        if s == 0.0 || !s.is_finite() {
            return None;
        }
        let s = s.signum();
        if side.is_some_and(|prev| prev != s) {
            return None;
        }
        side = Some(s);
    }
    side
}

/// `shadow_samples` samples of the light-side shadow boundary, as a gradient over the pose layout; `adjoint`
/// holds dLoss/d(radiance), 3 floats per pixel.
pub fn shadow_boundary(
    d: &SceneData,
    fp: &FrameParams,
    pose: &PoseLayout,
    edges: &ShadowEdges,
    adjoint: &[f32],
    shadow_samples: u32,
) -> Vec<f64> {
    // Only vertices that scatter get a secondary boundary; no lights, no shadows.
    if shadow_samples == 0 || fp.max_depth < 2 || fp.light_count == 0 || edges.total() <= 0.0 {
        return vec![0.0; pose.len];
    }
    let n = shadow_samples as usize;
    accumulate_blocks(n, pose.len, |samples, g| {
        let mut moving = vec![];
        for i in samples {
            shadow_sample(d, fp, pose, edges, adjoint, i as u32, shadow_samples, &mut moving, g);
        }
    })
}

/// Sample `i` of `shadow_boundary`, added to `g` (`moving` is scratch space).
#[allow(clippy::too_many_arguments)]
fn shadow_sample(
    d: &SceneData,
    fp: &FrameParams,
    pose: &PoseLayout,
    edges: &ShadowEdges,
    adjoint: &[f32],
    i: u32,
    count: u32,
    moving: &mut Vec<usize>,
    g: &mut [f64],
) {
    let s = Sampler { seed: fp.seed ^ SHADOW_SEED, pixel: i, sample: 0 };
    let Some((ei, p_edge)) = edges.sample(s.get(0)) else { return };
    let e = &edges.edges[ei];
    let t = s.get(1);
    let q = e.a + (e.b - e.a) * t;
    let light = sample_light(d, fp.light_count, s.get(2), s.get(3), s.get(4));
    let to_q = q - light.p;
    let r_qy = to_q.length();
    if r_qy.is_nan() || r_qy <= 0.0 || light.pdf_area.is_nan() || light.pdf_area <= 0.0 {
        return;
    }
    let dir = to_q / r_qy;
    let cos_y = light.n.dot(dir);
    if !(light.two_sided || cos_y > 0.0) {
        return; // the light does not shine toward q
    }
    // The line from y past q on the side away from the edge's faces (a silhouette from y has them both on one
    // side; otherwise the line enters the object and reaches nothing past q) goes on to x, the first surface
    // beyond q.
    let across = (e.b - e.a).cross(dir).normalize_or_zero();
    let Some(faces_side) = faces_side(e, across) else { return };
    let origin = offset_origin(light.p, light.n, dir);
    let ray = (q - across * (faces_side * SIDE_EPS * r_qy) - origin).normalize();
    let Some(hit) = trace_closest(&d.nodes, &d.triangles, origin, ray, f32::INFINITY) else { return };
    if hit.t < r_qy * (1.0 + EDGE_MARGIN) {
        return; // q in the shadow of something else (no light reaches it from y), or x at q itself
    }
    let x_object = d.triangles[hit.triangle as usize].object;
    let x = origin + ray * hit.t;
    // x seen by the camera, at pixel p.
    let cam = &d.camera;
    let eye = Vec3::from(cam.origin);
    let Some([px, py]) = project(cam, x) else { return };
    if !(px >= 0.0 && py >= 0.0 && px < cam.width as f32 && py < cam.height as f32) {
        return;
    }
    let to_x = x - eye;
    let r_c = to_x.length();
    let dir_c = to_x / r_c;
    // The camera's first hit must be x's own triangle (a distance margin would let the camera see floor points
    // just behind an object's foot, where contact shadows are strongest).
    match trace_closest(&d.nodes, &d.triangles, eye, dir_c, f32::INFINITY) {
        Some(seen) if seen.triangle == hit.triangle => {}
        _ => return,
    }
    let pixel = (py as u32 * cam.width + px as u32) as usize * 3;
    let a = Vec3::from_slice(&adjoint[pixel..pixel + 3]);
    if a == Vec3::ZERO {
        return;
    }
    // At x, as secondary_boundary does: the edge point's direction, its arc, the emitted radiance on both sides.
    let sp = surface_point(d, hit.triangle, hit.u, hit.v, dir_c);
    let wi = sp.to_local(-dir_c);
    let to = q - sp.p;
    let r = to.length();
    let om = to / r;
    let ab = e.b - e.a;
    let tau = (ab - om * om.dot(ab)) / r;
    let n_hat = om.cross(tau).normalize_or_zero();
    if n_hat == Vec3::ZERO {
        return;
    }
    let side = |sign: f32| {
        let w = (om + n_hat * (sign * SIDE_EPS)).normalize();
        let f = bsdf_eval(&sp.bsdf, wi, sp.to_local(w));
        if f == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let o = offset_origin(sp.p, sp.ng, w);
        match trace_closest(&d.nodes, &d.triangles, o, w, f32::INFINITY) {
            Some(h) => f * emitted_radiance(d, h.triangle, Vec3::from(d.shading[h.triangle as usize].ng).dot(-w) > 0.0),
            None => Vec3::ZERO,
        }
    };
    let jump = side(-1.0) - side(1.0);
    if jump == Vec3::ZERO {
        return;
    }
    // Pixels per unit solid angle on the axis, and the cosines and distances of the change of variables.
    let k = (cam.width as f32 / (2.0 * cam.tan_half_fov * cam.aspect)) * (cam.height as f32 / (2.0 * cam.tan_half_fov));
    let cos_c = dir_c.dot(Vec3::from(cam.forward));
    let (cos_xc, cos_xy) = (sp.ng.dot(dir_c).abs(), sp.ng.dot(om).abs());
    let jacobian = k * cos_xc * r * r * cos_y.abs() / (r_c * r_c * cos_c * cos_c * cos_c * r_qy * r_qy * cos_xy);
    let scale = a.dot(jump) * tau.length() * jacobian / (p_edge as f32 * light.pdf_area * count as f32);
    if !scale.is_finite() {
        return;
    }
    // Entries that move the edge point (a material point) or x (on a moving object, it slides along the
    // camera ray: dx/dθ = d_c (n·u(x)) / (n·d_c), u the velocity of the material point under x).
    let site = [(e.ends[0], 1.0 - t), (e.ends[1], t)];
    let corners = pose.corners(d, hit.triangle);
    let x_site = [(corners[0], 1.0 - hit.u - hit.v), (corners[1], hit.u), (corners[2], hit.v)];
    moving.clear();
    pose.entries_moving(e.object, &e.ends, moving);
    pose.entries_moving(x_object, &corners, moving);
    for &m in moving.iter() {
        let (o, comp, at) = pose.entries[m];
        let edge_velocity = if o == e.object { pose.velocity(o, comp, q, &site) } else { Vec3::ZERO };
        let x_velocity = if o == x_object {
            dir_c * (sp.ng.dot(pose.velocity(o, comp, sp.p, &x_site)) / sp.ng.dot(dir_c))
        } else {
            Vec3::ZERO
        };
        let rel = edge_velocity - x_velocity;
        let v_dir = (rel - om * om.dot(rel)) / r;
        g[at] += (scale * v_dir.dot(n_hat)) as f64;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{box_mesh, load_scene, Object, Pose};

    /// The unit cube's edges, welded (12, each between two faces at right angles).
    fn cube_edges() -> Vec<MeshEdge> {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/room/scene.json");
        let mut scene = load_scene(std::path::Path::new(path)).unwrap();
        scene.objects.clear();
        let mut cube = box_mesh(Vec3::ONE, false);
        cube.material = 0;
        scene.objects.push(Object { name: "cube".into(), parts: vec![cube], pose: Pose::default(), emitter: None });
        mesh_edges(&scene, |_| true)
    }

    /// A cube edge is a silhouette from half the directions (its faces' normals 90 degrees apart): weight half
    /// its length; a face diagonal (coplanar faces) never is: weight zero. The faces lie on one side of a line
    /// through the edge exactly when the line sees the edge as a silhouette (one face turned toward its
    /// direction, the other away).
    #[test]
    fn cube_edges_are_silhouettes_from_half_the_directions() {
        let edges = cube_edges();
        let sharp = edges.iter().filter(|e| e.faces[0].normal.dot(e.faces[1].normal) < 0.5).count();
        assert_eq!((edges.len(), sharp), (18, 12), "12 cube edges and 6 face diagonals");
        for e in &edges {
            let coplanar = e.faces[0].normal.dot(e.faces[1].normal) > 0.999;
            let expected = if coplanar { 0.0 } else { 0.5 * (e.b - e.a).length() };
            assert!((silhouette_weight(e) - expected).abs() < 1e-3, "{e:?}");
            for k in 0..64u32 {
                let s = Sampler { seed: 9, pixel: k, sample: 0 };
                let dir = Vec3::new(s.get(0) - 0.5, s.get(1) - 0.5, s.get(2) - 0.5).normalize();
                let across = (e.b - e.a).cross(dir).normalize_or_zero();
                let (d1, d2) = (e.faces[0].normal.dot(dir), e.faces[1].normal.dot(dir));
                if d1.abs() < 1e-3 || d2.abs() < 1e-3 || across == Vec3::ZERO {
                    continue;
                }
                let silhouette = (d1 > 0.0) != (d2 > 0.0);
                assert_eq!(faces_side(e, across).is_some(), silhouette, "edge {e:?}, direction {dir}");
            }
        }
    }
}
