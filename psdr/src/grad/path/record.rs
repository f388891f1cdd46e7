//! One camera path traced exactly as `render::path_trace::trace_path` traces it (same sampler dimensions, same
//! estimator), recorded vertex by vertex for the adjoint passes: what each vertex hit (triangle, barycentrics),
//! its local estimator terms, and the detached densities of its next-event and continuation samples.
//! Memory is one record per thread, bounded by max_depth, reused across samples.

use crate::render::bsdf::{bsdf_at, bsdf_eval_pdf, bsdf_sample_at, BsdfParams};
use crate::render::bvh::trace_closest;
use crate::render::camera::camera_ray;
use crate::render::layout::{FrameParams, NONE};
use crate::render::light::{emitted_radiance, light_pdf_area, mis_power, sample_light, select_light};
use crate::render::path_trace::unoccluded;
use crate::render::sampler::*;
use crate::render::shading::{offset_origin, surface_point};
use crate::render::SceneData;
use glam::{Vec2, Vec3};

/// Next-event estimation that reached its light.
#[derive(Clone, Copy, Debug, Default)]
pub struct RecordedNee {
    /// The light triangle.
    pub triangle: u32,
    /// World direction from the vertex to the light point.
    pub dir: Vec3,
    pub emitter: u32,
    pub radiance: Vec3,
    /// MIS weight / solid-angle density (detached: held fixed when differentiating): n = f · Le · this.
    pub w_over_pdf: f32,
    /// f · cos_o toward the light, and the light direction in the shading frame (for its derivatives).
    pub f: Vec3,
    pub wo_local: Vec3,
}

/// The BSDF-sampled continuation to the next vertex.
#[derive(Clone, Copy, Debug, Default)]
pub struct RecordedContinuation {
    /// World direction of the continuation ray.
    pub dir: Vec3,
    /// Solid-angle density of the sampled direction and the roulette survival probability (detached).
    pub pdf: f32,
    pub q: f32,
    /// β = f · cos / pdf / q, and the sampled direction in the shading frame (for its derivatives).
    pub beta: Vec3,
    pub wo_local: Vec3,
}

#[derive(Clone, Copy, Debug, Default)]
pub struct RecordedVertex {
    pub triangle: u32,
    pub u: f32,
    pub v: f32,
    /// Path throughput arriving at this vertex (T_k).
    pub throughput: Vec3,
    /// Emitter found here (NONE when none) and its MIS weight.
    pub emitter: u32,
    pub emission: Vec3,
    pub emission_mis: f32,
    pub nee: Option<RecordedNee>,
    pub next: Option<RecordedContinuation>,
    pub material: u32,
    /// The BSDF's inputs here (material values after texture lookup and clamping) and the incoming direction
    /// in the shading frame: derivatives w.r.t. material values are computed from them only when asked for.
    pub albedo: Vec3,
    pub roughness: f32,
    pub specular: f32,
    pub wi_local: Vec3,
    /// Texture coordinates after the uv transform.
    pub uv: Vec2,
    /// e_k + n_k: the radiance this vertex adds, relative to its throughput.
    pub local: Vec3,
}

#[derive(Clone, Debug, Default)]
pub struct PathRecord {
    pub origin: Vec3,
    pub dir: Vec3,
    pub vertices: Vec<RecordedVertex>,
}

impl RecordedVertex {
    pub fn bsdf(&self) -> BsdfParams {
        BsdfParams { albedo: self.albedo, roughness: self.roughness, specular: self.specular }
    }
}

impl PathRecord {
    /// The path's radiance estimate (what `trace_path` returns, up to rounding).
    pub fn radiance(&self) -> Vec3 {
        self.vertices.iter().map(|v| v.throughput * v.local).sum()
    }
}

/// Records sample `sample` of pixel (px, py) into `rec`.
pub fn record_path(d: &SceneData, fp: &FrameParams, px: u32, py: u32, sample: u32, rec: &mut PathRecord) {
    let cam = &d.camera;
    let s = Sampler { seed: fp.seed, pixel: py * cam.width + px, sample };
    let (jx, jy) = s.get2(DIM_PIXEL_X);
    let dir = camera_ray(cam, px as f32 + jx, py as f32 + jy);
    record_from(d, fp, &s, Vec3::from(cam.origin), dir, rec);
}

/// Records the path that starts with the camera ray (origin, dir), drawing bounce numbers from `s`.
pub fn record_from(d: &SceneData, fp: &FrameParams, s: &Sampler, origin: Vec3, dir: Vec3, rec: &mut PathRecord) {
    rec.vertices.clear();
    rec.origin = origin;
    rec.dir = dir;
    let (mut origin, mut dir) = (origin, dir);
    let mut beta = Vec3::ONE;
    let mut prev_bsdf_pdf = 0.0f32;
    for depth in 0..fp.max_depth {
        let Some(hit) = trace_closest(&d.nodes, &d.triangles, origin, dir, f32::INFINITY) else {
            break;
        };
        let sp = surface_point(d, hit.triangle, hit.u, hit.v, dir);
        let mut v = RecordedVertex {
            triangle: hit.triangle,
            u: hit.u,
            v: hit.v,
            throughput: beta,
            emitter: NONE,
            material: d.triangles[hit.triangle as usize].material,
            uv: sp.uv,
            albedo: sp.bsdf.albedo,
            roughness: sp.bsdf.roughness,
            specular: sp.bsdf.specular,
            ..Default::default()
        };
        let le = emitted_radiance(d, hit.triangle, sp.front);
        if le != Vec3::ZERO {
            v.emission_mis = if depth == 0 {
                1.0
            } else {
                let cos_l = sp.ng.dot(-dir).abs();
                mis_power(prev_bsdf_pdf, light_pdf_area(d, hit.triangle) * hit.t * hit.t / cos_l)
            };
            v.emitter = d.shading[hit.triangle as usize].emitter;
            v.emission = le;
            v.local += le * v.emission_mis;
        }
        if depth + 1 >= fp.max_depth {
            rec.vertices.push(v);
            break;
        }
        let wi = sp.to_local(-dir);
        v.wi_local = wi;
        let bsdf = bsdf_at(&sp.bsdf, wi);
        let (u_sel, u_lobe) = s.bounce2(depth, DIM_LIGHT_SELECT);
        if fp.light_count > 0 {
            let (u1, u2) = s.bounce2(depth, DIM_LIGHT_U);
            let ls = sample_light(d, fp.light_count, u_sel, u1, u2);
            let to_light = ls.p - sp.p;
            let dist2 = to_light.dot(to_light);
            let dist = dist2.sqrt();
            let wl = to_light / dist;
            let cos_l = if ls.two_sided { ls.n.dot(-wl).abs() } else { ls.n.dot(-wl) };
            if cos_l > 0.0 && dist > 0.0 {
                let wo = sp.to_local(wl);
                let (f, pdf) = bsdf_eval_pdf(&bsdf, wo);
                if f != Vec3::ZERO && unoccluded(d, sp.p, sp.ng, ls.p, ls.n) {
                    let light_pdf = ls.pdf_area * dist2 / cos_l;
                    let w = mis_power(light_pdf, pdf);
                    let nee = RecordedNee {
                        triangle: d.lights[select_light(&d.lights, fp.light_count, u_sel) as usize].triangle,
                        dir: wl,
                        emitter: ls.emitter,
                        radiance: ls.radiance,
                        w_over_pdf: w / light_pdf,
                        f,
                        wo_local: wo,
                    };
                    v.local += f * ls.radiance * nee.w_over_pdf;
                    v.nee = Some(nee);
                }
            }
        }
        let (b1, b2) = s.bounce2(depth, DIM_BSDF_U);
        let Some(bs) = bsdf_sample_at(&bsdf, u_lobe, b1, b2) else {
            rec.vertices.push(v);
            break;
        };
        prev_bsdf_pdf = bs.pdf;
        dir = sp.to_world(bs.wo).normalize();
        let mut next = RecordedContinuation { dir, pdf: bs.pdf, q: 1.0, beta: bs.weight, wo_local: bs.wo };
        origin = offset_origin(sp.p, sp.ng, dir);
        if depth + 1 >= fp.rr_depth {
            let q = (beta * bs.weight).max_element().min(0.95);
            if s.bounce(depth, DIM_ROULETTE) >= q || q.is_nan() {
                rec.vertices.push(v);
                break;
            }
            next.q = q;
            next.beta /= q;
        }
        beta *= next.beta;
        v.next = Some(next);
        rec.vertices.push(v);
    }
}
