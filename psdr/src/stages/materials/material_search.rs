//! Choosing a procedural material for a photo crop (PSDR-Room, "Material and lighting stage": the paper's CLIP
//! search and texture-transform search, weight-free here): every library material's albedo at default
//! parameters is viewed through a texture transform over a crop-sized patch (uv 0..1), and compared with the
//! crop by the scale-free texture descriptor loss (Gram matrices of a fixed filter bank, `loss::texture_loss`)
//! plus the distance of the mean colours (chromaticity, and weakly brightness). A first pass ranks the library
//! at a few scales; the leaders then get the transform search (scales 0.5-8 in steps of 2^(1/4), rotations -45,
//! 0, 45, 90 degrees, then the scale refined around the best in steps of 2^(1/16) and 2^(1/32)). Crops
//! should be albedo: the photo's colour divided by the shading the fitted lights give (see the caller).

use super::texture_view::{texture_view, UvGrid};
use crate::error::{Error, Result};
use crate::loss::{texture_descriptor, texture_loss_to, Image, Tensor};
use crate::vision::{cosine, embed, OnnxModel};
use psdr_materials::{library, Evaluator};
use rayon::prelude::*;

/// A library material's albedo texture at default parameters.
#[derive(Clone, Debug)]
pub struct LibraryTexture {
    pub name: String,
    pub size: usize,
    /// Linear RGB, size x size, row 0 on top.
    pub albedo: Vec<f32>,
}

/// Every library material's albedo at `size` x `size` texels.
pub fn library_textures(size: usize) -> Result<Vec<LibraryTexture>> {
    let mut out = vec![];
    for name in library::names() {
        let g = library::load(name)
            .ok_or_else(|| Error::Invalid(format!("material library: no '{name}'")))?
            .map_err(|e| Error::Invalid(format!("material library: {name}: {e}")))?;
        let mut ev = Evaluator::new(g.clone(), size);
        let albedo = ev.forward(&g.default_params()).albedo_linear.clone();
        out.push(LibraryTexture { name: name.to_string(), size, albedo });
    }
    Ok(out)
}

/// A `size` x `size` patch of a surface whose uv spans 0..1 across it, seen through `scale` and `rotation_deg`.
pub fn transformed_view(tex: &LibraryTexture, scale: f32, rotation_deg: f32, size: usize) -> Image {
    view_at(tex, scale, rotation_deg, &UvGrid::unit_square(size))
}

/// The library texture as the crop's pixels would show it through the transform (mip-filtered,
/// `texture_view`).
pub fn view_at(tex: &LibraryTexture, scale: f32, rotation_deg: f32, grid: &UvGrid) -> Image {
    texture_view(tex.size, &tex.albedo, scale, rotation_deg, grid)
}

/// One candidate and how well it matches.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MaterialMatch {
    pub name: String,
    pub scale: f32,
    pub rotation_deg: f32,
    /// Texture descriptor loss (at the crop's colour and contrast) + `colour_weight` x mean-colour distance
    /// (chromaticity, and half the |ln| of the brightness ratio) + |ln| of the fineness ratio + |ln| of the
    /// contrast ratio (lower is better).
    pub distance: f32,
    /// The descriptor loss alone.
    pub texture_distance: f32,
    /// Cosine similarity of the crop's and the material's view's embeddings, when an image encoder ranked them
    /// too (the distance then includes weight x (1 - similarity)).
    pub embedding_similarity: Option<f32>,
}

/// An ONNX image encoder and its weight in the ranking: the paper's CLIP search of the material library, with
/// whatever encoder a user has (a CLIP image tower, a style/texture encoder).
pub struct MaterialEncoder<'a> {
    pub model: &'a mut OnnxModel,
    pub weight: f32,
}

fn mean(img: &Image) -> [f32; 3] {
    let n = (img.width * img.height).max(1) as f32;
    let mut m = [0.0f32; 3];
    for p in img.data.chunks(img.channels) {
        for c in 0..3 {
            m[c] += p[c.min(img.channels - 1)] / n;
        }
    }
    m
}

/// Mean gradient magnitude over the standard deviation of the luminance: how fine a texture is. Zooming out
/// by s multiplies it by about s, which the Gram descriptor (contrast-normalised, pooled) only weakly sees.
fn fineness(img: &Image) -> f32 {
    let (w, h, c) = (img.width, img.height, img.channels);
    let lum: Vec<f32> = img.data.chunks(c).map(|p| p.iter().sum::<f32>() / c as f32).collect();
    let n = lum.len() as f32;
    let m = lum.iter().sum::<f32>() / n;
    let sd = (lum.iter().map(|v| (v - m).powi(2)).sum::<f32>() / n).sqrt().max(1e-6);
    let mut g = 0.0;
    for y in 0..h - 1 {
        for x in 0..w - 1 {
            let p = lum[y * w + x];
            g += ((lum[y * w + x + 1] - p).powi(2) + (lum[(y + 1) * w + x] - p).powi(2)).sqrt();
        }
    }
    g / ((w - 1) * (h - 1)) as f32 / sd
}

/// Standard deviation of the luminance over its mean.
pub fn contrast(img: &Image) -> f32 {
    let c = img.channels;
    let lum: Vec<f32> = img.data.chunks(c).map(|p| p.iter().sum::<f32>() / c as f32).collect();
    let n = lum.len().max(1) as f32;
    let m = lum.iter().sum::<f32>() / n;
    (lum.iter().map(|v| (v - m).powi(2)).sum::<f32>() / n).sqrt() / m.max(1e-6)
}

/// (total distance, descriptor loss of the view at the crop's colour and contrast). The descriptor sees
/// colour (its filters are zero-mean over all channels together, not per channel), which would dominate its
/// energy, so the view is first brought to the crop's mean colour (per-channel gain, as it is applied) and
/// contrast; colour, contrast and fineness are then judged apart, each as a relative or log-ratio error.
fn distance(
    crop_descriptor: &Tensor,
    crop_stats: &CropStats,
    mut view: Image,
    colour_weight: f32,
) -> Result<(f32, f32)> {
    let m = mean(&view);
    let crop_mean = crop_stats.mean;
    let colour = colour_distance(m, crop_mean);
    let scale = (fineness(&view).max(1e-6) / crop_stats.fineness.max(1e-6)).ln().abs();
    let view_contrast = contrast(&view).max(1e-6);
    let contrast_error = (view_contrast / crop_stats.contrast.max(1e-6)).ln().abs();
    let k = crop_stats.contrast / view_contrast;
    for p in view.data.chunks_mut(3) {
        (0..3).for_each(|c| p[c] = crop_mean[c] + (p[c] - m[c]) * crop_mean[c] / m[c].max(1e-4) * k);
    }
    let tex = texture_loss_to(&Tensor::constant(view), crop_descriptor)?.item().unwrap_or(f32::INFINITY);
    Ok((tex + colour_weight * colour + scale + contrast_error, tex))
}

/// How far two mean colours are, as a light left in the crop would move them least: the distance of their
/// chromaticities (each channel over the mean of the three) plus `BRIGHTNESS_WEIGHT` x the |ln| of their
/// brightness ratio, so a gain g on the crop costs the same whichever way; the relative RGB distance this
/// replaced cost 1.0 for a gain of 0.5 and 0.4 for 1.6, and dim crops lost their own material
/// (bench_texture_search).
fn colour_distance(a: [f32; 3], b: [f32; 3]) -> f32 {
    let lum = |c: [f32; 3]| (c.iter().sum::<f32>() / 3.0).max(1e-4);
    let (la, lb) = (lum(a), lum(b));
    let chroma = (0..3).map(|c| (a[c] / la - b[c] / lb).powi(2)).sum::<f32>().sqrt();
    chroma + BRIGHTNESS_WEIGHT * (la / lb).ln().abs()
}

/// The weight of the |ln| of the brightness ratio in `colour_distance`. (A crop's brightness is the albedo
/// division's, whose level the lights' scale leaves open: real room08's brick wall came out 3x as bright as
/// the library's brick and its crop went to terrazzo, brick_wall's descriptor loss a third of terrazzo's. At
/// 0.1 that wall and room11's became brick_wall, but a varied oak floor went to wood_grain
/// (tests/tests/procedural_fit.rs); the log of the descriptor loss in the ranking did the same for the bricks
/// and sent a walnut crop under a cool light to rattan_wicker: benchmarks/README.md.)
const BRIGHTNESS_WEIGHT: f32 = 0.5;

/// What the distance needs of the crop, computed once.
struct CropStats {
    mean: [f32; 3],
    fineness: f32,
    contrast: f32,
}

/// Ranks `library` for `crop` (albedo, linear RGB, square is best): the best `top_k` with their transforms.
pub fn search_materials(
    crop: &Image,
    library: &[LibraryTexture],
    top_k: usize,
    colour_weight: f32,
) -> Result<Vec<MaterialMatch>> {
    let size = crop.width.min(crop.height);
    search_materials_on(crop, &UvGrid::unit_square(size), library, top_k, colour_weight)
}

/// Ranks `library` for `crop` seen through `grid` (the surface's uv under each crop pixel, same size as the
/// crop): the best `top_k`, each with the uv transform (scale in repeats per uv unit, rotation) that makes the
/// surface look most like the crop. Scales are searched from 0.5 to 8 repeats across the crop's uv span.
pub fn search_materials_on(
    crop: &Image,
    grid: &UvGrid,
    library: &[LibraryTexture],
    top_k: usize,
    colour_weight: f32,
) -> Result<Vec<MaterialMatch>> {
    search_materials_with(crop, grid, library, top_k, colour_weight, None)
}

/// `search_materials_on`, with an image encoder's similarity between the crop and each material's view (at
/// the first pass's scale) in the ranking when one is given.
pub fn search_materials_with(
    crop: &Image,
    grid: &UvGrid,
    library: &[LibraryTexture],
    top_k: usize,
    colour_weight: f32,
    encoder: Option<&mut MaterialEncoder>,
) -> Result<Vec<MaterialMatch>> {
    if (grid.width, grid.height) != (crop.width, crop.height) || crop.channels != 3 {
        return Err(Error::Invalid(format!(
            "material search: the crop is {}x{}x{}, its uv grid {}x{}",
            crop.width, crop.height, crop.channels, grid.width, grid.height
        )));
    }
    let unit = 1.0 / grid.span() as f32;
    let stats = CropStats { mean: mean(crop), fineness: fineness(crop), contrast: contrast(crop) };
    // The crop's descriptor once; as a tensor per task (tensors are not shared across threads).
    let crop_descriptor = texture_descriptor(&Tensor::constant(crop.clone()))?.value().clone();
    let score = |crop_d: &Tensor, tex: &LibraryTexture, scale: f32, rotation: f32| {
        distance(crop_d, &stats, view_at(tex, scale * unit, rotation, grid), colour_weight)
    };
    // First pass: scales a factor sqrt(2) apart, no rotation. Materials are scored in parallel (each view is
    // built on one thread; the crops are small, so a view's own descriptor keeps two cores half busy).
    let mut first: Vec<MaterialMatch> = library
        .par_iter()
        .map(|tex| {
            let crop_d = Tensor::constant(crop_descriptor.clone());
            let mut best = MaterialMatch {
                name: tex.name.clone(),
                scale: 1.0,
                rotation_deg: 0.0,
                distance: f32::INFINITY,
                texture_distance: f32::INFINITY,
                embedding_similarity: None,
            };
            for k in 0..9 {
                let scale = 0.5 * 2f32.powf(k as f32 / 2.0);
                let (d, t) = score(&crop_d, tex, scale, 0.0)?;
                if d < best.distance {
                    (best.scale, best.distance, best.texture_distance) = (scale, d, t);
                }
            }
            Ok(best)
        })
        .collect::<Result<_>>()?;
    let appearance = |m: &MaterialMatch, w: f32| m.embedding_similarity.map_or(0.0, |s| w * (1.0 - s));
    let weight = encoder.as_ref().map_or(0.0, |e| e.weight);
    if let Some(enc) = encoder {
        let of_crop = embed(enc.model, crop)?;
        for m in first.iter_mut() {
            let tex = library.iter().find(|t| t.name == m.name).expect("from the library");
            let of_view = embed(enc.model, &view_at(tex, m.scale * unit, 0.0, grid))?;
            m.embedding_similarity = Some(cosine(&of_crop, &of_view));
            m.distance += appearance(m, enc.weight);
        }
    }
    first.sort_by(|a, b| a.distance.total_cmp(&b.distance));
    // The leaders' transform search.
    let leaders = (2 * top_k).max(top_k + 2).min(first.len());
    let leader_search = |m: &MaterialMatch| -> Result<MaterialMatch> {
        let tex =
            library.iter().find(|t| t.name == m.name).ok_or_else(|| Error::Invalid("material vanished".into()))?;
        let crop_d = Tensor::constant(crop_descriptor.clone());
        let mut best = m.clone();
        for k in 0..13 {
            let scale = 0.5 * 2f32.powf(k as f32 / 4.0);
            for rotation in [-45.0f32, 0.0, 45.0, 90.0] {
                let (d, t) = score(&crop_d, tex, scale, rotation)?;
                let d = d + appearance(m, weight);
                if d < best.distance {
                    (best.scale, best.rotation_deg, best.distance, best.texture_distance) = (scale, rotation, d, t);
                }
            }
        }
        // The scale between the grid's points: two finer passes around the best (steps 2^(1/16), then 2^(1/32)).
        for step in [16.0f32, 32.0] {
            let centre = best.scale;
            for k in [-2, -1, 1, 2] {
                let scale = centre * 2f32.powf(k as f32 / step);
                let (d, t) = score(&crop_d, tex, scale, best.rotation_deg)?;
                let d = d + appearance(m, weight);
                if d < best.distance {
                    (best.scale, best.distance, best.texture_distance) = (scale, d, t);
                }
            }
        }
        Ok(best)
    };
    let mut out: Vec<MaterialMatch> = first[..leaders].par_iter().map(leader_search).collect::<Result<_>>()?;
    out.sort_by(|a, b| a.distance.total_cmp(&b.distance));
    out.truncate(top_k);
    out.iter_mut().for_each(|m| m.scale *= unit);
    Ok(out)
}
