//! Reverse mode (vector-Jacobian product) of the radiance image for parameters that do not move geometry:
//! emitter radiance, material albedo and roughness constants, albedo texels. The interior term only: these
//! parameters create no discontinuities, so there is no boundary term for them.
//!
//! Each sample's path is traced exactly as `render::path_trace::trace_path` traces it (same sampler dimensions,
//! same estimator), recording per vertex its local terms; a backward sweep over the recorded vertices then
//! distributes the pixel's adjoint onto the parameters. With vertex k's throughput T_k, its MIS-weighted
//! emission e_k, its next-event term n_k and its continuation weight β_k (f·cos/pdf, /q after roulette):
//!     L = Σ_k T_k e_k + T_k n_k,   R_k = e_k + n_k + β_k R_{k+1},
//!     ∂L/∂θ = Σ_k T_k (∂n_k/∂θ + ∂β_k/∂θ R_{k+1} + ∂e_k/∂θ).
//! Sampling densities, light selection and MIS weights are held fixed (detached), which keeps the estimator
//! unbiased. Memory is one vertex list per thread (bounded by max_depth) and one gradient row per image row,
//! independent of spp; rows are reduced in order, so the result is identical on any thread count.

use super::bsdf_grad::{bsdf_eval_grad, BsdfGrad};
use super::ParamPath;
use crate::error::{Error, Result};
use crate::render::bsdf::{bsdf_eval, bsdf_pdf, bsdf_sample};
use crate::render::bvh::{trace_closest, trace_occluded};
use crate::render::camera::camera_ray;
use crate::render::cpu::frame_params;
use crate::render::layout::{FrameParams, TextureGpu, NONE};
use crate::render::light::{emitted_radiance, light_pdf_area, mis_power, sample_light};
use crate::render::sampler::*;
use crate::render::shading::{offset_origin, surface_point};
use crate::render::SceneData;
use crate::scene::{Color, RenderSettings, Scene};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Where each differentiable quantity's gradient goes in the flat gradient vector.
#[derive(Clone, Debug)]
pub struct GradLayout {
    pub params: Vec<ParamPath>,
    /// Offset of each parameter's first float in the gradient vector.
    pub offsets: Vec<usize>,
    pub len: usize,
    emitter: Vec<Option<usize>>,
    albedo: Vec<Option<usize>>,
    roughness: Vec<Option<usize>>,
    /// (texture, texel index, offset) of single albedo texels.
    texels: Vec<(u32, u32, usize)>,
}

impl GradLayout {
    /// Lays out the gradients of `params`; refuses the parameters this module cannot differentiate yet.
    pub fn new(scene: &Scene, params: &[ParamPath]) -> Result<GradLayout> {
        let emitter_of_object: Vec<Option<usize>> = scene
            .objects
            .iter()
            .scan(0usize, |n, o| {
                Some(o.emitter.map(|_| {
                    *n += 1;
                    *n - 1
                }))
            })
            .collect();
        let mut l = GradLayout {
            params: params.to_vec(),
            offsets: vec![],
            len: 0,
            emitter: vec![None; emitter_of_object.iter().flatten().count()],
            albedo: vec![None; scene.materials.len()],
            roughness: vec![None; scene.materials.len()],
            texels: vec![],
        };
        for p in params {
            let n = p.get(scene)?.len();
            let at = l.len;
            let unsupported = || {
                Error::Invalid(format!(
                    "{p}: analytic gradients cover light radiance, material albedo/roughness constants and albedo \
                     texels so far; use --fd for this parameter"
                ))
            };
            match p {
                ParamPath::LightRadiance(name) => {
                    let o = scene.object_index(name).expect("checked by get");
                    l.emitter[emitter_of_object[o].expect("checked by get")] = Some(at);
                }
                ParamPath::MaterialAlbedo(name) => l.albedo[scene.material_index(name).expect("checked")] = Some(at),
                ParamPath::MaterialRoughness(name) => {
                    l.roughness[scene.material_index(name).expect("checked")] = Some(at)
                }
                ParamPath::MaterialTexel { material, slot: super::TextureSlot::Albedo, x, y } => {
                    let m = &scene.materials[scene.material_index(material).expect("checked")];
                    let Color::Texture(t) = m.albedo else { unreachable!("checked by get") };
                    l.texels.push((t as u32, y * scene.textures[t].width + x, at));
                }
                _ => return Err(unsupported()),
            }
            l.offsets.push(at);
            l.len += n;
        }
        Ok(l)
    }
}

/// What the backward sweep needs of one path vertex.
#[derive(Clone, Copy, Default)]
struct Vertex {
    throughput: Vec3,
    /// MIS weight of the emission found here, and its emitter (NONE when none).
    emission_mis: f32,
    emitter: u32,
    /// Le · w / pdf of next-event estimation (zero when none) and its emitter.
    nee_light: Vec3,
    /// w / pdf of next-event estimation: ∂n_k/∂Le = f · w / pdf.
    nee_scale: f32,
    nee_emitter: u32,
    nee_f: Vec3,
    nee_grad: BsdfGrad,
    /// Continuation weight β_k and ∂β_k/∂θ (zero when the path ended here).
    beta: Vec3,
    beta_grad: BsdfGrad,
    material: u32,
    uv: Vec2,
    /// e_k + n_k, local to this vertex.
    local: Vec3,
}

/// dLoss/dθ for the marked parameters, given dLoss/d(radiance) per pixel channel (`adjoint`, w·h·3).
pub fn radiance_vjp(
    d: &SceneData,
    settings: &RenderSettings,
    layout: &GradLayout,
    adjoint: &[f32],
) -> Result<Vec<f64>> {
    let (w, h) = (d.camera.width as usize, d.camera.height as usize);
    if adjoint.len() != w * h * 3 {
        return Err(Error::Invalid(format!("adjoint image has {} values, expected {}", adjoint.len(), w * h * 3)));
    }
    if let Some(i) = adjoint.iter().position(|v| !v.is_finite()) {
        return Err(Error::Invalid(format!("adjoint image value {i} is not finite")));
    }
    let fp = frame_params(d, settings);
    let rows: Vec<Vec<f64>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut grad = vec![0.0f64; layout.len];
            let mut verts = Vec::with_capacity(fp.max_depth as usize);
            for x in 0..w {
                let i = (y * w + x) * 3;
                let delta = Vec3::from_slice(&adjoint[i..i + 3]) / fp.spp as f32;
                if delta == Vec3::ZERO {
                    continue;
                }
                for sample in 0..fp.spp {
                    trace_path_adjoint(d, &fp, x as u32, y as u32, sample, &mut verts);
                    backward_sweep(d, layout, &verts, delta, &mut grad);
                }
            }
            grad
        })
        .collect();
    let mut grad = vec![0.0; layout.len];
    for row in rows {
        grad.iter_mut().zip(row).for_each(|(g, r)| *g += r);
    }
    Ok(grad)
}

/// `trace_path`'s estimator, recording each vertex's local terms instead of summing them.
fn trace_path_adjoint(d: &SceneData, fp: &FrameParams, px: u32, py: u32, sample: u32, verts: &mut Vec<Vertex>) {
    verts.clear();
    let cam = &d.camera;
    let s = Sampler { seed: fp.seed, pixel: py * cam.width + px, sample };
    let mut dir = camera_ray(cam, px as f32 + s.get(DIM_PIXEL_X), py as f32 + s.get(DIM_PIXEL_Y));
    let mut origin = Vec3::from(cam.origin);
    let mut beta = Vec3::ONE;
    let mut prev_bsdf_pdf = 0.0f32;
    for depth in 0..fp.max_depth {
        let Some(hit) = trace_closest(&d.nodes, &d.triangles, origin, dir, f32::INFINITY) else {
            break;
        };
        let sp = surface_point(d, hit.triangle, hit.u, hit.v, dir);
        let mut v = Vertex {
            throughput: beta,
            emitter: NONE,
            nee_emitter: NONE,
            material: d.triangles[hit.triangle as usize].material,
            uv: sp.uv,
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
            v.local += le * v.emission_mis;
        }
        if depth + 1 >= fp.max_depth {
            verts.push(v);
            break;
        }
        let wi = sp.to_local(-dir);
        if fp.light_count > 0 {
            let ls = sample_light(
                d,
                fp.light_count,
                s.bounce(depth, DIM_LIGHT_SELECT),
                s.bounce(depth, DIM_LIGHT_U),
                s.bounce(depth, DIM_LIGHT_V),
            );
            let to_light = ls.p - sp.p;
            let dist2 = to_light.dot(to_light);
            let dist = dist2.sqrt();
            let wl = to_light / dist;
            let cos_l = if ls.two_sided { ls.n.dot(-wl).abs() } else { ls.n.dot(-wl) };
            if cos_l > 0.0 && dist > 0.0 {
                let f = bsdf_eval(&sp.bsdf, wi, sp.to_local(wl));
                if f != Vec3::ZERO {
                    let o = offset_origin(sp.p, sp.ng, wl);
                    if !trace_occluded(&d.nodes, &d.triangles, o, wl, dist * (1.0 - 1e-4)) {
                        let light_pdf = ls.pdf_area * dist2 / cos_l;
                        let w = mis_power(light_pdf, bsdf_pdf(&sp.bsdf, wi, sp.to_local(wl)));
                        v.nee_scale = w / light_pdf;
                        v.nee_light = ls.radiance * v.nee_scale;
                        v.nee_f = f;
                        v.nee_grad = bsdf_eval_grad(&sp.bsdf, wi, sp.to_local(wl));
                        v.nee_emitter = ls.emitter;
                        v.local += f * v.nee_light;
                    }
                }
            }
        }
        let Some(bs) = bsdf_sample(
            &sp.bsdf,
            wi,
            s.bounce(depth, DIM_LOBE),
            s.bounce(depth, DIM_BSDF_U),
            s.bounce(depth, DIM_BSDF_V),
        ) else {
            verts.push(v);
            break;
        };
        let mut step = bs.weight;
        let mut step_grad = bsdf_eval_grad(&sp.bsdf, wi, bs.wo);
        let mut inv_pdf = 1.0 / bs.pdf;
        prev_bsdf_pdf = bs.pdf;
        dir = sp.to_world(bs.wo).normalize();
        origin = offset_origin(sp.p, sp.ng, dir);
        if depth + 1 >= fp.rr_depth {
            let q = (beta * bs.weight).max_element().min(0.95);
            if s.bounce(depth, DIM_ROULETTE) >= q || q.is_nan() {
                verts.push(v);
                break;
            }
            step /= q;
            inv_pdf /= q;
        }
        step_grad.albedo *= inv_pdf;
        step_grad.roughness *= inv_pdf;
        v.beta = step;
        v.beta_grad = step_grad;
        beta *= step;
        verts.push(v);
    }
}

/// Distributes one path's adjoint `delta` (already divided by spp) onto the parameters.
fn backward_sweep(d: &SceneData, l: &GradLayout, verts: &[Vertex], delta: Vec3, grad: &mut [f64]) {
    let mut r_next = Vec3::ZERO; // R_{k+1}
    for v in verts.iter().rev() {
        let a = delta * v.throughput;
        if v.emitter != NONE {
            add3(grad, l.emitter[v.emitter as usize], a * v.emission_mis);
        }
        if v.nee_emitter != NONE {
            add3(grad, l.emitter[v.nee_emitter as usize], a * v.nee_f * v.nee_scale);
        }
        let via_nee = a * v.nee_light;
        let via_path = a * r_next;
        let m = v.material as usize;
        let d_albedo = via_nee * v.nee_grad.albedo + via_path * v.beta_grad.albedo;
        add3(grad, l.albedo[m], d_albedo);
        if let Some(o) = l.roughness[m] {
            let d_r = via_nee * v.nee_grad.roughness + via_path * v.beta_grad.roughness;
            grad[o] += (d_r.x + d_r.y + d_r.z) as f64;
        }
        if !l.texels.is_empty() {
            let tex = d.materials[m].albedo_tex;
            if tex != NONE {
                for &(t, texel, o) in &l.texels {
                    if t == tex {
                        let wgt = bilinear_weight(&d.textures[t as usize], v.uv, texel);
                        add3(grad, Some(o), d_albedo * wgt);
                    }
                }
            }
        }
        r_next = v.local + v.beta * r_next;
    }
}

fn add3(grad: &mut [f64], at: Option<usize>, v: Vec3) {
    if let Some(o) = at {
        grad[o] += v.x as f64;
        grad[o + 1] += v.y as f64;
        grad[o + 2] += v.z as f64;
    }
}

/// Weight of texel `texel` in the bilinear lookup at uv (render/texture.rs's footprint, with wrap).
fn bilinear_weight(t: &TextureGpu, uv: Vec2, texel: u32) -> f32 {
    let x = uv.x * t.width as f32 - 0.5;
    let y = (1.0 - uv.y) * t.height as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (w, h) = (t.width as i32, t.height as i32);
    let wrap = |i: i32, n: i32| ((i % n) + n) % n;
    let (ix, iy) = (x0 as i32, y0 as i32);
    let mut weight = 0.0;
    for (dx, dy, wt) in
        [(0, 0, (1.0 - fx) * (1.0 - fy)), (1, 0, fx * (1.0 - fy)), (0, 1, (1.0 - fx) * fy), (1, 1, fx * fy)]
    {
        if (wrap(iy + dy, h) * w + wrap(ix + dx, w)) as u32 == texel {
            weight += wt;
        }
    }
    weight
}
