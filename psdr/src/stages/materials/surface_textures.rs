//! Procedural materials for the surfaces a photo shows (PSDR-Room, "Material and lighting stage": crops, the
//! material search and the texture-transform search), after the homogeneous fit:
//!
//! 1. the crop: the rectangle inside the segment's mask with the largest square in it (cut to at most
//!    `max_crop` pixels and twice its width a side, centred), cut from the detail photo when there is one (the
//!    photo over the working view at more pixels: a brick course is 3 working pixels on a 512x384 photo's
//!    wall, and its mortar averages away);
//! 2. the crop as albedo: the photo divided by the shading the fitted lights give there (photo x albedo /
//!    render, per channel: the render is the fitted homogeneous albedo times that shading, at the working
//!    size and resampled onto the detail crop: shading is smooth);
//! 3. the surface's uv under every crop pixel (`samples` x `samples` rays per pixel against the fitted scene),
//!    so candidates are compared as the camera sees them, perspective and all, and a chosen scale is the
//!    surface's own uv transform;
//! 4. a crop whose luminance varies less than `min_contrast` about its local mean (standard deviation over
//!    a box blur an eighth of the crop wide: texture, not the smooth shading residue a fit leaves), judged at
//!    the working size (the detail photo's grain would add to it), is flat:
//!    it stays homogeneous. Otherwise the library is searched (`search_materials_on`: texture descriptor, mean colour,
//!    fineness; scales and rotations) and the best match replaces the homogeneous albedo when it reproduces
//!    the crop's local contrast closely (|contrast(view) - contrast(crop)| below `contrast_tolerance`, 0.5,
//!    of the crop's: the flat colour's error is the whole contrast). The descriptor ranks
//!    materials but cannot make this call: it sees colour, which dominates its energy on a plank floor;
//! 5. applied as the library material's procedural albedo (`scene::Procedural`), its graph's parameters, tint
//!    and uv scale first fitted to the crop by the texture descriptor (`graph_fit`: no rendering, exact
//!    gradients), then tinted per channel so its mean is the fitted albedo (the lights' fit stays valid), with
//!    the found rotation. The joint optimisation may move the graph further;
//! 6. registered (`texture_registration`, when `register`): rotation, scale and offset found by correlating the
//!    texture with the photo's albedo over every pixel of the segment, so tiles, courses and seams fall on the
//!    photo's own (the descriptor cannot see where a pattern sits). With registration every one of the
//!    `top_k` matches that reproduces the crop's contrast is applied (at the library's parameters) and
//!    registered, each on a copy of the scene, and the one whose registered texture is closest to the photo's
//!    albedo pixel by pixel is kept, its graph then fitted (step 5) and registered again: the descriptor ranks
//!    but does not decide (real room11's brick walls ranked terrazzo, granite, checker tiles and a rug before
//!    bricks, and registered bricks alone came closer than flat). The kept one is taken back where it is not
//!    clearly closer than the flat albedo (`error_ratio` not below `max_error_ratio`, 0.9): the segment stays
//!    homogeneous;
//! 7. the kept material's graph, tint and uv transform fitted once more, block by block where it was
//!    registered (`aligned_graph_fit`: the error ratio itself by Adam, on at most `aligned_max_cells` blocks,
//!    each seen through lookups spread over it), kept where that lowers the error ratio, and the texture taken
//!    back where that ratio is not below `max_error_ratio`: the descriptor fit of step 5 cannot see a grout
//!    line's width or darkness apart from the tiles' contrast (real room00's floor: image error 6.14 -> 5.12 %;
//!    its true tile parameters give 4.61 %).
//!
//! Every segment's crop, top matches and decision are returned (result.json keeps them as alternatives).

use super::albedo_division::Segment;
use super::aligned_graph_fit::{fit_graph_on_cells, AlignedFit};
use super::graph_fit::{fit_graph_to_crop, tint_to_mean, GraphFit, GraphFitOptions};
use super::material_search::{search_materials_with, view_at, LibraryTexture, MaterialEncoder, MaterialMatch};
use super::texture_registration::{register_texture, Cells, Registration, RegistrationOptions};
use super::texture_view::UvGrid;
use crate::backend::Backend;
use crate::base::squarest_rect;
use crate::error::{Error, Result};
use crate::loss::{Image, Tensor};
use crate::render::bvh::trace_closest;
use crate::render::camera::camera_ray;
use crate::render::layout::SHADING_HAS_UVS;
use crate::render::SceneData;
use crate::scene::{Color, Procedural, Scene, UvTransform};
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct SurfaceTextureOptions {
    /// Samples per pixel of the render the shading comes from.
    pub spp: u32,
    pub top_k: usize,
    pub colour_weight: f32,
    /// Crops whose luminance varies less than this about its local mean stay homogeneous.
    pub min_contrast: f32,
    /// Crops smaller than this (pixels, either side; the texture descriptor needs 24) are not searched; larger
    /// ones are cut to `max_crop`.
    pub min_crop: usize,
    pub max_crop: usize,
    /// Rays per pixel side for the uv grid (a pixel's footprint).
    pub samples: usize,
    /// The best match is applied when its local contrast is within this fraction of the crop's (a flat colour
    /// misses it by the whole of it).
    pub contrast_tolerance: f32,
    /// The chosen material's graph parameters and tint fitted to the crop (`graph_fit`; 0 iterations: the
    /// library's parameters, tinted).
    pub graph_fit: GraphFitOptions,
    /// An ONNX image encoder whose similarity between crop and material joins the ranking (the paper's CLIP
    /// search), with this weight on (1 - cosine).
    pub embedding: Option<std::path::PathBuf>,
    pub embedding_weight: f32,
    /// Step 6: the applied material registered on the segment's pixels.
    pub register: bool,
    pub registration: RegistrationOptions,
    /// Step 7: the registered material's graph fitted on the segment's pixels (0 iterations: not), on at most
    /// `aligned_max_cells` blocks.
    pub aligned_fit: GraphFitOptions,
    pub aligned_max_cells: usize,
}

impl Default for SurfaceTextureOptions {
    fn default() -> Self {
        SurfaceTextureOptions {
            spp: 32,
            top_k: 5,
            colour_weight: 1.0,
            min_contrast: 0.08,
            min_crop: 24,
            max_crop: 64,
            samples: 3,
            contrast_tolerance: 0.5,
            graph_fit: GraphFitOptions::default(),
            embedding: None,
            embedding_weight: 1.0,
            register: true,
            registration: RegistrationOptions::default(),
            aligned_fit: GraphFitOptions::default(),
            aligned_max_cells: 4_000,
        }
    }
}

/// What the stage saw and did for one segment.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SurfaceTexture {
    pub material: String,
    /// x, y, width, height of the crop in the (working) photo.
    pub crop: Option<[usize; 4]>,
    /// The same crop in the detail photo the search saw (see `texture_surfaces`), when there was one.
    pub detail_crop: Option<[usize; 4]>,
    /// Local contrast (see `local_contrast`) of the crop at the working size: whether the surface is textured.
    pub contrast: f32,
    /// The same of the crop the search saw (the detail photo's, where there is one) and of the best match seen
    /// through its transform there: whether the match reproduces it.
    pub search_contrast: Option<f32>,
    pub match_contrast: Option<f32>,
    /// The best library materials, best first, with their uv transforms.
    pub matches: Vec<MaterialMatch>,
    /// The one applied, if any.
    pub chosen: Option<MaterialMatch>,
    /// Why it stayed homogeneous, or what was applied.
    pub decision: String,
    /// The fit of the applied material's graph to the crop.
    pub graph_fit: Option<GraphFit>,
    /// Where the applied material was registered on the segment (step 6).
    pub registration: Option<Registration>,
    /// The other matches applied and registered on a copy of the scene, not kept (step 6).
    pub tried: Vec<TriedMaterial>,
    /// The kept material's graph fitted pixel by pixel where it was registered (step 7).
    pub aligned_fit: Option<AlignedFit>,
}

/// A match applied and registered on a copy of the scene and not kept: its squared error against the photo's
/// albedo over the flat albedo's (None: it could not be registered).
#[derive(Clone, Debug, serde::Serialize)]
pub struct TriedMaterial {
    pub name: String,
    pub error_ratio: Option<f32>,
}

/// Runs steps 1-5 on every segment (see the module) and changes the chosen materials in `scene`; the shading
/// render runs on `backend`. `detail`, when given, is the photo over the same view at a higher resolution
/// (`Observations::photo_detail`): the crops are cut from it (at most `max_crop` of its pixels a side), the
/// working render's shading resampled onto them, so a texture the working size averages away (a brick wall's
/// mortar at 3 working pixels a course) is there to be recognised. Masks, the crop's place and the joint
/// pass's crop pairs stay in working pixels.
pub fn texture_surfaces(
    backend: &mut dyn Backend,
    scene: &mut Scene,
    photo: &[f32],
    detail: Option<&Image>,
    segments: &[Segment],
    library: &[LibraryTexture],
    opts: &SurfaceTextureOptions,
) -> Result<Vec<SurfaceTexture>> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let detail = detail_or_working("texture_surfaces", photo, detail, (w, h))?;
    let has_detail = matches!(detail, std::borrow::Cow::Borrowed(_));
    let detail = detail.as_ref();
    let working = Image { width: w, height: h, channels: 3, data: photo.to_vec() };
    let k = [detail.width as f32 / w as f32, detail.height as f32 / h as f32];
    let progress = crate::progress::activity(
        format!("textures: the shading at {} spp, then the library searched per segment", opts.spp.max(1)),
        Some(segments.len()),
    );
    let data = SceneData::build(scene)?;
    let mut settings = scene.settings.clone();
    settings.spp = opts.spp.max(1);
    let render = backend.render(&data, &settings, &|_, _| {})?.radiance;
    let shading = blurred(&render, w, h);
    let mut model = opts.embedding.as_deref().map(crate::vision::load_embedding_model).transpose()?;
    let mut encoder = model.as_mut().map(|model| MaterialEncoder { model, weight: opts.embedding_weight });
    let mut out = vec![];
    for seg in segments {
        progress.advance();
        let material = scene
            .materials
            .get(seg.material)
            .ok_or_else(|| Error::Invalid(format!("texture_surfaces: no material {}", seg.material)))?;
        let mut entry = SurfaceTexture {
            material: material.name.clone(),
            crop: None,
            detail_crop: None,
            contrast: 0.0,
            search_contrast: None,
            match_contrast: None,
            matches: vec![],
            chosen: None,
            decision: String::new(),
            graph_fit: None,
            registration: None,
            tried: vec![],
            aligned_fit: None,
        };
        let Color::Constant(albedo) = material.albedo else {
            entry.decision = "already textured".into();
            out.push(entry);
            continue;
        };
        if seg.mask.len() != w * h {
            return Err(Error::Invalid(format!("texture_surfaces: the mask of '{}' is not {w}x{h}", entry.material)));
        }
        let mask = Image { width: w, height: h, channels: 1, data: seg.mask.clone() };
        let Some(mut r) = squarest_rect(&mask)? else {
            entry.decision = "no pixels".into();
            out.push(entry);
            continue;
        };
        if r.w < opts.min_crop || r.h < opts.min_crop {
            entry.decision = format!("crop {}x{} smaller than {} pixels: homogeneous", r.w, r.h, opts.min_crop);
            out.push(entry);
            continue;
        }
        // At most max_crop detail pixels a side and twice as long as wide, centred.
        let side = (2 * r.w.min(r.h)).min((opts.max_crop as f32 / k[0].max(k[1])).floor() as usize).max(1);
        for (pos, len) in [(&mut r.x, &mut r.w), (&mut r.y, &mut r.h)] {
            if *len > side {
                *pos += (*len - side) / 2;
                *len = side;
            }
        }
        entry.crop = Some([r.x, r.y, r.w, r.h]);
        let rd = detail_rect([r.x, r.y, r.w, r.h], k, detail);
        if has_detail {
            entry.detail_crop = Some(rd);
        }
        // The texture gate looks at the working crop: its threshold was set there, and the detail photo's own
        // noise (a photo's grain, a render's samples) adds contrast a plain wall does not have (real room04's
        // plain wall: 0.042 working, 0.084 at 1.6x, and stucco chosen).
        entry.contrast = local_contrast(&albedo_crop(
            &working,
            &render,
            albedo,
            w,
            [r.x, r.y, r.w, r.h],
            [r.x, r.y, r.w, r.h],
            [1.0; 2],
        ));
        let crop = albedo_crop(detail, &render, albedo, w, [r.x, r.y, r.w, r.h], rd, k);
        let crop_contrast = local_contrast(&crop);
        entry.search_contrast = Some(crop_contrast);
        let Some(grid) = uv_grid(&data, seg.material as u32, rd, k, opts.samples.max(1)) else {
            entry.decision = "the fitted surface under the crop is another or has no uvs: homogeneous".into();
            out.push(entry);
            continue;
        };
        if entry.contrast < opts.min_contrast {
            entry.decision = format!("contrast {:.3} below {}: homogeneous", entry.contrast, opts.min_contrast);
            out.push(entry);
            continue;
        }
        entry.matches =
            search_materials_with(&crop, &grid, library, opts.top_k.max(1), opts.colour_weight, encoder.as_mut())?;
        let best = entry.matches.first().cloned().expect("the library is not empty");
        let library_texture =
            |name: &str| library.iter().find(|t| t.name == name).expect("matches come from the library");
        let contrast_of =
            |m: &MaterialMatch| local_contrast(&view_at(library_texture(&m.name), m.scale, m.rotation_deg, &grid));
        entry.match_contrast = Some(contrast_of(&best));
        // The candidates: the best match, or with registration each of the top matches, that reproduces the
        // crop's local contrast. The descriptor ranks them but cannot see where a pattern sits nor tell bricks
        // from a stone of their colour (real room11's brick walls ranked terrazzo and granite first); the
        // registration compares each with every pixel of the segment, and the one closest to the photo's
        // albedo is kept.
        let ranked = if opts.register { &entry.matches[..] } else { &entry.matches[..1] };
        let mut rejected = vec![];
        let candidates: Vec<&MaterialMatch> = ranked
            .iter()
            .filter(|m| {
                let c = contrast_of(m);
                let pass = (c - crop_contrast).abs() < opts.contrast_tolerance * crop_contrast;
                if !pass {
                    rejected.push(format!("{} has contrast {c:.3} against the crop's {crop_contrast:.3}", m.name));
                }
                pass
            })
            .collect();
        if candidates.is_empty() {
            entry.decision = format!("{}: homogeneous", rejected.join("; "));
            out.push(entry);
            continue;
        }
        // The photo's albedo under the fitted shading, per working pixel.
        let map: Vec<f32> = match opts.register {
            true => (0..w * h * 3).map(|i| (photo[i] * albedo[i % 3] / shading[i].max(1e-4)).clamp(0.0, 1.0)).collect(),
            false => vec![],
        };
        let pixels = seg.mask.iter().filter(|&&m| m > 0.5).count();
        let cells = opts.register.then(|| {
            let side = ((pixels as f64 / opts.registration.max_cells.max(1) as f64).sqrt().ceil() as usize).max(1);
            Cells::gather(&data, seg.material as u32, &seg.mask, &map, side)
        });
        // Each candidate applied to a copy of the scene and registered there; the kept one's copy replaces it.
        // With several, they are compared at the library's parameters and only the closest has its graph fitted
        // to the crop (then registered again, and kept fitted where that comes out closer): the fit refines a
        // family's look, the registration tells the families apart.
        let register = |scene: &mut Scene| {
            cells.as_ref().and_then(|cells| register_texture(scene, seg.material, albedo, cells, &opts.registration))
        };
        let compare_unfitted = candidates.len() > 1 && cells.is_some() && opts.graph_fit.iters > 0;
        let unfitted = GraphFitOptions { iters: 0, ..opts.graph_fit.clone() };
        let compare = if compare_unfitted { &unfitted } else { &opts.graph_fit };
        let mut trials = vec![];
        for m in candidates {
            let mut scene = scene.clone();
            let graph_fit =
                apply(&mut scene, seg.material, library_texture(&m.name), albedo, m, &grid, &crop, compare)?;
            let registration = register(&mut scene);
            trials.push(Trial { scene, chosen: m.clone(), graph_fit, registration });
        }
        let k = (0..trials.len()).min_by(|&a, &b| trials[a].error().total_cmp(&trials[b].error())).unwrap_or(0);
        entry.tried = trials
            .iter()
            .enumerate()
            .filter(|&(i, _)| i != k)
            .map(|(_, t)| TriedMaterial {
                name: t.chosen.name.clone(),
                error_ratio: t.registration.as_ref().map(|r| r.error_ratio),
            })
            .collect();
        let mut kept = trials.swap_remove(k);
        if compare_unfitted {
            let mut scene = scene.clone();
            let m = &kept.chosen;
            let graph_fit =
                apply(&mut scene, seg.material, library_texture(&m.name), albedo, m, &grid, &crop, &opts.graph_fit)?;
            let fitted = Trial { registration: register(&mut scene), scene, chosen: m.clone(), graph_fit };
            if fitted.error() <= kept.error() {
                kept = fitted;
            }
        }
        entry.decision = kept.describe();
        if !entry.tried.is_empty() {
            let others: Vec<String> =
                entry.tried.iter().map(|t| format!("{} ({:.2})", t.name, t.error_ratio.unwrap_or(f32::NAN))).collect();
            entry.decision += &format!("; closer than {}", others.join(", "));
        }
        if !rejected.is_empty() {
            entry.decision += &format!("; not tried: {}", rejected.join("; "));
        }
        (entry.registration, entry.graph_fit) = (kept.registration, kept.graph_fit);
        if entry.registration.as_ref().is_some_and(|r| !r.applied) {
            // Farther from the photo, pixel by pixel, than the flat albedo: the homogeneous material stays.
            entry.decision += &format!(" (not below {}): homogeneous", opts.registration.max_error_ratio);
        } else {
            // Step 7; its blocks see the texture as the camera does (each block's lookups spread over it, where the
            // registration filters one lookup to the block's longer side), so its error ratio is the closer
            // measure, and the texture is taken back where that is not below the same bar (real room00's sofa:
            // 0.90 registered, 1.05 so).
            let mut keep = true;
            if opts.aligned_fit.iters > 0 && entry.registration.is_some() {
                let side = ((pixels as f64 / opts.aligned_max_cells.max(1) as f64).sqrt().ceil() as usize).max(1);
                let fit = fit_where_registered(&mut kept.scene, seg.material, &seg.mask, &map, side, albedo, opts)?;
                if let Some(f) = &fit {
                    let error = if f.applied { f.error_after } else { f.error_before };
                    keep = error < opts.registration.max_error_ratio;
                    entry.decision += &format!(
                        "; its graph fitted where registered ({} blocks): error ratio {:.3} -> {:.3}{}{}",
                        f.cells,
                        f.error_before,
                        f.error_after,
                        if f.applied { "" } else { ", not kept" },
                        if keep {
                            String::new()
                        } else {
                            format!(" (not below {}): homogeneous", opts.registration.max_error_ratio)
                        }
                    );
                }
                entry.aligned_fit = fit;
            }
            if keep {
                *scene = kept.scene;
                entry.chosen = Some(kept.chosen);
            }
        }
        out.push(entry);
    }
    Ok(out)
}

/// A library material applied to a copy of the scene, and where it registered on the segment.
struct Trial {
    scene: Scene,
    chosen: MaterialMatch,
    graph_fit: Option<GraphFit>,
    registration: Option<Registration>,
}

impl Trial {
    /// The registered texture's squared error against the photo's albedo over the flat albedo's (infinite
    /// where it was not registered).
    fn error(&self) -> f32 {
        self.registration.as_ref().map_or(f32::INFINITY, |r| r.error_ratio)
    }

    fn describe(&self) -> String {
        let m = &self.chosen;
        let mut d = format!("{} at scale {:.3}, rotation {}", m.name, m.scale, m.rotation_deg);
        if let Some(r) = &self.registration {
            d += &format!(
                "; registered at scale {:.3}, rotation {}, offset ({:.3}, {:.3}): correlation {:.2} -> {:.2}, error \
                 {:.2} of the flat albedo's",
                r.scale, r.rotation_deg, r.offset[0], r.offset[1], r.correlation_before, r.correlation, r.error_ratio
            );
        }
        d
    }
}

/// The detail photo to cut from (`texture_surfaces`, `photo_textures`): `detail` when given, checked to be RGB,
/// at least the working `w` x `h` and of its aspect (to 2 %), else the working photo itself; `what` names the
/// caller in errors.
pub(super) fn detail_or_working<'a>(
    what: &str,
    photo: &[f32],
    detail: Option<&'a Image>,
    (w, h): (usize, usize),
) -> Result<std::borrow::Cow<'a, Image>> {
    if photo.len() != w * h * 3 {
        return Err(Error::Invalid(format!("{what}: the photo is not the camera's {w}x{h} RGB")));
    }
    let Some(detail) = detail else {
        return Ok(std::borrow::Cow::Owned(Image { width: w, height: h, channels: 3, data: photo.to_vec() }));
    };
    if detail.channels != 3 || detail.width < w || detail.height < h {
        return Err(Error::Invalid(format!(
            "{what}: the detail photo is {}x{}x{}, not RGB at least the working {w}x{h}",
            detail.width, detail.height, detail.channels
        )));
    }
    let k = [detail.width as f32 / w as f32, detail.height as f32 / h as f32];
    if (k[0] / k[1] - 1.0).abs() > 0.02 {
        return Err(Error::Invalid(format!(
            "{what}: the detail photo's {}x{} is not the working {w}x{h}'s aspect",
            detail.width, detail.height
        )));
    }
    Ok(std::borrow::Cow::Borrowed(detail))
}

/// Working rect `r` in detail pixels (k detail pixels per working pixel), inside the detail photo.
fn detail_rect(r: [usize; 4], k: [f32; 2], detail: &Image) -> [usize; 4] {
    let x = ((r[0] as f32 * k[0]).round() as usize).min(detail.width - 1);
    let y = ((r[1] as f32 * k[1]).round() as usize).min(detail.height - 1);
    let cw = ((r[2] as f32 * k[0]).round() as usize).clamp(1, detail.width - x);
    let ch = ((r[3] as f32 * k[1]).round() as usize).clamp(1, detail.height - y);
    [x, y, cw, ch]
}

/// The crop `rd` of detail x albedo / render (the photo's albedo under the fitted shading), clamped to 0..1.
/// The render's working rect `r` is blurred first (sigma `SHADING_BLUR` pixels): inside a crop of one surface
/// the shading is smooth, and its Monte Carlo noise, divided into the crop, would read as fine texture to the
/// descriptor (a graph fit then widens plank seams to match it); each detail pixel then takes the blurred
/// shading bilinearly at its centre (at k = 1, the working pixel itself).
fn albedo_crop(
    detail: &Image,
    render: &[f32],
    albedo: Vec3,
    w: usize,
    r: [usize; 4],
    rd: [usize; 4],
    k: [f32; 2],
) -> Image {
    let mut shading = Vec::with_capacity(r[2] * r[3] * 3);
    for y in r[1]..r[1] + r[3] {
        shading.extend_from_slice(&render[3 * (y * w + r[0])..3 * (y * w + r[0] + r[2])]);
    }
    let shading = Image { width: r[2], height: r[3], channels: 3, data: shading };
    let shading = crate::loss::blur(&Tensor::constant(shading), SHADING_BLUR).map(|t| t.value().data.clone());
    let shading = shading.expect("a positive blur of a non-empty crop");
    // Where detail pixel `i` (a column or row index) falls in the working rect starting at `start`, `len` long:
    // the two pixels either side and the weight of the second.
    let taps = |i: usize, k: f32, start: usize, len: usize| {
        let u = ((i as f32 + 0.5) / k - 0.5 - start as f32).clamp(0.0, (len - 1) as f32);
        let a = u.floor() as usize;
        (a, (a + 1).min(len - 1), u - a as f32)
    };
    let mut data = Vec::with_capacity(rd[2] * rd[3] * 3);
    for y in rd[1]..rd[1] + rd[3] {
        let (y0, y1, fy) = taps(y, k[1], r[1], r[3]);
        for x in rd[0]..rd[0] + rd[2] {
            let (x0, x1, fx) = taps(x, k[0], r[0], r[2]);
            let p = 3 * (y * detail.width + x);
            for c in 0..3 {
                let at = |yy: usize, xx: usize| shading[3 * (yy * r[2] + xx) + c];
                let top = at(y0, x0) * (1.0 - fx) + at(y0, x1) * fx;
                let bottom = at(y1, x0) * (1.0 - fx) + at(y1, x1) * fx;
                let s = top * (1.0 - fy) + bottom * fy;
                data.push((detail.data[p + c] * albedo[c] / s.max(1e-4)).clamp(0.0, 1.0));
            }
        }
    }
    Image { width: rd[2], height: rd[3], channels: 3, data }
}

/// The render blurred by `SHADING_BLUR` pixels (see `albedo_crop`), `w` x `h` RGB.
pub(super) fn blurred(render: &[f32], w: usize, h: usize) -> Vec<f32> {
    let img = Image { width: w, height: h, channels: 3, data: render.to_vec() };
    crate::loss::blur(&Tensor::constant(img), SHADING_BLUR)
        .map(|t| t.value().data.clone())
        .expect("a positive blur of a non-empty render")
}

/// Pixels of blur on the shading a crop's albedo is divided by.
const SHADING_BLUR: f32 = 2.0;

/// The luminance's standard deviation relative to its local mean (a box blur an eighth of the crop wide,
/// twice): texture, not the smooth shading a fit leaves behind (lights a little off, a highlight).
fn local_contrast(img: &Image) -> f32 {
    let (w, h) = (img.width, img.height);
    let lum: Vec<f32> = img.data.chunks(3).map(|p| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]).collect();
    let r = (w.min(h) / 8).max(1) as isize;
    let blur = |v: &[f32]| -> Vec<f32> {
        let at = |x: isize, y: isize| v[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize];
        let rows: Vec<f32> = (0..w * h)
            .map(|p| {
                let (x, y) = ((p % w) as isize, (p / w) as isize);
                (-r..=r).map(|d| at(x + d, y)).sum::<f32>() / (2 * r + 1) as f32
            })
            .collect();
        let at =
            |x: isize, y: isize| rows[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize];
        (0..w * h)
            .map(|p| {
                let (x, y) = ((p % w) as isize, (p / w) as isize);
                (-r..=r).map(|d| at(x, y + d)).sum::<f32>() / (2 * r + 1) as f32
            })
            .collect()
    };
    let smooth = blur(&blur(&lum));
    let ratio: Vec<f32> = lum.iter().zip(&smooth).map(|(l, s)| l / s.max(1e-6) - 1.0).collect();
    let n = ratio.len().max(1) as f32;
    let m = ratio.iter().sum::<f32>() / n;
    (ratio.iter().map(|v| (v - m).powi(2)).sum::<f32>() / n).sqrt()
}

/// The uvs of `material`'s surface under each pixel of the crop `r` of the detail photo (k of its pixels per
/// working pixel); pixels where the fitted scene shows another surface borrow their left (or upper)
/// neighbour's. None when more than 5 % of the pixels do.
fn uv_grid(d: &SceneData, material: u32, r: [usize; 4], k: [f32; 2], samples: usize) -> Option<UvGrid> {
    let origin = Vec3::from(d.camera.origin);
    let mut uvs: Vec<Vec<[f64; 2]>> = Vec::with_capacity(r[2] * r[3]);
    for y in r[1]..r[1] + r[3] {
        for x in r[0]..r[0] + r[2] {
            let mut px = vec![];
            for j in 0..samples {
                for i in 0..samples {
                    let (sx, sy) = ((i as f32 + 0.5) / samples as f32, (j as f32 + 0.5) / samples as f32);
                    let dir = camera_ray(&d.camera, (x as f32 + sx) / k[0], (y as f32 + sy) / k[1]);
                    let Some(hit) = trace_closest(&d.nodes, &d.triangles, origin, dir, f32::INFINITY) else { continue };
                    let t = hit.triangle as usize;
                    let sh = &d.shading[t];
                    if d.triangles[t].material != material || sh.flags & SHADING_HAS_UVS == 0 {
                        continue;
                    }
                    let uv = Vec2::from(sh.uv0) * (1.0 - hit.u - hit.v)
                        + Vec2::from(sh.uv1) * hit.u
                        + Vec2::from(sh.uv2) * hit.v;
                    px.push([uv.x as f64, uv.y as f64]);
                }
            }
            uvs.push(px);
        }
    }
    let missing = uvs.iter().filter(|p| p.is_empty()).count();
    if missing * 20 > uvs.len() {
        return None;
    }
    for k in 0..uvs.len() {
        if uvs[k].is_empty() {
            let from = if k % r[2] > 0 { k - 1 } else { k.saturating_sub(r[2]) };
            uvs[k] = uvs[from].clone();
        }
    }
    if uvs.iter().any(|p| p.is_empty()) {
        return None;
    }
    Some(UvGrid { width: r[2], height: r[3], uvs })
}

/// Step 7 on the kept scene: the material's graph fitted on blocks of `side` working pixels of its segment
/// (`mask`), seen through its registered transform and its surfaces' shifted uvs, against the photo's albedo
/// `map`; applied where it lowers the error ratio. None where the material is not procedural or no block shows
/// it.
fn fit_where_registered(
    scene: &mut Scene,
    material: usize,
    mask: &[f32],
    map: &[f32],
    side: usize,
    flat: Vec3,
    opts: &SurfaceTextureOptions,
) -> Result<Option<AlignedFit>> {
    let Some(mut p) = scene.materials[material].procedural.clone() else { return Ok(None) };
    let cells = Cells::gather(&SceneData::build(scene)?, material as u32, mask, map, side);
    if cells.len() < 16 {
        return Ok(None);
    }
    let transform = scene.materials[material].uv_transform;
    let (error_before, error_after, fitted) = fit_graph_on_cells(&mut p, transform, &cells, flat, &opts.aligned_fit)?;
    let applied = error_after < error_before;
    if applied {
        scene.set_procedural(material, p)?;
        scene.materials[material].uv_transform = fitted;
    }
    Ok(Some(AlignedFit { error_before, error_after, cells: cells.len(), cell_pixels: side, applied }))
}

/// The library material as the material's procedural albedo through the found transform, its graph fitted to
/// the crop (when `fit.iters` > 0), tinted to mean `albedo`.
#[allow(clippy::too_many_arguments)]
fn apply(
    scene: &mut Scene,
    material: usize,
    tex: &LibraryTexture,
    albedo: Vec3,
    m: &MaterialMatch,
    grid: &UvGrid,
    crop: &Image,
    fit: &GraphFitOptions,
) -> Result<Option<GraphFit>> {
    let n = (tex.size * tex.size) as f32;
    let mean = Vec3::from_array(std::array::from_fn(|c| tex.albedo.iter().skip(c).step_by(3).sum::<f32>() / n));
    let mut p = Procedural::new(&tex.name, tex.size as u32)?;
    p.tint = albedo / mean.max(Vec3::splat(1e-4));
    let mut scale = m.scale;
    let report = if fit.iters > 0 {
        Some(fit_graph_to_crop(&mut p, &mut scale, m.rotation_deg, grid, crop, fit)?)
    } else {
        None
    };
    // The segment's fitted albedo is the better estimate of the mean (the crop is one part of the surface,
    // under the shading's local errors): the tint brings the fitted graph back to it.
    tint_to_mean(&mut p, albedo)?;
    scene.set_procedural(material, p)?;
    let mat = &mut scene.materials[material];
    mat.uv_transform = UvTransform { scale: Vec2::splat(scale), rotation_deg: m.rotation_deg, offset: Vec2::ZERO };
    Ok(report)
}
