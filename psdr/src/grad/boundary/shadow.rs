//! The direct-shadow part of the secondary boundary, sampled from the light: where a moving object's silhouette
//! crosses a light as seen from a path vertex x, the light's radiance jumps. The path-vertex estimator
//! (boundary/secondary.rs) draws these shadow edges from x by geometry alone and finds them rarely: on the
//! furnished room, the 0.3 % of its samples whose side ray reached the light held 97 % of its variance. Here
//! the integral is sampled the other way round: a point q on a moving edge (by length times the share of
//! directions from which the edge is a silhouette), a point y on a light (as next-event estimation picks it),
//! and x, the first surface the line from y through q reaches beyond q. Almost every such sample lands on a
//! shadow boundary. Each sample serves two vertices of camera paths:
//! - k = 0, x seen by the camera (on a moving object too, sliding along the camera ray);
//! - k = 1, x seen from x0, the first surface a cosine-distributed direction from x reaches, seen by the camera
//!   (x0 slides along the camera ray, x along the ray from x0, as the interior term's ray form moves them).
//!
//! The estimator owns exactly this part: vertices k ≤ 1 (`secondary::light_side_vertex`), edges of moving
//! objects that do not emit, and the jump of the radiance *emitted* at the first surface each side ray reaches;
//! `secondary_boundary` leaves that part out there (`SecondaryEdges::leaves_emission`) and keeps the rest.
//!     ∫_image ∫_edge a(p) [h⁻ − h⁺] (dω_q/dθ · n̂) |dω_q/dt| dt dA_image,   h = f cos L_e(first hit),
//! with dA_image = K cos θ_xc / (r_c² cos³ θ_c) dA_x (K the image's pixels per unit solid angle on its axis,
//! θ_xc between x's normal and the camera ray) and, for fixed q, dA_x = r_qx² cos θ_y / (r_qy² cos θ_xq) dA_y
//! (θ_xq between x's normal and the line through q): each k = 0 sample weighs
//!     a(p) [h⁻ − h⁺] |dω_q/dt| (dω_q/dθ · n̂) K cos θ_xc r_qx² cos θ_y / (r_c² cos³ θ_c r_qy² cos θ_xq)
//! over p_edge p_y. For k = 1 the camera's view of x is replaced by the view of x0 and the path's bounce there:
//! ∫ a(p) f(x0) cos_s dω0 dA_image with dω0 = |n_x·ω| / r² dA_x and the density of x0 given x,
//! p_ω |n_x0·ω| / r², so the factor a(p) K cos θ_x0c / (r_c² cos³ θ_c) becomes that of x0 times
//! f(x0) cos_s |n_x·ω| / (p_ω |n_x0·ω|), with p_ω = |n_x·ω| / π: π f(x0) cos_s / |n_x0·ω|.

use crate::grad::accumulate_blocks;
use crate::grad::boundary::mesh_edges::{mesh_edges, MeshEdge};
use crate::grad::boundary::primary::project;
use crate::grad::path::velocity::PoseLayout;
use crate::render::bsdf::bsdf_eval;
use crate::render::bsdf::sample_cosine_hemisphere;
use crate::render::bvh::trace_closest;
use crate::render::layout::FrameParams;
use crate::render::light::{emitted_radiance, sample_light};
use crate::render::sampler::Sampler;
use crate::render::shading::{offset_origin, orthogonal, surface_point};
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
    // The edge point's direction from x, its arc, and the radiance emitted toward x on both sides of it (the
    // same for every way x is seen; only the BSDF at x depends on that).
    let to = q - x;
    let r = to.length();
    let om = to / r;
    let ab = e.b - e.a;
    let tau = (ab - om * om.dot(ab)) / r;
    let n_hat = om.cross(tau).normalize_or_zero();
    if n_hat == Vec3::ZERO || !r.is_finite() {
        return;
    }
    let lit = surface_point(d, hit.triangle, hit.u, hit.v, ray); // normals facing the light's side
    let sides = [-1.0f32, 1.0].map(|sign| {
        let w = (om + n_hat * (sign * SIDE_EPS)).normalize();
        let o = offset_origin(lit.p, lit.ng, w);
        let le = match trace_closest(&d.nodes, &d.triangles, o, w, f32::INFINITY) {
            Some(h) => emitted_radiance(d, h.triangle, Vec3::from(d.shading[h.triangle as usize].ng).dot(-w) > 0.0, w),
            None => Vec3::ZERO,
        };
        (w, le)
    });
    if sides[0].1 == sides[1].1 {
        return; // no jump, whatever the BSDF
    }
    // x seen along `dir` (toward x): the jump of f cos L_e across the edge.
    let jump = |dir: Vec3| {
        let sp = surface_point(d, hit.triangle, hit.u, hit.v, dir);
        let wi = sp.to_local(-dir);
        let [(w0, l0), (w1, l1)] = sides;
        bsdf_eval(&sp.bsdf, wi, sp.to_local(w0)) * l0 - bsdf_eval(&sp.bsdf, wi, sp.to_local(w1)) * l1
    };
    // The edge and light samples' part of the change of variables (dA_x over dA_y, their densities).
    let cos_xq = lit.ng.dot(om).abs();
    let per_x =
        tau.length() * r * r * cos_y.abs() / (cos_xq * r_qy * r_qy * p_edge as f32 * light.pdf_area * count as f32);
    // Adds a sample's `scale` times the edge point's velocity relative to x's (both along n̂ over r) for every
    // entry that moves the edge point (a material point), the triangles `under` (object, corners) or x.
    let mut add = |scale: f32, x_velocity: &dyn Fn(usize) -> Vec3, under: &[(u32, [u32; 3])]| {
        if !scale.is_finite() || scale == 0.0 {
            return;
        }
        let site = [(e.ends[0], 1.0 - t), (e.ends[1], t)];
        moving.clear();
        pose.entries_moving(e.object, &e.ends, moving);
        for (object, corners) in under {
            pose.entries_moving(*object, corners, moving);
        }
        for &m in moving.iter() {
            let (o, comp, at) = pose.entries[m];
            let edge_velocity = if o == e.object { pose.velocity(o, comp, q, &site) } else { Vec3::ZERO };
            let rel = edge_velocity - x_velocity(m);
            let v_dir = (rel - om * om.dot(rel)) / r;
            g[at] += (scale * v_dir.dot(n_hat)) as f64;
        }
    };
    // The velocity u of the material point at `p` on triangle `ti` under entry m.
    let material_velocity = |m: usize, ti: u32, p: Vec3, u: f32, v: f32| {
        let (o, comp, _) = pose.entries[m];
        if o != d.triangles[ti as usize].object {
            return Vec3::ZERO;
        }
        let c = pose.corners(d, ti);
        pose.velocity(o, comp, p, &[(c[0], 1.0 - u - v), (c[1], u), (c[2], v)])
    };
    // A vertex on the ray (origin moving at v_o, direction held fixed) slides to stay on its surface (normal n,
    // material velocity u): v_o + dir (n·(u − v_o)) / (n·dir), as the interior term's ray form moves it.
    let slide = |v_o: Vec3, dir: Vec3, n: Vec3, u: Vec3| v_o + dir * (n.dot(u - v_o) / n.dot(dir));
    let x_under = (x_object, pose.corners(d, hit.triangle));
    // Seen by the camera (k = 0): a(p) times the image area per unit area at x; x slides along the camera ray.
    if let Some(c) = camera_view(d, adjoint, x, hit.triangle) {
        let scale = c.adjoint.dot(jump(c.dir)) * c.image_per_area * per_x;
        let x_velocity = |m| slide(Vec3::ZERO, c.dir, lit.ng, material_velocity(m, hit.triangle, x, hit.u, hit.v));
        add(scale, &x_velocity, &[x_under]);
    }
    // Seen after one bounce (k = 1): x0 drawn from x by a cosine direction; the image area per unit area at x0,
    // times f(x0) |n_x·ω| / (p_ω |n_x0·ω|) = π f(x0) / |n_x0·ω|. x0 slides along the camera ray, x along the
    // ray from x0.
    if fp.max_depth >= 3 {
        let n = lit.ng;
        let (t1, local) = (orthogonal(n), sample_cosine_hemisphere(s.get(5), s.get(6)));
        let om0 = (t1 * local.x + n.cross(t1) * local.y + n * local.z).normalize();
        let o0 = offset_origin(x, n, om0);
        let Some(h0) = trace_closest(&d.nodes, &d.triangles, o0, om0, f32::INFINITY) else { return };
        let x0 = o0 + om0 * h0.t;
        let Some(c) = camera_view(d, adjoint, x0, h0.triangle) else { return };
        let sp0 = surface_point(d, h0.triangle, h0.u, h0.v, c.dir);
        let f0 = bsdf_eval(&sp0.bsdf, sp0.to_local(-c.dir), sp0.to_local(-om0));
        let weight = c.adjoint * f0 * (std::f32::consts::PI / sp0.ng.dot(om0).abs());
        let scale = weight.dot(jump(-om0)) * c.image_per_area * per_x;
        let x_velocity = |m| {
            let v0 = slide(Vec3::ZERO, c.dir, sp0.ng, material_velocity(m, h0.triangle, x0, h0.u, h0.v));
            slide(v0, -om0, lit.ng, material_velocity(m, hit.triangle, x, hit.u, hit.v))
        };
        let x0_under = (d.triangles[h0.triangle as usize].object, pose.corners(d, h0.triangle));
        add(scale, &x_velocity, &[x_under, x0_under]);
    }
}

/// How the camera sees a point: the direction from the eye, the pixel's adjoint, and the image's area per
/// unit surface area there (K cos θ_xc / (r_c² cos³ θ_c), K the pixels per unit solid angle on the axis).
struct CameraView {
    dir: Vec3,
    adjoint: Vec3,
    image_per_area: f32,
}

/// The camera's view of point `x` on triangle `triangle`: None unless x projects into the image and the
/// camera's first hit toward it is that triangle (a distance margin would let the camera see floor points just
/// behind an object's foot, where contact shadows are strongest), or the pixel's adjoint is zero.
fn camera_view(d: &SceneData, adjoint: &[f32], x: Vec3, triangle: u32) -> Option<CameraView> {
    let cam = &d.camera;
    let eye = Vec3::from(cam.origin);
    let [px, py] = project(cam, x)?;
    if !(px >= 0.0 && py >= 0.0 && px < cam.width as f32 && py < cam.height as f32) {
        return None;
    }
    let to_x = x - eye;
    let r_c = to_x.length();
    let dir = to_x / r_c;
    if trace_closest(&d.nodes, &d.triangles, eye, dir, f32::INFINITY)?.triangle != triangle {
        return None;
    }
    let pixel = (py as u32 * cam.width + px as u32) as usize * 3;
    let adjoint = Vec3::from_slice(&adjoint[pixel..pixel + 3]);
    if adjoint == Vec3::ZERO {
        return None;
    }
    let k = (cam.width as f32 / (2.0 * cam.tan_half_fov * cam.aspect)) * (cam.height as f32 / (2.0 * cam.tan_half_fov));
    let cos_c = dir.dot(Vec3::from(cam.forward));
    let ng = Vec3::from(d.shading[triangle as usize].ng);
    let image_per_area = k * ng.dot(dir).abs() / (r_c * r_c * cos_c * cos_c * cos_c);
    Some(CameraView { dir, adjoint, image_per_area })
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
