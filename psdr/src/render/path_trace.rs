//! The primal integrator: unidirectional path tracing with next-event estimation, MIS (power heuristic)
//! and Russian roulette, plus the primary-hit AOVs; one integrator for the renderer and the adjoint passes'
//! path recorder (`PathObserver`). GLSL twin: shaders/render/path_trace.comp.

use super::bsdf::{bsdf_at, bsdf_eval_pdf, bsdf_sample_at};
use super::bvh::{trace_closest, trace_occluded, Hit};
use super::camera::camera_ray;
use super::layout::*;
use super::light::{emitted_radiance, emitter_shape, light_pdf_area, mis_power, sample_light, sky_shape};
use super::sampler::*;
use super::scene_data::SceneData;
use super::shading::{offset_origin, surface_point, SurfacePoint};
use glam::Vec3;

/// What one camera path returns.
pub struct PathSample {
    pub radiance: Vec3,
    /// Camera-space depth of the primary hit (0 on a miss).
    pub depth: f32,
    pub normal: Vec3,
    pub albedo: Vec3,
    /// Object of the primary hit, or NONE.
    pub object: u32,
    /// Rays traced (closest-hit and shadow).
    pub rays: u32,
    /// Radiance emitted by the first surface hit toward the ray (part of `radiance`; the secondary boundary
    /// leaves it to the light-side shadow estimator where that owns it).
    pub first_emission: Vec3,
}

/// A next-event estimate that reached its light, as the integrator computed it.
#[derive(Clone, Copy, Debug)]
pub struct NeeEvent {
    /// The light-selection number (which light: `light::select_light`).
    pub u_select: f32,
    /// World direction from the vertex to the light point.
    pub dir: Vec3,
    pub emitter: u32,
    pub radiance: Vec3,
    /// MIS weight over the light's solid-angle density: the estimate is f · radiance · this.
    pub w_over_pdf: f32,
    /// f · cos_o toward the light and that direction in the shading frame.
    pub f: Vec3,
    pub wo_local: Vec3,
}

/// The BSDF-sampled continuation of a path.
#[derive(Clone, Copy, Debug)]
pub struct ContinueEvent {
    /// World direction of the continuation ray.
    pub dir: Vec3,
    /// Solid-angle density of the sampled direction, and the roulette survival probability (1 before rr_depth).
    pub pdf: f32,
    pub q: f32,
    /// f · cos / pdf of the sample, and its direction in the shading frame.
    pub weight: Vec3,
    pub wo_local: Vec3,
}

/// What the integrator reports of a path as it traces it, for callers that record paths (the adjoint passes,
/// grad/path/record.rs). The primal passes `()`, whose methods are empty and compile away, so the renderer and
/// the recorder run one integrator instead of two hand-synced copies.
pub trait PathObserver {
    /// The path starts with the ray (origin, dir).
    #[inline(always)]
    fn start(&mut self, _origin: Vec3, _dir: Vec3) {}
    /// A surface was hit, with throughput `beta` arriving; the events that follow belong to this vertex.
    #[inline(always)]
    fn hit(&mut self, _hit: &Hit, _sp: &SurfacePoint, _beta: Vec3) {}
    /// Emission found at the vertex, what the emitter's radiance was multiplied by toward the path
    /// (`light::sky_shape`), and its MIS weight (1 where the camera sees it).
    #[inline(always)]
    fn emission(&mut self, _emitter: u32, _le: Vec3, _shape: Vec3, _mis: f32) {}
    /// The path scatters here: the incoming direction in the shading frame.
    #[inline(always)]
    fn scatter(&mut self, _wi_local: Vec3) {}
    #[inline(always)]
    fn nee(&mut self, _e: &NeeEvent) {}
    #[inline(always)]
    fn continuation(&mut self, _e: &ContinueEvent) {}
}

impl PathObserver for () {}

/// Traces sample `sample` of pixel (px, py).
pub fn trace_path(d: &SceneData, fp: &FrameParams, px: u32, py: u32, sample: u32) -> PathSample {
    trace_path_observed(d, fp, px, py, sample, &mut ())
}

/// `trace_path`, reporting each vertex to `obs`.
#[inline(always)]
pub fn trace_path_observed<O: PathObserver>(
    d: &SceneData,
    fp: &FrameParams,
    px: u32,
    py: u32,
    sample: u32,
    obs: &mut O,
) -> PathSample {
    let cam = &d.camera;
    let s = Sampler { seed: fp.seed, pixel: py * cam.width + px, sample };
    let (jx, jy) = s.get2(DIM_PIXEL_X);
    let dir = camera_ray(cam, px as f32 + jx, py as f32 + jy);
    trace_from(d, fp, &s, Vec3::from(cam.origin), dir, obs)
}

/// The integrator, from the ray (origin, dir) on, drawing bounce numbers from `s` (the AOVs are those of the
/// first hit, depth measured along the camera's forward axis).
#[inline(always)]
pub fn trace_from<O: PathObserver>(
    d: &SceneData,
    fp: &FrameParams,
    s: &Sampler,
    origin: Vec3,
    dir: Vec3,
    obs: &mut O,
) -> PathSample {
    let cam = &d.camera;
    obs.start(origin, dir);
    let (mut origin, mut dir) = (origin, dir);
    let mut out = PathSample {
        radiance: Vec3::ZERO,
        depth: 0.0,
        normal: Vec3::ZERO,
        albedo: Vec3::ZERO,
        object: NONE,
        rays: 0,
        first_emission: Vec3::ZERO,
    };
    let mut beta = Vec3::ONE;
    let mut prev_bsdf_pdf = 0.0f32;
    for depth in 0..fp.max_depth {
        out.rays += 1;
        let Some(hit) = trace_closest(&d.nodes, &d.triangles, origin, dir, f32::INFINITY) else {
            break;
        };
        let sp = surface_point(d, hit.triangle, hit.u, hit.v, dir);
        obs.hit(&hit, &sp, beta);
        if depth == 0 {
            out.depth = hit.t * dir.dot(Vec3::from(cam.forward));
            out.normal = sp.ns;
            out.albedo = sp.bsdf.albedo;
            out.object = sp.object;
        }
        // Emission reached by the previous bounce (or seen directly), MIS-weighted against NEE.
        let le = emitted_radiance(d, hit.triangle, sp.front, dir);
        if le != Vec3::ZERO {
            let emitter = d.shading[hit.triangle as usize].emitter;
            let shape = emitter_shape(d, emitter, dir);
            if depth == 0 {
                out.radiance += beta * le;
                out.first_emission = beta * le;
                obs.emission(emitter, le, shape, 1.0);
            } else {
                let cos_l = sp.ng.dot(-dir).abs();
                let light_pdf = light_pdf_area(d, hit.triangle) * hit.t * hit.t / cos_l;
                let mis = mis_power(prev_bsdf_pdf, light_pdf);
                out.radiance += beta * le * mis;
                obs.emission(emitter, le, shape, mis);
            }
        }
        if depth + 1 >= fp.max_depth {
            break;
        }
        let wi = sp.to_local(-dir);
        obs.scatter(wi);
        let bsdf = bsdf_at(&sp.bsdf, wi);
        let (u_select, u_lobe) = s.bounce2(depth, DIM_LIGHT_SELECT);
        // Next-event estimation: one point on one light.
        if fp.light_count > 0 {
            let (u1, u2) = s.bounce2(depth, DIM_LIGHT_U);
            let ls = sample_light(d, fp.light_count, u_select, u1, u2);
            let to_light = ls.p - sp.p;
            let dist2 = to_light.dot(to_light);
            let dist = dist2.sqrt();
            let wl = to_light / dist;
            let cos_l = if ls.two_sided { ls.n.dot(-wl).abs() } else { ls.n.dot(-wl) };
            if cos_l > 0.0 && dist > 0.0 {
                let wo = sp.to_local(wl);
                let (f, pdf) = bsdf_eval_pdf(&bsdf, wo);
                if f != Vec3::ZERO {
                    out.rays += 1;
                    if unoccluded(d, sp.p, sp.ng, ls.p, ls.n) {
                        let light_pdf = ls.pdf_area * dist2 / cos_l;
                        let w = mis_power(light_pdf, pdf);
                        let w_over_pdf = w / light_pdf;
                        let le = ls.radiance * sky_shape(ls.sky_gradient, wl);
                        out.radiance += beta * f * le * w_over_pdf;
                        obs.nee(&NeeEvent {
                            u_select,
                            dir: wl,
                            emitter: ls.emitter,
                            radiance: le,
                            w_over_pdf,
                            f,
                            wo_local: wo,
                        });
                    }
                }
            }
        }
        // Continue the path by sampling the BSDF.
        let (b1, b2) = s.bounce2(depth, DIM_BSDF_U);
        let Some(bs) = bsdf_sample_at(&bsdf, u_lobe, b1, b2) else {
            break;
        };
        beta *= bs.weight;
        prev_bsdf_pdf = bs.pdf;
        dir = sp.to_world(bs.wo).normalize();
        origin = offset_origin(sp.p, sp.ng, dir);
        let mut q = 1.0;
        if depth + 1 >= fp.rr_depth {
            q = beta.max_element().min(0.95);
            if s.bounce(depth, DIM_ROULETTE) >= q || q.is_nan() {
                break;
            }
            beta /= q;
        }
        obs.continuation(&ContinueEvent { dir, pdf: bs.pdf, q, weight: bs.weight, wo_local: bs.wo });
    }
    out
}

/// True when nothing blocks the segment from surface point `p` (geometric normal `ng`) to light point `q` (light
/// triangle normal `nq`). Both ends are offset off their own surfaces toward each other and the ray ends at the
/// offset light point: a ray from the offset origin aimed at the light point itself would cross the light's plane
/// up to offset * |ng.nq| / cos_l before the light point, which a relative margin cannot absorb at grazing cos_l
/// (that falsely shadowed about 0.1 % of the second-bounce light in a white furnace).
#[inline(always)]
pub fn unoccluded(d: &SceneData, p: Vec3, ng: Vec3, q: Vec3, nq: Vec3) -> bool {
    let o = offset_origin(p, ng, q - p);
    let v = offset_origin(q, nq, p - q) - o;
    let dist = v.length();
    dist > 0.0 && !trace_occluded(&d.nodes, &d.triangles, o, v / dist, dist)
}

/// Per-pixel sums over the samples of one pass (one row of each output buffer).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PixelSums {
    pub radiance: Vec3,
    pub depth: f32,
    pub normal: Vec3,
    pub albedo: Vec3,
    pub rays: u32,
}

/// The kernel body: accumulates samples [sample_begin, sample_begin + sample_count) of pixel (px, py)
/// into `sums` and the pixel's coverage row `coverage[object]` (one entry per object).
pub fn path_trace(d: &SceneData, fp: &FrameParams, px: u32, py: u32, sums: &mut PixelSums, coverage: &mut [f32]) {
    for sample in fp.sample_begin..fp.sample_begin + fp.sample_count {
        let ps = trace_path(d, fp, px, py, sample);
        sums.radiance += ps.radiance;
        sums.depth += ps.depth;
        sums.normal += ps.normal;
        sums.albedo += ps.albedo;
        sums.rays += ps.rays;
        if ps.object != NONE {
            coverage[ps.object as usize] += 1.0;
        }
    }
}

/// Object seen through the centre of pixel (px, py), or NONE (the id AOV: exact, not averaged).
pub fn object_at_pixel_center(d: &SceneData, px: u32, py: u32) -> u32 {
    let dir = camera_ray(&d.camera, px as f32 + 0.5, py as f32 + 0.5);
    match trace_closest(&d.nodes, &d.triangles, Vec3::from(d.camera.origin), dir, f32::INFINITY) {
        Some(h) => d.triangles[h.triangle as usize].object,
        None => NONE,
    }
}
