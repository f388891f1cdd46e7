//! Reverse mode (vector-Jacobian product) of the radiance image for parameters that do not move geometry:
//! emitter radiance, material albedo, roughness and specular constants, albedo and roughness texels, uv scale
//! and rotation, and a procedural material's graph parameters and tint (its whole albedo texture's gradient
//! accumulated, then chained through the graph's backward, `ProceduralChain`).
//! The interior term only: these
//! parameters create no discontinuities, so there is no boundary term for them.
//!
//! Each sample's path is recorded (`path_record`) with its local terms per vertex; a backward sweep over the
//! recorded vertices then distributes the pixel's adjoint onto the parameters. With vertex k's throughput T_k, its MIS-weighted
//! emission e_k, its next-event term n_k and its continuation weight β_k (f·cos/pdf, /q after roulette):
//!     L = Σ_k T_k e_k + T_k n_k,   R_k = e_k + n_k + β_k R_{k+1},
//!     ∂L/∂θ = Σ_k T_k (∂n_k/∂θ + ∂β_k/∂θ R_{k+1} + ∂e_k/∂θ).
//! Sampling densities, light selection and MIS weights are held fixed (detached), which keeps the estimator
//! unbiased. Memory is one vertex list per thread (bounded by max_depth) and one gradient row per image row,
//! independent of spp; rows are reduced in order, so the result is identical on any thread count.

use crate::error::{Error, Result};
use crate::grad::ad::bsdf_grad::{bsdf_albedo_grad, bsdf_eval_grad, BsdfGrad};
use crate::grad::interior::normal_map::{bsdf_normal_adjoint, normal_map_jacobian, normal_map_uv_tangents};
use crate::grad::path::record::{record_path, PathRecord, RecordedVertex};
use crate::grad::{accumulate_blocks, check_adjoint};
use crate::render::bsdf::BsdfParams;
use crate::render::cpu::frame_params;
use crate::render::layout::{TextureGpu, NONE};
use crate::render::light::emitter_shape;
use crate::render::texture::{texel_index, texture_footprint};
use crate::render::SceneData;
use crate::scene::ParamPath;
use crate::scene::{Color, Procedural, RenderSettings, Scalar, Scene};
use glam::{Vec2, Vec3};
use psdr_materials::{TextureTransform, TextureView, TransformGrad};

/// Which BSDF derivatives a material's parameters need (the discriminants are the GPU adjoint's codes).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Wanted {
    Nothing = 0,
    Albedo = 1,
    All = 2,
}

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
    specular: Vec<Option<usize>>,
    /// (texture, texel index, offset) of single albedo texels and of single roughness texels.
    texels: Vec<(u32, u32, usize)>,
    rough_texels: Vec<(u32, u32, usize)>,
    /// The same for normal-map texels.
    normal_texels: Vec<(u32, u32, usize)>,
    /// Per material: which derivatives of its BSDF values some parameter needs.
    material_wanted: Vec<Wanted>,
    /// Per material: some parameter lives in texture space (texels, whole maps, the uv transform), so the albedo
    /// and roughness adjoints read at a vertex go through `texture_read_adjoint`.
    texture_reads: Vec<bool>,
    /// Per material: its normal map has requested texels or its uv transform is requested, so the normal-map
    /// adjoint at a vertex goes through `normal_read_adjoint`.
    normal_reads: Vec<bool>,
    /// Some parameter moves shading normals (normal-map texels, the uv transform of a normal-mapped material).
    pub(crate) shading_normal_wanted: bool,
    /// Per material: offsets of uv scale (2) and rotation (1) gradients, and the transform itself.
    uv_scale: Vec<Option<usize>>,
    uv_rotation: Vec<Option<usize>>,
    uv_transform: Vec<TextureTransform>,
    /// (texture, offset) of whole albedo textures whose every texel's gradient is accumulated (past `len`),
    /// and the procedural materials those gradients are chained into.
    albedo_maps: Vec<(u32, usize)>,
    chains: Vec<ProceduralChain>,
    /// Length of the gradient vector the passes accumulate: `len` plus the whole textures.
    pub(crate) extended_len: usize,
}

/// The GPU adjoint's slot table (`GradLayout::device_slots`).
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceSlots {
    pub materials: usize,
    pub emitters: usize,
    /// Albedo offsets per material, radiance offsets per emitter, roughness and specular offsets per material,
    /// then per material the BSDF derivatives wanted (0 none, 1 albedo, 2 all), its reads wanted (1 albedo and
    /// roughness textures, 2 the normal map) and its uv transform (scale x, scale y, rotation in degrees, as f32
    /// bits).
    pub table: Vec<u32>,
    /// Some material's texture or normal-map reads are wanted: the kernel writes them out for
    /// `texture_read_adjoint` and `normal_read_adjoint`.
    pub texture_reads: bool,
}

/// A procedural material some of whose graph parameters or tint are requested.
#[derive(Clone, Debug)]
struct ProceduralChain {
    texture: u32,
    procedural: Procedural,
    /// Offset of the texture's texel gradients (3 per texel) in the extended gradient.
    texels_at: usize,
    /// (offset in the graph's float parameters, entries, offset in the gradient) of each requested parameter.
    params: Vec<(usize, usize, usize)>,
    tint: Option<usize>,
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
            specular: vec![None; scene.materials.len()],
            texels: vec![],
            rough_texels: vec![],
            normal_texels: vec![],
            material_wanted: vec![],
            texture_reads: vec![],
            normal_reads: vec![],
            shading_normal_wanted: false,
            uv_scale: vec![None; scene.materials.len()],
            uv_rotation: vec![None; scene.materials.len()],
            uv_transform: scene.materials.iter().map(|m| m.uv_transform.texture_transform()).collect(),
            albedo_maps: vec![],
            chains: vec![],
            extended_len: 0,
        };
        for p in params {
            let n = p.get(scene)?.len();
            let at = l.len;
            let unsupported = || {
                Error::Invalid(format!(
                    "{p}: analytic gradients cover light radiance, material albedo/roughness/specular constants, \
                     albedo, roughness and normal-map texels, uv scale and rotation, and object translation, yaw, \
                     rotation, scale and vertices; use --fd for this parameter"
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
                ParamPath::MaterialSpecular(name) => {
                    l.specular[scene.material_index(name).expect("checked")] = Some(at)
                }
                ParamPath::UvScale(name) | ParamPath::UvRotation(name) => {
                    let m = scene.material_index(name).expect("checked");
                    match p {
                        ParamPath::UvScale(_) => l.uv_scale[m] = Some(at),
                        _ => l.uv_rotation[m] = Some(at),
                    }
                }
                ParamPath::MaterialTexel { material, slot: crate::scene::TextureSlot::Albedo, x, y } => {
                    let m = &scene.materials[scene.material_index(material).expect("checked")];
                    let Color::Texture(t) = m.albedo else { unreachable!("checked by get") };
                    l.texels.push((t as u32, y * scene.textures[t].width + x, at));
                }
                ParamPath::MaterialTexel { material, slot: crate::scene::TextureSlot::Roughness, x, y } => {
                    let m = &scene.materials[scene.material_index(material).expect("checked")];
                    let Scalar::Texture(t) = m.roughness else { unreachable!("checked by get") };
                    l.rough_texels.push((t as u32, y * scene.textures[t].width + x, at));
                }
                ParamPath::MaterialTexel { material, slot: crate::scene::TextureSlot::NormalMap, x, y } => {
                    let m = &scene.materials[scene.material_index(material).expect("checked")];
                    let t = m.normal_map.expect("checked by get");
                    l.normal_texels.push((t as u32, y * scene.textures[t].width + x, at));
                }
                ParamPath::GraphParam { material, .. } | ParamPath::ProceduralTint(material) => {
                    let mat = &scene.materials[scene.material_index(material).expect("checked")];
                    let (Some(proc), Color::Texture(t)) = (&mat.procedural, mat.albedo) else {
                        unreachable!("checked by get")
                    };
                    let c = match l.chains.iter().position(|c| c.texture == t as u32) {
                        Some(c) => c,
                        None => {
                            l.chains.push(ProceduralChain {
                                texture: t as u32,
                                procedural: proc.clone(),
                                texels_at: 0,
                                params: vec![],
                                tint: None,
                            });
                            l.chains.len() - 1
                        }
                    };
                    match p {
                        ParamPath::GraphParam { name, .. } => {
                            let (g_at, g_len) = proc.float_param(&proc.load_graph()?, name)?;
                            l.chains[c].params.push((g_at, g_len, at));
                        }
                        _ => l.chains[c].tint = Some(at),
                    }
                }
                _ => return Err(unsupported()),
            }
            l.offsets.push(at);
            l.len += n;
        }
        l.extended_len = l.len;
        for c in &mut l.chains {
            c.texels_at = l.extended_len;
            l.albedo_maps.push((c.texture, c.texels_at));
            l.extended_len += (c.procedural.size * c.procedural.size * 3) as usize;
        }
        let has =
            |list: &[(u32, u32, usize)], t: Option<usize>| t.is_some_and(|t| list.iter().any(|e| e.0 as usize == t));
        for (m, mat) in scene.materials.iter().enumerate() {
            let albedo_tex = if let Color::Texture(t) = mat.albedo { Some(t) } else { None };
            let rough_tex = if let Scalar::Texture(t) = mat.roughness { Some(t) } else { None };
            let uv = l.uv_scale[m].is_some() || l.uv_rotation[m].is_some();
            let albedo_map = albedo_tex.is_some_and(|t| l.albedo_maps.iter().any(|e| e.0 as usize == t));
            let (albedo_texels, rough_texels) = (has(&l.texels, albedo_tex), has(&l.rough_texels, rough_tex));
            l.material_wanted.push(if l.roughness[m].is_some() || l.specular[m].is_some() || uv || rough_texels {
                Wanted::All
            } else if l.albedo[m].is_some() || albedo_texels || albedo_map {
                Wanted::Albedo
            } else {
                Wanted::Nothing
            });
            l.texture_reads.push(uv || albedo_texels || albedo_map || rough_texels);
            let normal = mat.normal_map;
            l.normal_reads.push(
                normal.is_some() && (uv || normal.is_some_and(|t| l.normal_texels.iter().any(|e| e.0 as usize == t))),
            );
        }
        l.shading_normal_wanted =
            !l.normal_texels.is_empty()
                || scene.materials.iter().enumerate().any(|(m, mat)| {
                    mat.normal_map.is_some() && (l.uv_scale[m].is_some() || l.uv_rotation[m].is_some())
                });
        Ok(l)
    }

    /// What the GPU adjoint (shaders/grad/interior/material_light.comp) needs when it covers every requested
    /// parameter (`DeviceSlots`): every material and light parameter; `None` for anything that moves geometry.
    pub fn device_slots(&self) -> Option<DeviceSlots> {
        let covered = self.params.iter().all(|p| {
            matches!(
                p,
                ParamPath::LightRadiance(_)
                    | ParamPath::MaterialAlbedo(_)
                    | ParamPath::MaterialRoughness(_)
                    | ParamPath::MaterialSpecular(_)
                    | ParamPath::MaterialTexel { .. }
                    | ParamPath::UvScale(_)
                    | ParamPath::UvRotation(_)
                    | ParamPath::GraphParam { .. }
                    | ParamPath::ProceduralTint(_)
            )
        });
        if !covered {
            return None;
        }
        let slot = |o: &Option<usize>| o.map_or(u32::MAX, |o| o as u32);
        let mut table: Vec<u32> = [&self.albedo, &self.emitter, &self.roughness, &self.specular]
            .iter()
            .flat_map(|v| v.iter().map(slot))
            .collect();
        table.extend(self.material_wanted.iter().map(|&w| w as u32));
        table
            .extend(self.texture_reads.iter().zip(&self.normal_reads).map(|(&t, &n)| u32::from(t) | u32::from(n) << 1));
        for t in &self.uv_transform {
            table.extend([t.scale[0] as f32, t.scale[1] as f32, t.rotation_deg as f32].map(f32::to_bits));
        }
        Some(DeviceSlots {
            materials: self.albedo.len(),
            emitters: self.emitter.len(),
            table,
            texture_reads: self.texture_reads.contains(&true) || self.normal_reads.contains(&true),
        })
    }

    /// The requested gradients (`len` values) from the extended vector the passes accumulated: whole-texture
    /// gradients chained through their procedural graphs (texels = clamp(tint · albedo(params), 0, 1)).
    pub(crate) fn finish(&self, mut grad: Vec<f64>) -> Result<Vec<f64>> {
        for c in &self.chains {
            let (mut ev, base) = c.procedural.evaluate()?;
            let g_texels = &grad[c.texels_at..c.texels_at + base.len()];
            let (d_params, d_tint) = c.procedural.backward(&mut ev, &base, g_texels, !c.params.is_empty());
            if let Some(o) = c.tint {
                grad[o..o + 3].copy_from_slice(&d_tint);
            }
            for &(g_at, n, o) in &c.params {
                let d = d_params.as_ref().expect("asked for");
                grad[o..o + n].copy_from_slice(&d[g_at..g_at + n]);
            }
        }
        grad.truncate(self.len);
        Ok(grad)
    }
}

/// dLoss/dθ for the marked parameters, given dLoss/d(radiance) per pixel channel (`adjoint`, w·h·3).
pub fn radiance_vjp(
    d: &SceneData,
    settings: &RenderSettings,
    layout: &GradLayout,
    adjoint: &[f32],
) -> Result<Vec<f64>> {
    let (w, h) = (d.camera.width as usize, d.camera.height as usize);
    check_adjoint(adjoint, w * h * 3)?;
    let fp = frame_params(d, settings);
    layout.finish(accumulate_blocks(h, layout.extended_len, |rows, grad| {
        let mut rec = PathRecord::default();
        for y in rows {
            for x in 0..w {
                let i = (y * w + x) * 3;
                let delta = Vec3::from_slice(&adjoint[i..i + 3]) / fp.spp as f32;
                if delta == Vec3::ZERO {
                    continue;
                }
                for sample in 0..fp.spp {
                    record_path(d, &fp, x as u32, y as u32, sample, &mut rec);
                    backward_sweep(d, layout, &rec.vertices, delta, grad);
                    if layout.shading_normal_wanted {
                        normal_map_sweep(d, layout, &rec, delta, grad);
                    }
                }
            }
        }
    }))
}

/// Distributes one path's adjoint `delta` (already divided by spp) onto the parameters.
pub(crate) fn backward_sweep(d: &SceneData, l: &GradLayout, verts: &[RecordedVertex], delta: Vec3, grad: &mut [f64]) {
    let mut r_next = Vec3::ZERO; // R_{k+1}
    for v in verts.iter().rev() {
        let a = delta * v.throughput;
        if v.emitter != NONE {
            add3(grad, l.emitter[v.emitter as usize], a * v.emission_shape * v.emission_mis);
        }
        let m = v.material as usize;
        let (mut d_albedo, mut d_rough, mut d_spec) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
        // BSDF derivatives only where some requested parameter reads this material, and the roughness and
        // specular ones (a dual evaluation) only when asked for.
        let grad_of = match l.material_wanted[m] {
            Wanted::Nothing => None,
            Wanted::Albedo => Some(bsdf_albedo_grad as fn(&BsdfParams, Vec3, Vec3) -> BsdfGrad),
            Wanted::All => Some(bsdf_eval_grad as fn(&BsdfParams, Vec3, Vec3) -> BsdfGrad),
        };
        if let Some(n) = &v.nee {
            add3(grad, l.emitter[n.emitter as usize], a * n.f * emitter_shape(d, n.emitter, n.dir) * n.w_over_pdf);
            if let Some(grad_of) = grad_of {
                let via_nee = a * n.radiance * n.w_over_pdf;
                let f_grad = grad_of(&v.bsdf(), v.wi_local, n.wo_local);
                d_albedo += via_nee * f_grad.albedo;
                d_rough += via_nee * f_grad.roughness;
                d_spec += via_nee * f_grad.specular;
            }
        }
        let beta = v.next.map_or(Vec3::ZERO, |c| c.beta);
        if let (Some(c), Some(grad_of)) = (&v.next, grad_of) {
            let via_path = a * r_next;
            let beta_grad = grad_of(&v.bsdf(), v.wi_local, c.wo_local).scaled(1.0 / (c.pdf * c.q));
            d_albedo += via_path * beta_grad.albedo;
            d_rough += via_path * beta_grad.roughness;
            d_spec += via_path * beta_grad.specular;
        }
        add3(grad, l.albedo[m], d_albedo);
        if let Some(o) = l.roughness[m] {
            grad[o] += (d_rough.x + d_rough.y + d_rough.z) as f64;
        }
        if let Some(o) = l.specular[m] {
            grad[o] += (d_spec.x + d_spec.y + d_spec.z) as f64;
        }
        if l.texture_reads[m] {
            texture_read_adjoint(d, l, m, v.uv, d_albedo, d_rough.x + d_rough.y + d_rough.z, grad);
        }
        r_next = v.local + beta * r_next;
    }
}

/// Carries the adjoints of the albedo and roughness material `m` read at (transformed) `uv` into texture space:
/// single texels, whole albedo maps of procedural materials, and the uv transform. The GPU adjoint writes these
/// arguments out per vertex and the host calls this in the CPU's order (backend/vk_adjoint.rs).
pub fn texture_read_adjoint(
    d: &SceneData,
    l: &GradLayout,
    m: usize,
    uv: Vec2,
    d_albedo: Vec3,
    d_rough: f32,
    grad: &mut [f64],
) {
    if l.uv_scale[m].is_some() || l.uv_rotation[m].is_some() {
        uv_transform_adjoint(d, l, m, uv, d_albedo, d_rough, grad);
    }
    let tex = d.materials[m].albedo_tex;
    for &(t, texel, o) in l.texels.iter().filter(|e| e.0 == tex) {
        let wgt = bilinear_weight(&d.textures[t as usize], uv, texel);
        add3(grad, Some(o), d_albedo * wgt);
    }
    for &(t, o) in l.albedo_maps.iter().filter(|e| e.0 == tex) {
        let f = texture_footprint(&d.textures[t as usize], uv);
        let (fx, fy) = (f.fx, f.fy);
        for (texel, wgt) in f.texel.iter().zip([(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy]) {
            add3(grad, Some(o + 3 * *texel as usize), d_albedo * wgt);
        }
    }
    // The primal clamps roughness to [0, 1]; a clamped lookup does not move.
    let tex = d.materials[m].roughness_tex;
    for &(t, texel, o) in l.rough_texels.iter().filter(|e| e.0 == tex) {
        let tg = &d.textures[t as usize];
        if (0.0..=1.0).contains(&crate::render::texture::texture_sample(&d.texels, tg, uv, 0)) {
            grad[o] += (d_rough * bilinear_weight(tg, uv, texel)) as f64;
        }
    }
}

/// Distributes one path's adjoint onto normal-map texels: at each vertex whose map has requested texels,
/// dL/dn_s from its next-event and continuation terms (R_{k+1} as in `backward_sweep`), through the mapping.
pub(crate) fn normal_map_sweep(d: &SceneData, l: &GradLayout, rec: &PathRecord, delta: Vec3, grad: &mut [f64]) {
    let verts = &rec.vertices;
    // R_{k+1} for every k, from the back.
    let mut r_after = vec![Vec3::ZERO; verts.len()];
    let mut r_next = Vec3::ZERO;
    for (k, v) in verts.iter().enumerate().rev() {
        r_after[k] = r_next;
        r_next = v.local + v.next.map_or(Vec3::ZERO, |c| c.beta) * r_next;
    }
    for (k, v) in verts.iter().enumerate() {
        let m = v.material as usize;
        if !l.normal_reads[m] {
            continue;
        }
        let incoming = if k == 0 { rec.dir } else { verts[k - 1].next.expect("a later vertex was reached").dir };
        let Some((sp, jacobian)) = normal_map_jacobian(d, v.triangle, v.u, v.v, incoming) else { continue };
        let a = delta * v.throughput;
        let mut d_ns = Vec3::ZERO;
        if let Some(n) = &v.nee {
            d_ns += bsdf_normal_adjoint(&sp, -incoming, n.dir, a * n.radiance * n.w_over_pdf);
        }
        if let Some(c) = &v.next {
            d_ns += bsdf_normal_adjoint(&sp, -incoming, c.dir, a * r_after[k] / (c.pdf * c.q));
        }
        let d_c = jacobian.transpose() * d_ns;
        let mut d_uv = [0.0f32; 3];
        if l.uv_scale[m].is_some() || l.uv_rotation[m].is_some() {
            let tr = &l.uv_transform[m];
            let scale = Vec2::new(tr.scale[0] as f32, tr.scale[1] as f32);
            let dn = normal_map_uv_tangents(d, v.triangle, v.u, v.v, incoming, scale, tr.rotation_deg as f32);
            d_uv = [d_ns.dot(dn[0]), d_ns.dot(dn[1]), d_ns.dot(dn[2])];
        }
        normal_read_adjoint(d, l, m, v.uv, d_c, d_uv, grad);
    }
}

/// Carries the adjoint of the normal map read at (transformed) `uv` of material `m` (`d_c`, per map channel) and
/// of its uv transform (`d_uv`: scale x, scale y, rotation) into the gradient: the map's requested texels by their
/// bilinear weights, the transform's slots. The GPU adjoint writes these arguments out per vertex and the host
/// calls this in the CPU's order (backend/vk_adjoint.rs).
pub fn normal_read_adjoint(
    d: &SceneData,
    l: &GradLayout,
    m: usize,
    uv: Vec2,
    d_c: Vec3,
    d_uv: [f32; 3],
    grad: &mut [f64],
) {
    let tex = d.materials[m].normal_tex;
    for &(t, texel, o) in l.normal_texels.iter().filter(|e| e.0 == tex) {
        add3(grad, Some(o), d_c * bilinear_weight(&d.textures[t as usize], uv, texel));
    }
    if let Some(o) = l.uv_scale[m] {
        grad[o] += d_uv[0] as f64;
        grad[o + 1] += d_uv[1] as f64;
    }
    if let Some(o) = l.uv_rotation[m] {
        grad[o] += d_uv[2] as f64;
    }
}

/// Chains the adjoints of the albedo and roughness read at this vertex into the material's uv transform,
/// through the differentiable lookup of psdr-materials (proven equal to the renderer's lookup).
fn uv_transform_adjoint(
    d: &SceneData,
    l: &GradLayout,
    m: usize,
    uvt: Vec2,
    d_albedo: Vec3,
    d_rough: f32,
    grad: &mut [f64],
) {
    let t = &l.uv_transform[m];
    // Back from the transformed uv the renderer recorded to the mesh uv: uv = S⁻¹ R⁻¹ (uv' − o).
    let (s, c) = t.rotation_deg.to_radians().sin_cos();
    let (x, y) = (uvt.x as f64 - t.offset[0], uvt.y as f64 - t.offset[1]);
    let uv = [(c * x + s * y) / t.scale[0], (-s * x + c * y) / t.scale[1]];
    let mat = &d.materials[m];
    let mut g = TransformGrad::default();
    for (tex, d_out) in
        [(mat.albedo_tex, d_albedo.to_array().map(f64::from).to_vec()), (mat.roughness_tex, vec![d_rough as f64])]
    {
        if tex == NONE {
            continue;
        }
        let tg = &d.textures[tex as usize];
        let texels = &d.texels[tg.offset as usize..(tg.offset + tg.width * tg.height * tg.channels) as usize];
        let view = TextureView {
            width: tg.width as usize,
            height: tg.height as usize,
            channels: tg.channels as usize,
            texels,
        };
        t.lookup_backward(&view, uv, &d_out, None, &mut g);
    }
    if let Some(o) = l.uv_scale[m] {
        grad[o] += g.scale[0];
        grad[o + 1] += g.scale[1];
    }
    if let Some(o) = l.uv_rotation[m] {
        grad[o] += g.rotation_deg;
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
    let (ix, iy) = (texel_index(x0), texel_index(y0));
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
