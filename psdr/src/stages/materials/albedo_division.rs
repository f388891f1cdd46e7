//! Albedos from shading, and the one thing shading cannot tell: how bright the lights are.
//!
//! `divide_albedos`: a surface's colour in the photo is its albedo times the light reaching it, so each
//! segment's homogeneous albedo is multiplied by the photo's mean colour over the render's there, a few rounds
//! so that interreflections settle (the light reaching one surface depends on the others' albedos), each
//! step a Newton step on how fast the surfaces' light grows with their albedos (`division_steps`).
//!
//! `search_light_scale`: scaling every light by s and dividing the albedos anew reproduces each segment's mean
//! colour for any s; only interreflections tell s apart (light bounced off a surface carries its albedo once
//! more), and they do so per colour channel. The scale is searched on a log grid over a range, each point
//! with the albedos divided anew, scored by the L1 distance to the photo at 1/downsample size per channel; per
//! channel the best grid point, refined by a parabola through its neighbours. Albedos are clamped to
//! 0.01..0.95, so a scale that would need brighter surfaces shows up as a worse fit, not a wrong albedo.
//! Both leave out the pixels where the photo is clipped (`vision::unclipped`), and render on the run's backend
//! (a GPU renders the division's many full-size images far faster than the CPU).

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::render::SceneData;
use crate::scene::{Color, Scene};
use glam::Vec3;

/// A homogeneous material and the photo's pixels that show it (weights 0..1).
#[derive(Clone, Debug)]
pub struct Segment {
    pub material: usize,
    pub mask: Vec<f32>,
}

/// Albedo bounds of the division (a real surface neither absorbs nor reflects everything).
const ALBEDO_RANGE: (f32, f32) = (0.01, 0.95);

fn mean_colour(img: &[f32], mask: &[f32]) -> Vec3 {
    let (mut sum, mut weight) = (Vec3::ZERO, 0.0f32);
    for (p, &m) in mask.iter().enumerate() {
        if m > 0.0 {
            sum += m * Vec3::new(img[3 * p], img[3 * p + 1], img[3 * p + 2]);
            weight += m;
        }
    }
    sum / weight.max(1e-6)
}

fn check(scene: &Scene, photo: &[f32], segments: &[Segment]) -> Result<()> {
    let n = (scene.camera.width * scene.camera.height) as usize;
    if photo.len() != 3 * n {
        return Err(Error::Invalid(format!(
            "albedo division: the photo has {} values, the scene's camera renders {n} RGB pixels",
            photo.len()
        )));
    }
    for s in segments {
        let m = scene
            .materials
            .get(s.material)
            .ok_or_else(|| Error::Invalid(format!("albedo division: no material {} in the scene", s.material)))?;
        if !matches!(m.albedo, Color::Constant(_)) {
            return Err(Error::Invalid(format!("albedo division: material '{}' has a textured albedo", m.name)));
        }
        if s.mask.len() != n {
            return Err(Error::Invalid(format!("albedo division: the mask of '{}' is not the photo's size", m.name)));
        }
        if s.mask.iter().sum::<f32>() <= 0.0 {
            return Err(Error::Invalid(format!("albedo division: the mask of '{}' is empty", m.name)));
        }
    }
    Ok(())
}

fn render(backend: &mut dyn Backend, scene: &Scene, spp: u32, seed: u32) -> Result<Vec<f32>> {
    let mut settings = scene.settings.clone();
    (settings.spp, settings.seed) = (spp, seed);
    Ok(backend.render(&SceneData::build(scene)?, &settings, &|_, _| {})?.radiance)
}

/// The segments' masks where the photo records the scene (its clipped pixels left out); a segment the photo
/// shows only clipped is dropped (it keeps its albedo).
fn recorded(segments: &[Segment], photo: &[f32], width: usize) -> Vec<Segment> {
    let unclipped = crate::vision::unclipped(photo, width);
    segments
        .iter()
        .map(|s| Segment { material: s.material, mask: s.mask.iter().zip(&unclipped).map(|(m, u)| m * u).collect() })
        .filter(|s| s.mask.iter().sum::<f32>() > 0.0)
        .collect()
}

/// Per segment and channel, the share of its rendered light that bounced: 1 less a render of 2-vertex paths
/// (direct light only) over `full` (0 where the scene's paths are that short).
fn bounced_shares(
    backend: &mut dyn Backend,
    scene: &Scene,
    segments: &[Segment],
    full: &[f32],
    spp: u32,
) -> Result<Vec<Vec3>> {
    if scene.settings.max_depth <= 2 {
        return Ok(vec![Vec3::ZERO; segments.len()]);
    }
    let mut direct = scene.clone();
    direct.settings.max_depth = 2;
    let img = render(backend, &direct, spp, scene.settings.seed)?;
    Ok(segments
        .iter()
        .map(|s| {
            let share = mean_colour(&img, &s.mask) / mean_colour(full, &s.mask).max(Vec3::splat(1e-6));
            (Vec3::ONE - share).clamp(Vec3::ZERO, Vec3::splat(MAX_BOUNCED))
        })
        .collect())
}

/// The bounced share `bounced_shares` reports at most (a surface lit by bounced light alone still moves).
const MAX_BOUNCED: f32 = 0.9;

/// The division's steps in log albedo, per channel: each segment's log ratio (photo mean over render mean)
/// split into the segments' common part (their pixel-weighted mean) and each one's difference from it. Light
/// that bounced carries the albedos again, so a render grows faster than its albedos. When all of them move
/// together the render grows at a rate of about 1 / (1 - b) (b: the bounced share over the segments; in a room
/// all of one albedo light bounces 1 / (1 - b) times), more as the albedos rise; the common part takes the
/// Newton step 1 / rate, the rate from that estimate in the first round and measured between rounds after (a
/// secant, within 1..MAX_RATE). A segment moving alone changes the light reaching it much less (from not at
/// all, a small object, to its own interreflection), and its difference takes 1 / (1 + b_s). The plain ratio
/// (step 1 for both) overshot and oscillated where light bounces often: at 8-vertex paths room10's
/// light-scale errors jumped 0.04 -> 0.10 -> 0.17 -> 0.04 between neighbouring factors
/// (tests/tests/albedo_division.rs: a light room's worst albedo 60 -> 68 -> 102 -> 71 -> 107 % off over rounds).
struct DivisionSteps {
    weights: Vec<f32>,
    bounced: Vec<Vec3>,
    /// The common part's rate per channel, and the previous round's mean log albedo and log ratio.
    rate: Vec3,
    last: Option<(Vec3, Vec3)>,
}

/// The fastest the segments' common render may grow with their common albedo (light bouncing 10 times).
const MAX_RATE: f32 = 10.0;

impl DivisionSteps {
    fn new(weights: Vec<f32>, bounced: Vec<Vec3>) -> DivisionSteps {
        let mut d = DivisionSteps { weights, bounced, rate: Vec3::ONE, last: None };
        let b = d.mean(&|j| d.bounced[j]);
        d.rate = (Vec3::ONE / (Vec3::ONE - b)).clamp(Vec3::ONE, Vec3::splat(MAX_RATE));
        d
    }

    fn mean(&self, v: &dyn Fn(usize) -> Vec3) -> Vec3 {
        let total = self.weights.iter().sum::<f32>().max(1e-12);
        (0..self.weights.len()).map(|j| v(j) * self.weights[j]).sum::<Vec3>() / total
    }

    /// The steps for this round's log ratios at log albedos `albedos`.
    fn steps(&mut self, ratios: &[Vec3], albedos: &[Vec3]) -> Vec<Vec3> {
        let common = self.mean(&|j| ratios[j]);
        let x = self.mean(&|j| albedos[j]);
        if let Some((x0, r0)) = self.last {
            // The photo stays, so the log render rose by as much as the log ratio fell: rate = that / dx.
            for c in 0..3 {
                let dx = x[c] - x0[c];
                if dx.abs() > 0.02 {
                    self.rate[c] = ((r0[c] - common[c]) / dx).clamp(1.0, MAX_RATE);
                }
            }
        }
        self.last = Some((x, common));
        (0..ratios.len()).map(|j| common / self.rate + (ratios[j] - common) / (Vec3::ONE + self.bounced[j])).collect()
    }
}

/// `rounds` rounds of albedo = albedo x the photo's mean over the render's per segment, as Newton steps on
/// the interreflections (`division_steps`), renders at `spp`.
pub fn divide_albedos(
    backend: &mut dyn Backend,
    scene: &mut Scene,
    photo: &[f32],
    segments: &[Segment],
    rounds: usize,
    spp: u32,
) -> Result<()> {
    check(scene, photo, segments)?;
    let segments = &recorded(segments, photo, scene.camera.width as usize);
    let want: Vec<Vec3> = segments.iter().map(|s| mean_colour(photo, &s.mask)).collect();
    let progress = crate::progress::activity(format!("albedos divided out of {spp}-spp renders"), Some(rounds));
    let weights: Vec<f32> = segments.iter().map(|s| s.mask.iter().sum()).collect();
    let ln = |v: Vec3| Vec3::from_array(v.to_array().map(f32::ln));
    let albedo = |scene: &Scene, s: &Segment| match scene.materials[s.material].albedo {
        Color::Constant(a) => a,
        _ => Vec3::ONE, // `check` admits only constant albedos
    };
    let mut steps: Option<DivisionSteps> = None;
    for round in 0..rounds {
        progress.set(round, None);
        let img = render(backend, scene, spp, scene.settings.seed.wrapping_add(round as u32))?;
        let steps = match &mut steps {
            Some(s) => s,
            None => {
                steps.insert(DivisionSteps::new(weights.clone(), bounced_shares(backend, scene, segments, &img, spp)?))
            }
        };
        let ratios: Vec<Vec3> = segments
            .iter()
            .zip(&want)
            .map(|(s, want)| ln(want.max(Vec3::splat(1e-4)) / mean_colour(&img, &s.mask).max(Vec3::splat(1e-4))))
            .collect();
        let albedos: Vec<Vec3> = segments.iter().map(|s| ln(albedo(scene, s))).collect();
        for (s, step) in segments.iter().zip(steps.steps(&ratios, &albedos)) {
            if let Color::Constant(a) = &mut scene.materials[s.material].albedo {
                let by = Vec3::from_array(step.to_array().map(f32::exp));
                *a = (*a * by).clamp(Vec3::splat(ALBEDO_RANGE.0), Vec3::splat(ALBEDO_RANGE.1));
            }
        }
    }
    Ok(())
}

#[derive(Clone, Debug)]
pub struct LightScaleOptions {
    /// Factors searched, lowest and highest (log-spaced).
    pub range: (f32, f32),
    pub steps: usize,
    /// Division rounds at each factor.
    pub rounds: usize,
    pub spp: u32,
    pub downsample: usize,
    /// A factor per colour channel (white balance absorbed into the lights' colour), or one for all three
    /// (the lights keep their fitted colour; the albedos take the rest).
    pub per_channel: bool,
}

impl Default for LightScaleOptions {
    fn default() -> Self {
        LightScaleOptions { range: (0.5, 2.0), steps: 9, rounds: 3, spp: 32, downsample: 8, per_channel: true }
    }
}

/// What the search tried and chose.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LightScale {
    pub factors: Vec<f32>,
    /// Per factor, the L1 distance to the photo at 1/downsample size per channel (mean over cells).
    pub errors: Vec<[f64; 3]>,
    /// Per channel, the factor applied to every light's radiance.
    pub chosen: [f32; 3],
}

/// Mean |a - b| per channel after k x k box downsampling.
fn l1_downsampled(a: &[f32], b: &[f32], w: usize, h: usize, k: usize) -> [f64; 3] {
    let (sw, sh) = ((w / k).max(1), (h / k).max(1));
    let mut e = [0.0f64; 3];
    for y in 0..sh {
        for x in 0..sw {
            let mut d = [0.0f64; 3];
            let mut n = 0.0f64;
            for yy in y * k..((y + 1) * k).min(h) {
                for xx in x * k..((x + 1) * k).min(w) {
                    let p = 3 * (yy * w + xx);
                    (0..3).for_each(|c| d[c] += (a[p + c] - b[p + c]) as f64);
                    n += 1.0;
                }
            }
            (0..3).for_each(|c| e[c] += (d[c] / n).abs() / (sw * sh) as f64);
        }
    }
    e
}

/// Searches the lights' common scale per channel (see the module), leaves the scene at the chosen one with
/// its albedos divided, and returns what it tried. (Searched at 1/downsample of the camera's size, the same
/// spp per pixel, the noise flattened the error curve and the scale came out 25 % off; it runs at full size.)
pub fn search_light_scale(
    backend: &mut dyn Backend,
    scene: &mut Scene,
    photo: &[f32],
    segments: &[Segment],
    opts: &LightScaleOptions,
) -> Result<LightScale> {
    check(scene, photo, segments)?;
    let (lo, hi) = opts.range;
    if !(lo > 0.0 && hi > lo && lo.is_finite() && hi.is_finite()) || opts.steps < 3 {
        return Err(Error::Invalid(format!(
            "light scale search: the range must be 0 < low < high and steps at least 3 (got {lo}..{hi}, {})",
            opts.steps
        )));
    }
    let lights: Vec<usize> = (0..scene.objects.len()).filter(|&i| scene.objects[i].emitter.is_some()).collect();
    let base: Vec<Vec3> = lights.iter().map(|&i| scene.objects[i].emitter.unwrap().radiance).collect();
    let set = |scene: &mut Scene, f: Vec3| {
        for (&i, b) in lights.iter().zip(&base) {
            scene.objects[i].emitter.as_mut().unwrap().radiance = *b * f;
        }
    };
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let mut out = LightScale { factors: vec![], errors: vec![], chosen: [1.0; 3] };
    if lights.is_empty() {
        return Ok(out);
    }
    let progress = crate::progress::activity("the lights' common scale, per factor", Some(opts.steps));
    // Each factor's division starts from the previous factor's albedos rescaled by the ratio of the factors
    // (exact without interreflections), so one round lands near the converged albedos. Started from the
    // previous albedos unchanged, one round left them a factor step off and the chosen scale 15 % off.
    // Scored where the photo records the scene: clipped pixels are zero in both images.
    let recorded_rgb: Vec<f32> = crate::vision::unclipped(photo, w).iter().flat_map(|&u| [u; 3]).collect();
    let recorded_photo: Vec<f32> = photo.iter().zip(&recorded_rgb).map(|(v, u)| v * u).collect();
    let mut at_factor: Vec<Vec<Vec3>> = vec![];
    let mut previous = Vec3::ONE;
    for step in 0..opts.steps {
        progress.set(step, None);
        let f = lo * (hi / lo).powf(step as f32 / (opts.steps - 1) as f32);
        set(scene, Vec3::splat(f));
        rescale_albedos(scene, segments, previous / f);
        previous = Vec3::splat(f);
        divide_albedos(backend, scene, photo, segments, opts.rounds, opts.spp)?;
        at_factor.push(albedos(scene, segments));
        let img = render(backend, scene, opts.spp, scene.settings.seed)?;
        out.factors.push(f);
        let img: Vec<f32> = img.iter().zip(&recorded_rgb).map(|(v, u)| v * u).collect();
        out.errors.push(l1_downsampled(&img, &recorded_photo, w, h, opts.downsample.max(1)));
    }
    for c in 0..3 {
        // One channel's error, or the three's sum when the factor is common.
        let e = |i: usize| if opts.per_channel { out.errors[i][c] } else { out.errors[i].iter().sum() };
        let i = (0..out.factors.len()).min_by(|&a, &b| e(a).total_cmp(&e(b))).unwrap_or(0);
        let mut x = out.factors[i].ln();
        if i > 0 && i + 1 < out.factors.len() {
            let curve = e(i - 1) - 2.0 * e(i) + e(i + 1);
            if curve > 0.0 {
                let step = (x - out.factors[i - 1].ln()) as f64;
                x += (0.5 * step * (e(i - 1) - e(i + 1)) / curve) as f32;
            }
        }
        out.chosen[c] = x.exp();
    }
    // The chosen scale starts from the albedos of the grid point nearest it (per channel), rescaled.
    let chosen = Vec3::from_array(out.chosen);
    let nearest = |c: usize| {
        let d = |i: usize| (out.factors[i] / out.chosen[c]).ln().abs();
        (0..out.factors.len()).min_by(|&a, &b| d(a).total_cmp(&d(b))).unwrap_or(0)
    };
    let near: [usize; 3] = std::array::from_fn(nearest);
    for (j, s) in segments.iter().enumerate() {
        if let Color::Constant(a) = &mut scene.materials[s.material].albedo {
            let start = std::array::from_fn(|c| at_factor[near[c]][j][c] * out.factors[near[c]] / out.chosen[c]);
            *a = Vec3::from_array(start).clamp(Vec3::splat(ALBEDO_RANGE.0), Vec3::splat(ALBEDO_RANGE.1));
        }
    }
    set(scene, chosen);
    divide_albedos(backend, scene, photo, segments, opts.rounds, opts.spp)?;
    Ok(out)
}

fn albedos(scene: &Scene, segments: &[Segment]) -> Vec<Vec3> {
    let albedo = |s: &Segment| match scene.materials[s.material].albedo {
        Color::Constant(a) => a,
        _ => Vec3::ZERO, // `check` admits only constant albedos
    };
    segments.iter().map(albedo).collect()
}

/// Multiplies the segments' albedos by `by` per channel, within the division's bounds.
fn rescale_albedos(scene: &mut Scene, segments: &[Segment], by: Vec3) {
    for s in segments {
        if let Color::Constant(a) = &mut scene.materials[s.material].albedo {
            *a = (*a * by).clamp(Vec3::splat(ALBEDO_RANGE.0), Vec3::splat(ALBEDO_RANGE.1));
        }
    }
}
