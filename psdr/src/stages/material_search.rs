//! Choosing a procedural material for a photo crop (PSDR-Room, "Material and lighting stage": the paper's CLIP
//! search and texture-transform search, weight-free here): every library material's albedo at default
//! parameters is viewed through a texture transform over a crop-sized patch (uv 0..1), and compared with the
//! crop by the scale-free texture descriptor loss (Gram matrices of a fixed filter bank, `loss::texture_loss`)
//! plus the relative distance of the mean colours. A first pass ranks the library at a few scales; the leaders
//! then get the transform search (scales 0.5-8 in steps of 2^(1/4), rotations -45, 0, 45, 90 degrees). Crops
//! should be albedo: the photo's colour divided by the shading the fitted lights give (see the caller).

use crate::error::{Error, Result};
use crate::loss::{texture_loss, Image, Tensor};
use psdr_materials::{library, Evaluator, TextureTransform, TextureView};

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
    let view = TextureView { width: tex.size, height: tex.size, channels: 3, texels: &tex.albedo };
    let t = TextureTransform { scale: [scale as f64; 2], rotation_deg: rotation_deg as f64, offset: [0.0, 0.0] };
    let mut data = Vec::with_capacity(size * size * 3);
    let mut px = [0.0f64; 3];
    for y in 0..size {
        for x in 0..size {
            let uv = [(x as f64 + 0.5) / size as f64, 1.0 - (y as f64 + 0.5) / size as f64];
            t.lookup(&view, uv, &mut px);
            data.extend(px.iter().map(|v| *v as f32));
        }
    }
    Image { width: size, height: size, channels: 3, data }
}

/// One candidate and how well it matches.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MaterialMatch {
    pub name: String,
    pub scale: f32,
    pub rotation_deg: f32,
    /// Texture descriptor loss + `colour_weight` x relative mean-colour distance + |ln| of the fineness ratio
    /// (lower is better).
    pub distance: f32,
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

fn distance(crop: &Tensor, crop_mean: [f32; 3], crop_fineness: f32, view: Image, colour_weight: f32) -> Result<f32> {
    let m = mean(&view);
    let norm = crop_mean.iter().map(|v| v * v).sum::<f32>().sqrt().max(1e-4);
    let colour = (0..3).map(|c| (m[c] - crop_mean[c]).powi(2)).sum::<f32>().sqrt() / norm;
    let scale = (fineness(&view).max(1e-6) / crop_fineness.max(1e-6)).ln().abs();
    let tex = texture_loss(&Tensor::constant(view), crop)?.item().unwrap_or(f32::INFINITY);
    Ok(tex + colour_weight * colour + scale)
}

/// Ranks `library` for `crop` (albedo, linear RGB, square is best): the best `top_k` with their transforms.
pub fn search_materials(
    crop: &Image,
    library: &[LibraryTexture],
    top_k: usize,
    colour_weight: f32,
) -> Result<Vec<MaterialMatch>> {
    let size = crop.width.min(crop.height);
    let crop_t = Tensor::constant(crop.clone());
    let crop_mean = mean(crop);
    let crop_fineness = fineness(crop);
    // First pass: a few scales, no rotation.
    let mut first: Vec<MaterialMatch> = vec![];
    for tex in library {
        let mut best = MaterialMatch { name: tex.name.clone(), scale: 1.0, rotation_deg: 0.0, distance: f32::INFINITY };
        for scale in [1.0f32, 2.0, 4.0] {
            let d =
                distance(&crop_t, crop_mean, crop_fineness, transformed_view(tex, scale, 0.0, size), colour_weight)?;
            if d < best.distance {
                (best.scale, best.distance) = (scale, d);
            }
        }
        first.push(best);
    }
    first.sort_by(|a, b| a.distance.total_cmp(&b.distance));
    // The leaders' transform search.
    let leaders = (2 * top_k).max(top_k + 2).min(first.len());
    let mut out: Vec<MaterialMatch> = vec![];
    for m in first.iter().take(leaders) {
        let tex =
            library.iter().find(|t| t.name == m.name).ok_or_else(|| Error::Invalid("material vanished".into()))?;
        let mut best = m.clone();
        for k in 0..13 {
            let scale = 0.5 * 2f32.powf(k as f32 / 4.0);
            for rotation in [-45.0f32, 0.0, 45.0, 90.0] {
                let d = distance(
                    &crop_t,
                    crop_mean,
                    crop_fineness,
                    transformed_view(tex, scale, rotation, size),
                    colour_weight,
                )?;
                if d < best.distance {
                    (best.scale, best.rotation_deg, best.distance) = (scale, rotation, d);
                }
            }
        }
        out.push(best);
    }
    out.sort_by(|a, b| a.distance.total_cmp(&b.distance));
    out.truncate(top_k);
    Ok(out)
}
