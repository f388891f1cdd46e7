//! Gloss where the photo shows it: a specular lobe (roughness and specular level) for each segment whose pixels
//! a glossy material reproduces clearly better than a matte one (a varnished floor's highlights under the
//! ceiling lights, a lacquered cabinet's sheen).
//!
//! The albedo division and the joint pass cannot find this: at specular 0 the lobe is absent and its gradient
//! is nothing, and a highlight divided out reads as a brighter albedo. So each candidate roughness is tried on
//! every tested segment at once (interreflections between segments are second order): a render `G` with the
//! tested materials given that lobe at the renders' specular level, less a matte render `M'` of the same
//! samples, is the light the lobe adds (`L = G - M'`: the highlights, the room mirrored, less the diffuse
//! light the Fresnel term takes). Per segment the photo `P` is fitted in closed form as `a M + k L`, `M` a
//! matte render of other samples: a scale `a` on the albedo per colour channel and one specular scale `k` for
//! the three (a dielectric's highlight is the light's colour), least squares over the segment's unclipped
//! pixels in blocks (the renders' noise averages out); the matte fit is the same with `k = 0`. `L` is taken
//! from `M'`, not `M`: a difference sharing `M`'s noise would average two renders' noise and lower the error
//! of any surface (a matte room's cabinet and table took lobes at 0.89-0.90 of the matte error). A segment
//! takes the candidate of least error where that is below `1 - min_gain` of the matte fit's and a neighbouring
//! candidate's is below `1 - min_gain / 2` (a lobe's gain is smooth in roughness; noise's is not): its roughness,
//! specular `k` times the renders' level (at most 1), the albedo times `a`; else it is matte (specular 0), its
//! albedo as the division left it. The Fresnel term is not linear in the specular level, so `k` is a close
//! estimate; an albedo division after it settles the albedo under the lobe.

use super::albedo_division::{Segment, ALBEDO_RANGE};
use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::render::SceneData;
use crate::scene::{Color, Scalar, Scene};
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct GlossOptions {
    /// Samples per pixel of each render (two matte ones, one per candidate).
    pub spp: u32,
    /// The candidate roughnesses (perceptual: GGX alpha = roughness^2), tried in increasing order.
    pub roughness: Vec<f32>,
    /// The specular level the candidates are rendered at; a segment's own is `k` times it, at most 1.
    pub specular: f32,
    /// A lobe is kept where its squared error is below (1 - this) times the matte fit's.
    pub min_gain: f32,
    /// Pixels compared in blocks of this side.
    pub block: usize,
    /// Segments with fewer (unclipped) pixels than this are left as they are.
    pub min_pixels: f32,
}

impl Default for GlossOptions {
    fn default() -> Self {
        GlossOptions {
            spp: 16,
            roughness: vec![0.1, 0.2, 0.35, 0.5],
            specular: 1.0,
            min_gain: 0.15,
            block: 4,
            min_pixels: 200.0,
        }
    }
}

/// One candidate lobe's fit on one segment.
#[derive(Clone, Debug, serde::Serialize)]
pub struct GlossCandidate {
    pub roughness: f32,
    /// The fitted specular level (k times the renders' level, at most 1).
    pub specular: f32,
    /// Its squared error over the matte fit's.
    pub error_ratio: f32,
}

/// What was decided for one material (result.json's `gloss`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct GlossChoice {
    pub material: String,
    pub glossy: bool,
    pub roughness: f32,
    pub specular: f32,
    /// The best candidate's error over the matte fit's.
    pub error_ratio: f32,
    pub tried: Vec<GlossCandidate>,
    pub decision: String,
}

/// One segment's blocks: per block its weight and the weighted means of the photo (P), the matte render (X) and
/// the light a lobe adds (Z; zero for the matte fit), per channel.
struct Blocks {
    weight: Vec<f32>,
    photo: Vec<Vec3>,
    diffuse: Vec<Vec3>,
    specular: Vec<Vec3>,
}

/// Scale per channel `a` and one `k` in 0..=k_max minimising sum_b w_b |P - a X - k Z|^2; the error with them.
fn fit_blocks(b: &Blocks, k_max: f32) -> (Vec3, f32, f32) {
    let dot = |u: &[Vec3], v: &[Vec3]| -> Vec3 {
        u.iter().zip(v).zip(&b.weight).fold(Vec3::ZERO, |acc, ((x, y), &w)| acc + w * *x * *y)
    };
    let (pp, xx, zz) = (dot(&b.photo, &b.photo), dot(&b.diffuse, &b.diffuse), dot(&b.specular, &b.specular));
    let (xp, zp, xz) = (dot(&b.diffuse, &b.photo), dot(&b.specular, &b.photo), dot(&b.diffuse, &b.specular));
    let xx = xx.max(Vec3::splat(1e-12));
    // With a per channel eliminated the error is quadratic in k: its minimum, clamped.
    let num = (zp - xz * xp / xx).element_sum();
    let den = (zz - xz * xz / xx).element_sum();
    let k = if den > 1e-12 { (num / den).clamp(0.0, k_max) } else { 0.0 };
    let a = ((xp - k * xz) / xx).max(Vec3::ZERO);
    let err = pp - 2.0 * a * xp - 2.0 * k * zp + a * a * xx + 2.0 * k * a * xz + k * k * zz;
    (a, k, err.element_sum().max(0.0))
}

fn block_sums(photo: &[f32], r: &[f32], z: Option<&[f32]>, mask: &[f32], w: usize, h: usize, side: usize) -> Blocks {
    let (bw, bh) = (w.div_ceil(side), h.div_ceil(side));
    let n = bw * bh;
    let (mut weight, mut sp, mut sx, mut sz) =
        (vec![0.0f32; n], vec![Vec3::ZERO; n], vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    let px = |img: &[f32], i: usize| Vec3::new(img[3 * i], img[3 * i + 1], img[3 * i + 2]);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let m = mask[i];
            if m <= 0.0 {
                continue;
            }
            let b = (y / side) * bw + x / side;
            let spec = z.map_or(Vec3::ZERO, |z| px(z, i));
            weight[b] += m;
            sp[b] += m * px(photo, i);
            sx[b] += m * px(r, i);
            sz[b] += m * spec;
        }
    }
    let keep: Vec<usize> = (0..n).filter(|&b| weight[b] > 0.0).collect();
    let mean = |s: &[Vec3]| keep.iter().map(|&b| s[b] / weight[b]).collect();
    Blocks {
        photo: mean(&sp),
        diffuse: mean(&sx),
        specular: mean(&sz),
        weight: keep.iter().map(|&b| weight[b]).collect(),
    }
}

fn render(backend: &mut dyn Backend, scene: &Scene, spp: u32, seed: u32) -> Result<Vec<f32>> {
    let mut settings = scene.settings.clone();
    (settings.spp, settings.seed) = (spp.max(1), seed);
    Ok(backend.render(&SceneData::build(scene)?, &settings, &|_, _| {})?.radiance)
}

/// The scene with every material of `tested` given this lobe.
fn with_lobe(scene: &Scene, tested: &[usize], roughness: f32, specular: f32) -> Scene {
    let mut s = scene.clone();
    for &m in tested {
        s.materials[m].roughness = Scalar::Constant(roughness);
        s.materials[m].specular = Scalar::Constant(specular);
    }
    s
}

/// Decides each segment's lobe (above) and sets it, with the albedo its fit scales to. In place.
pub fn fit_gloss(
    backend: &mut dyn Backend,
    scene: &mut Scene,
    photo: &[f32],
    segments: &[Segment],
    opts: &GlossOptions,
) -> Result<Vec<GlossChoice>> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    if photo.len() != w * h * 3 {
        return Err(Error::Invalid(format!("fit_gloss: the photo is not the camera's {w}x{h} RGB")));
    }
    if let Some(bad) = opts.roughness.iter().find(|r| !(0.0..=1.0).contains(*r)) {
        return Err(Error::Invalid(format!("fit_gloss: a candidate roughness of {bad}, not within 0..1")));
    }
    if !(opts.specular > 0.0 && opts.specular <= 1.0) {
        return Err(Error::Invalid(format!(
            "fit_gloss: the renders' specular level {} is not within (0, 1]",
            opts.specular
        )));
    }
    let mut roughness = opts.roughness.clone();
    roughness.sort_by(f32::total_cmp);
    let unclipped = crate::vision::unclipped(photo, w);
    // The segments tested: a constant albedo and lobe, enough unclipped pixels.
    let mut tested: Vec<(usize, Vec<f32>)> = vec![];
    for seg in segments {
        if seg.mask.len() != w * h {
            return Err(Error::Invalid(format!("fit_gloss: a segment's mask is not {w}x{h}")));
        }
        let m =
            scene.materials.get(seg.material).ok_or_else(|| Error::Invalid("fit_gloss: no such material".into()))?;
        let constant = matches!(
            (m.albedo, m.roughness, m.specular),
            (Color::Constant(_), Scalar::Constant(_), Scalar::Constant(_))
        );
        let mask: Vec<f32> = seg.mask.iter().zip(&unclipped).map(|(a, b)| a * b).collect();
        if constant && mask.iter().sum::<f32>() >= opts.min_pixels && !tested.iter().any(|t| t.0 == seg.material) {
            tested.push((seg.material, mask));
        }
    }
    if tested.is_empty() {
        return Ok(vec![]);
    }
    let materials: Vec<usize> = tested.iter().map(|t| t.0).collect();
    let progress = crate::progress::activity(
        format!("gloss: {} lobes tried on {} materials at {} spp", roughness.len(), tested.len(), opts.spp),
        Some(1 + roughness.len()),
    );
    let side = opts.block.max(1);
    let seed = scene.settings.seed;
    let matte_scene = with_lobe(scene, &materials, 1.0, 0.0);
    let matte = render(backend, &matte_scene, opts.spp, seed)?;
    // The lobes are differences from a matte render of their own samples: fitted on `matte`'s, a difference
    // sharing its noise would average two renders' noise and lower the error on any surface.
    let paired = render(backend, &matte_scene, opts.spp, seed.wrapping_add(1))?;
    progress.advance();
    let matte_fits: Vec<f32> =
        tested.iter().map(|(_, mask)| fit_blocks(&block_sums(photo, &matte, None, mask, w, h, side), 0.0).2).collect();
    // Per candidate, per segment: (albedo scale, specular scale, error).
    let mut fits: Vec<Vec<(Vec3, f32, f32)>> = vec![];
    for &r in &roughness {
        let glossy = render(backend, &with_lobe(scene, &materials, r, opts.specular), opts.spp, seed.wrapping_add(1))?;
        progress.advance();
        let lobe: Vec<f32> = glossy.iter().zip(&paired).map(|(g, m)| g - m).collect();
        let k_max = 1.0 / opts.specular;
        fits.push(
            tested
                .iter()
                .map(|(_, mask)| fit_blocks(&block_sums(photo, &matte, Some(&lobe), mask, w, h, side), k_max))
                .collect(),
        );
    }
    let mut out = vec![];
    for (t, (m, _)) in tested.iter().enumerate() {
        let matte_err = matte_fits[t];
        let ratio = |err: f32| if matte_err > 0.0 { err / matte_err } else { 1.0 };
        let tried: Vec<GlossCandidate> = roughness
            .iter()
            .zip(&fits)
            .map(|(&r, f)| GlossCandidate {
                roughness: r,
                specular: (f[t].1 * opts.specular).min(1.0),
                error_ratio: ratio(f[t].2),
            })
            .collect();
        let material = &mut scene.materials[*m];
        let Color::Constant(albedo) = material.albedo else { continue };
        let clamp = |a: Vec3| a.clamp(Vec3::splat(ALBEDO_RANGE.0), Vec3::splat(ALBEDO_RANGE.1));
        let mut choice = GlossChoice {
            material: material.name.clone(),
            glossy: false,
            roughness: 1.0,
            specular: 0.0,
            error_ratio: tried.iter().map(|c| c.error_ratio).fold(1.0, f32::min),
            tried: tried.clone(),
            decision: String::new(),
        };
        match kept_lobe(&tried, opts.min_gain) {
            Ok(b) => {
                let c = &tried[b];
                (choice.glossy, choice.roughness, choice.specular) = (true, c.roughness, c.specular);
                choice.decision = format!(
                    "glossy: roughness {:.2}, specular {:.2}, its error {:.2} of the matte fit's (below {:.2})",
                    c.roughness,
                    c.specular,
                    c.error_ratio,
                    1.0 - opts.min_gain
                );
                material.albedo = Color::Constant(clamp(albedo * fits[b][t].0));
            }
            Err(why) => choice.decision = format!("matte: {why}"),
        }
        material.roughness = Scalar::Constant(choice.roughness);
        material.specular = Scalar::Constant(choice.specular);
        out.push(choice);
    }
    Ok(out)
}

/// The candidate kept (index into `tried`, in increasing roughness), or why none is: the least error must be
/// below `1 - min_gain` of the matte fit's with a specular level above 0, and a neighbouring candidate's below
/// `1 - min_gain / 2`: a lobe's gain varies smoothly with its roughness, while one candidate gaining alone
/// fits the renders' noise or a texture's residue (real room08's books: 0.88 at roughness 0.1, none at 0.2).
fn kept_lobe(tried: &[GlossCandidate], min_gain: f32) -> std::result::Result<usize, String> {
    let Some(b) = (0..tried.len()).min_by(|&a, &b| tried[a].error_ratio.total_cmp(&tried[b].error_ratio)) else {
        return Err("no lobe tried".into());
    };
    let c = &tried[b];
    if !(c.error_ratio < 1.0 - min_gain && c.specular > 0.0) {
        return Err(format!(
            "the best lobe's error {:.2} of the matte fit's, not below {:.2}",
            c.error_ratio,
            1.0 - min_gain
        ));
    }
    let neighbour =
        [b.wrapping_sub(1), b + 1].iter().any(|&n| tried.get(n).is_some_and(|c| c.error_ratio < 1.0 - 0.5 * min_gain));
    if tried.len() > 1 && !neighbour {
        return Err(format!(
            "only roughness {:.2} lowers the error ({:.2} of the matte fit's), no neighbour below {:.3}",
            c.roughness,
            c.error_ratio,
            1.0 - 0.5 * min_gain
        ));
    }
    Ok(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blocks(photo: &[Vec3], diffuse: &[Vec3], specular: &[Vec3]) -> Blocks {
        Blocks {
            weight: vec![1.0; photo.len()],
            photo: photo.to_vec(),
            diffuse: diffuse.to_vec(),
            specular: specular.to_vec(),
        }
    }

    #[test]
    fn the_closed_form_recovers_a_mix_of_diffuse_and_specular() {
        let diffuse: Vec<Vec3> =
            (0..20).map(|i| Vec3::new(1.0 + i as f32 * 0.1, 0.8, 0.5 + (i % 3) as f32 * 0.2)).collect();
        let specular: Vec<Vec3> =
            (0..20).map(|i| Vec3::splat(if i % 5 == 0 { 0.6 } else { 0.05 * i as f32 })).collect();
        let (a, k) = (Vec3::new(0.7, 0.5, 0.3), 0.4);
        let photo: Vec<Vec3> = diffuse.iter().zip(&specular).map(|(d, s)| a * *d + k * *s).collect();
        let (fa, fk, err) = fit_blocks(&blocks(&photo, &diffuse, &specular), 10.0);
        assert!((fa - a).abs().max_element() < 1e-4, "{fa:?}");
        assert!((fk - k).abs() < 1e-4, "{fk}");
        assert!(err < 1e-6, "{err}");
        // k held to its bound: a fits what is left.
        let (_, fk, err) = fit_blocks(&blocks(&photo, &diffuse, &specular), 0.2);
        assert_eq!(fk, 0.2);
        assert!(err > 1e-4);
    }

    #[test]
    fn a_lobe_is_kept_where_it_and_a_neighbour_gain() {
        let tried = |ratios: &[f32]| -> Vec<GlossCandidate> {
            ratios
                .iter()
                .enumerate()
                .map(|(i, &e)| GlossCandidate { roughness: 0.1 * (i + 1) as f32, specular: 0.5, error_ratio: e })
                .collect()
        };
        // The known-geometry room's varnished floor and real room08's: kept.
        assert_eq!(kept_lobe(&tried(&[0.92, 0.37, 0.43, 0.74]), 0.15), Ok(1));
        assert_eq!(kept_lobe(&tried(&[1.0, 0.925, 0.836, 0.92]), 0.15), Ok(2));
        // One candidate gaining alone (as real room08's books did, 0.88 at roughness 0.1 and none elsewhere).
        assert!(kept_lobe(&tried(&[0.8, 1.0, 1.0, 1.0]), 0.15).unwrap_err().contains("only roughness 0.10"));
        // Not enough gain; nothing tried.
        assert!(kept_lobe(&tried(&[0.9, 0.88, 0.95]), 0.15).unwrap_err().contains("not below 0.85"));
        assert!(kept_lobe(&[], 0.15).is_err());
        // One candidate: no neighbour to ask.
        assert_eq!(kept_lobe(&tried(&[0.5]), 0.15), Ok(0));
    }

    #[test]
    fn bad_input_is_named() {
        use crate::backend::CpuBackend;
        use crate::scene::{Camera, Material};
        let mut scene = Scene::empty(Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 4, 4));
        scene.materials = vec![Material::diffuse("floor", Vec3::splat(0.5))];
        let segs = [Segment { material: 0, mask: vec![1.0; 16] }];
        let photo = vec![0.5; 48];
        let err = |photo: &[f32], opts: &GlossOptions| {
            fit_gloss(&mut CpuBackend, &mut scene.clone(), photo, &segs, opts).unwrap_err().to_string()
        };
        assert!(err(&photo[..47], &GlossOptions::default()).contains("not the camera's 4x4 RGB"));
        let rough = GlossOptions { roughness: vec![0.2, 1.5], ..Default::default() };
        assert!(err(&photo, &rough).contains("roughness of 1.5"));
        let level = GlossOptions { specular: f32::NAN, ..Default::default() };
        assert!(err(&photo, &level).contains("specular level NaN"));
        // Too few pixels to test: nothing decided, nothing changed.
        let mut s = scene.clone();
        assert!(fit_gloss(&mut CpuBackend, &mut s, &photo, &segs, &GlossOptions::default()).unwrap().is_empty());
        assert_eq!(s.materials, scene.materials);
    }

    #[test]
    fn a_matte_photo_takes_no_specular() {
        let diffuse: Vec<Vec3> = (0..10).map(|i| Vec3::splat(0.5 + 0.1 * i as f32)).collect();
        let specular: Vec<Vec3> = (0..10).map(|i| Vec3::splat(if i == 3 { 1.0 } else { 0.0 })).collect();
        // The photo is darker exactly where the lobe would add light: the best k is negative, held at 0.
        let photo: Vec<Vec3> = diffuse.iter().zip(&specular).map(|(d, s)| 0.6 * *d - 0.3 * *s).collect();
        let (_, k, _) = fit_blocks(&blocks(&photo, &diffuse, &specular), 10.0);
        assert_eq!(k, 0.0);
    }
}
