//! Albedos from shading, and the one thing shading cannot tell: how bright the lights are.
//!
//! `divide_albedos`: a surface's colour in the photo is its albedo times the light reaching it, so each
//! segment's homogeneous albedo is multiplied by the photo's mean colour over the render's there, a few rounds
//! so that interreflections settle (the light reaching one surface depends on the others' albedos), each
//! step a Newton step on how fast the surfaces' light grows with their albedos (`division_steps`).
//!
//! `search_light_scale`: scaling every light by s and dividing the albedos anew reproduces each segment's mean
//! colour for any s; only interreflections tell s apart (light bounced off a surface carries its albedo once
//! more), and they do so per colour channel. Each factor tried has the albedos divided anew and is scored by
//! the squared distance to the photo at 1/downsample size per channel (estimated from two renders so that
//! their noise does not score; `squared_error_unbiased`). The channels are independent problems (light
//! transport and the division are per channel), so one render scores three factors at once, one per channel:
//! a log grid over a range first, then per channel the grid goes on past an end while its best factor is
//! there, and the interval beside its best is halved until the best's neighbours are within `resolution`;
//! the choice is the parabola through the best and its neighbours, the channels' common best unless a
//! channel's own is clearly lower (`per_channel_choice`). With `LightScaleOptions::split` each factor
//! also refits how the light divides between the lamps (it depends on the scale through the bounced light), so
//! the lights' level after a factor is the refit's, near but not exactly the factor times the start's.
//! Albedos are clamped to 0.01..0.95, so a
//! scale that would need brighter surfaces shows up as a worse fit, not a wrong albedo.
//! With `LightScaleOptions::bounce_spp` the factors are scored without a render each, from one render whose
//! light is sorted by bounce (`light_scale_bounces`; the pipeline's default).
//! Both leave out the pixels where the photo is clipped (`vision::unclipped`), and render on the run's backend
//! (a GPU renders the division's many full-size images far faster than the CPU).

use super::light_scale_bounces::{BounceModel, ScoreTarget};
use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::render::SceneData;
use crate::scene::{Color, Scene};
use crate::stages::{fit_lights, LightFitOptions};
use glam::Vec3;

/// A homogeneous material and the photo's pixels that show it (weights 0..1).
#[derive(Clone, Debug)]
pub struct Segment {
    pub material: usize,
    pub mask: Vec<f32>,
}

/// Albedo bounds of the division (a real surface neither absorbs nor reflects everything).
pub(crate) const ALBEDO_RANGE: (f32, f32) = (0.01, 0.95);

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
/// (direct light only, at `spp`) over `full` (0 where the scene's paths are that short).
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

/// How `divide_albedos` divides: at most `rounds` rounds of renders at `spp`, ending after the round whose
/// segments' ratios (photo over render, |ln| of the worst channel, averaged over the segments by their pixels)
/// are within `tolerance` (0: every round). Started near the answer (the light-scale search's factors after the
/// first three), a round's ratios are the renders' noise (0.003-0.008 at 32 spp on the known-geometry room)
/// and the rounds after it move nothing but that noise. `direct_spp` (0: `spp`): the samples of the one
/// render of direct light only that sets the Newton steps' rate (`bounced_shares`, means over whole segments).
#[derive(Clone, Copy, Debug)]
pub struct Division {
    pub rounds: usize,
    pub spp: u32,
    pub tolerance: f32,
    pub direct_spp: u32,
}

impl Default for Division {
    fn default() -> Self {
        Division { rounds: 3, spp: 32, tolerance: 0.0, direct_spp: 0 }
    }
}

/// Rounds of albedo = albedo x the photo's mean over the render's per segment (`Division`), as Newton steps
/// on the interreflections (`division_steps`). Returns the rounds it rendered.
pub fn divide_albedos(
    backend: &mut dyn Backend,
    scene: &mut Scene,
    photo: &[f32],
    segments: &[Segment],
    division: &Division,
) -> Result<usize> {
    let Division { rounds, spp, tolerance, direct_spp } = *division;
    let direct_spp = if direct_spp > 0 { direct_spp } else { spp };
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
            None => steps.insert(DivisionSteps::new(
                weights.clone(),
                bounced_shares(backend, scene, segments, &img, direct_spp)?,
            )),
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
        let off: f32 = ratios.iter().zip(&weights).map(|(r, w)| r.abs().max_element() * w).sum::<f32>()
            / weights.iter().sum::<f32>().max(1e-12);
        if off < tolerance {
            return Ok(round + 1);
        }
    }
    Ok(rounds)
}

#[derive(Clone, Debug)]
pub struct LightScaleOptions {
    /// The first grid's lowest and highest factors (log-spaced, `steps` of them).
    pub range: (f32, f32),
    pub steps: usize,
    /// Division rounds at each factor (at most: see `tolerance`).
    pub rounds: usize,
    /// Samples per pixel of each factor's division and score renders.
    pub spp: u32,
    /// Each factor's divisions end early where a round's ratios are within this (`Division::tolerance`).
    pub tolerance: f32,
    /// Samples of each division's one render of direct light (`Division::direct_spp`; 0: `spp`). A quarter of
    /// `spp` in the pipeline: at `spp` it took 15 % of the search's time, and it only sets the Newton steps' rate.
    pub direct_spp: u32,
    pub downsample: usize,
    /// A factor per colour channel (white balance absorbed into the lights' colour), or one for all three
    /// (the lights keep their fitted colour; the albedos take the rest).
    pub per_channel: bool,
    /// With a factor per channel, a channel takes its own best factor only where that lowers its error below
    /// its error at the channels' common best by more than this fraction (`per_channel_choice`; 0: wherever
    /// it is lower at all).
    pub channel_min_gain: f32,
    /// Grid steps tried past either end of `range` while a channel's best factor is at that end.
    pub extend: usize,
    /// The search ends where the factors beside each channel's best are within this ratio of it (the grid's
    /// intervals beside the best halved until then; at most the grid's own ratio).
    pub resolution: f32,
    /// At each factor, the lights' split refitted with each surface's albedo free (`fit_lights` with these
    /// options and the segments' masks, every light kept) and the albedos divided again; None: the lights keep
    /// the split they came with. The split depends on the scale: the unit renders' interreflections are only
    /// right at the right albedos (the known-geometry room's free fit, the truth's albedos times 0.8, put its
    /// dimmer light's red at 9.1 for 4.0; at the true albedos 3.96).
    pub split: Option<LightFitOptions>,
    /// Division rounds after the split is refitted. The refit needs the albedos divided at the factor first
    /// (`rounds`: with one round there the known-geometry room's dimmer light came out at a quarter of its
    /// red); after it, one round left the worst albedo 1.2 % off, three 1.7 %.
    pub split_rounds: usize,
    /// Samples of the renders kept by bounce count that score every factor without rendering it
    /// (`light_scale_bounces`; two halves of this many); 0: each factor rendered and divided (the search above).
    pub bounce_spp: u32,
    /// With `bounce_spp`, the ratio between neighbouring factors of the grid scored over the whole searched
    /// range (`range` extended by `extend` grid steps each way).
    pub bounce_step: f32,
    /// With `bounce_spp`, the times the model is rendered and searched (each from the scene the last left).
    pub bounce_passes: usize,
    /// With `bounce_spp`, score by the mean absolute error over cells instead of the squared error.
    pub bounce_l1: bool,
    /// Per photo pixel, 1 where the fitted geometry agrees with the segmentation (`geometry_agreement`), 0 where
    /// it does not: the scores leave those pixels out, as they leave clipped ones (empty: every pixel agrees).
    pub agreement: Vec<f32>,
}

impl Default for LightScaleOptions {
    fn default() -> Self {
        LightScaleOptions {
            range: (0.5, 2.0),
            steps: 9,
            rounds: 3,
            spp: 32,
            tolerance: 0.0,
            direct_spp: 0,
            downsample: 8,
            per_channel: true,
            channel_min_gain: 0.1,
            extend: 0,
            resolution: 1.19,
            split: None,
            split_rounds: 1,
            bounce_spp: 0,
            bounce_step: 1.02,
            bounce_passes: 3,
            bounce_l1: false,
            agreement: vec![],
        }
    }
}

/// What the search tried and chose.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LightScale {
    /// Per render scored, the factor of each channel (R, G, B) in the order tried.
    pub factors: Vec<[f32; 3]>,
    /// Per render, the squared distance to the photo at 1/downsample size per channel (mean over cells, an
    /// unbiased estimate of the noise-free render's: `squared_error_unbiased`; it can fall below 0).
    pub errors: Vec<[f64; 3]>,
    /// Per render, those estimates' standard errors.
    pub standard_errors: Vec<[f64; 3]>,
    /// Per channel, the factor applied to every light's radiance.
    pub chosen: [f32; 3],
    /// The factor that fits the three channels together best; with a factor per channel, how much lower each
    /// channel's error is at its own best than there, as a fraction (it takes its own factor past
    /// `LightScaleOptions::channel_min_gain`).
    pub common: f32,
    pub channel_gain: Option<[f32; 3]>,
}

/// The squared distance between a render and the photo after k x k box downsampling, per channel, from two
/// independent renders `a` and `b` of the same scene: the mean of (a - p)(b - p) over the cells, whose
/// expectation is the squared error of the noise-free render. The noise of one render would add its variance
/// to any score of it (L1 or L2), and that variance is not the same at every factor: brighter lights over
/// darker albedos shift light from the bounced paths (noisy) to direct light (less so), so a one-render score
/// favoured bright lights (the shipped example's red at 32 spp: 1.55, at 128 spp 1.39). Also returns the
/// estimate's standard error per channel (of the mean over cells).
pub(super) fn squared_error_unbiased(
    a: &[f32],
    b: &[f32],
    photo: &[f32],
    w: usize,
    h: usize,
    k: usize,
) -> ([f64; 3], [f64; 3]) {
    let (sw, sh) = ((w / k).max(1), (h / k).max(1));
    let cells = (sw * sh) as f64;
    let (mut e, mut e2) = ([0.0f64; 3], [0.0f64; 3]);
    for y in 0..sh {
        for x in 0..sw {
            let (mut da, mut db) = ([0.0f64; 3], [0.0f64; 3]);
            let mut n = 0.0f64;
            for yy in y * k..((y + 1) * k).min(h) {
                for xx in x * k..((x + 1) * k).min(w) {
                    let p = 3 * (yy * w + xx);
                    for c in 0..3 {
                        da[c] += (a[p + c] - photo[p + c]) as f64;
                        db[c] += (b[p + c] - photo[p + c]) as f64;
                    }
                    n += 1.0;
                }
            }
            for c in 0..3 {
                let product = da[c] * db[c] / (n * n);
                e[c] += product / cells;
                e2[c] += product * product / cells;
            }
        }
    }
    let se = std::array::from_fn(|c| ((e2[c] - e[c] * e[c]).max(0.0) / cells).sqrt());
    (e, se)
}

/// One render of the search: the lights at `factor` (per channel) times their radiance, the albedos divided
/// anew there.
pub(super) struct ScalePoint {
    pub(super) factor: Vec3,
    pub(super) errors: [f64; 3],
    pub(super) standard_errors: [f64; 3],
    pub(super) albedos: Vec<Vec3>,
    /// The lights' radiances there (the factor times theirs before the search, unless the split is refitted).
    pub(super) radiances: Vec<Vec3>,
}

/// What scoring a factor needs besides the scene: the lights (object index, radiance before the search) and
/// the photo where it records the scene (clipped pixels zero, `recorded_rgb` the mask per value).
struct ScaleScoring<'a> {
    lights: Vec<(usize, Vec3)>,
    photo: &'a [f32],
    recorded_rgb: Vec<f32>,
    recorded_photo: Vec<f32>,
}

impl ScaleScoring<'_> {
    fn radiances(&self, scene: &Scene) -> Vec<Vec3> {
        self.lights.iter().map(|&(i, _)| scene.objects[i].emitter.map_or(Vec3::ZERO, |e| e.radiance)).collect()
    }

    fn set(&self, scene: &mut Scene, radiances: &[Vec3]) {
        for (&(i, _), r) in self.lights.iter().zip(radiances) {
            scene.objects[i].emitter.as_mut().unwrap().radiance = *r;
        }
    }

    /// The albedos divided anew under the lights as the caller set them (at factor `f`), with the split
    /// refitted in between where asked (`LightScaleOptions::split`).
    fn divide(
        &self,
        backend: &mut dyn Backend,
        scene: &mut Scene,
        segments: &[Segment],
        opts: &LightScaleOptions,
    ) -> Result<()> {
        let spp = opts.spp;
        let division = |rounds: usize| Division { rounds, spp, tolerance: opts.tolerance, direct_spp: opts.direct_spp };
        // One light has no split to refit (its level and colour are the factor's).
        let Some(fit) = opts.split.as_ref().filter(|_| self.lights.len() > 1) else {
            return divide_albedos(backend, scene, self.photo, segments, &division(opts.rounds)).map(|_| ());
        };
        divide_albedos(backend, scene, self.photo, segments, &division(opts.rounds))?;
        let names: Vec<String> = self.lights.iter().map(|&(i, _)| scene.objects[i].name.clone()).collect();
        let masks: Vec<Vec<f32>> = segments.iter().map(|s| s.mask.clone()).collect();
        let keep_all = LightFitOptions { removal_threshold: 0.0, ..fit.clone() };
        let found = fit_lights(backend, scene, &names, self.photo, &masks, &keep_all)?;
        let radiances: Vec<Vec3> = found.radiance.iter().map(|r| Vec3::from(*r).max(Vec3::splat(1e-6))).collect();
        self.set(scene, &radiances);
        divide_albedos(backend, scene, self.photo, segments, &division(opts.split_rounds)).map(|_| ())
    }

    /// The albedos (and lights, started where the caller left them at `f`) divided anew, and the score.
    fn score(
        &self,
        backend: &mut dyn Backend,
        scene: &mut Scene,
        segments: &[Segment],
        opts: &LightScaleOptions,
        f: Vec3,
    ) -> Result<ScalePoint> {
        self.divide(backend, scene, segments, opts)?;
        let albedos = albedos(scene, segments);
        let radiances = self.radiances(scene);
        // Two renders of half the samples each, with their own seeds (the score's noise cancels between them).
        let half = (opts.spp / 2).max(1);
        let seed = scene.settings.seed;
        let [a, b] = [seed, seed.wrapping_add(0x9e37_79b9)].map(|s| render(backend, scene, half, s));
        // As the camera records them (clamped at its white where the photo is 8-bit): an emitter the render
        // shows where the photo does not (a window drawn a few rows taller than the photo's) would otherwise
        // score its radiance, which grows with the factor (room01's scale went to the range's low end).
        let recorded = |img: Vec<f32>| -> Vec<f32> {
            let img = crate::vision::clip_like_photo(&img, self.photo);
            img.iter().zip(&self.recorded_rgb).map(|(v, u)| v * u).collect()
        };
        let (a, b) = (recorded(a?), recorded(b?));
        let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
        let (errors, standard_errors) =
            squared_error_unbiased(&a, &b, &self.recorded_photo, w, h, opts.downsample.max(1));
        Ok(ScalePoint { factor: f, errors, standard_errors, albedos, radiances })
    }
}

/// One channel's (or, with one factor for all three, the three's) view of the search: the distinct factors
/// it tried, in ascending order, with their mean error and how many renders scored it (a factor scored again,
/// while the other channels go on, is averaged).
struct ChannelCurve {
    points: Vec<(f32, f64, usize)>,
}

impl ChannelCurve {
    fn new(tried: &[ScalePoint], channels: &[usize]) -> ChannelCurve {
        let mut points: Vec<(f32, f64, usize)> = vec![];
        for p in tried {
            let f = p.factor[channels[0]];
            let e: f64 = channels.iter().map(|&c| p.errors[c]).sum();
            match points.iter_mut().find(|q| q.0 == f) {
                Some(q) => (q.1, q.2) = ((q.1 * q.2 as f64 + e) / (q.2 + 1) as f64, q.2 + 1),
                None => points.push((f, e, 1)),
            }
        }
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        ChannelCurve { points }
    }

    /// The error at factor `f`, linear in log factor between the factors tried either side of it; None
    /// outside what was tried.
    fn at(&self, f: f32) -> Option<f64> {
        let x = f.ln();
        let n = self.points.len();
        (0..n).find_map(|k| {
            let j = (k + 1).min(n - 1);
            let (a, b) = (self.points[k].0.ln(), self.points[j].0.ln());
            (x >= a - 1e-5 && x <= b + 1e-5).then(|| {
                let t = if b > a { f64::from(((x - a) / (b - a)).clamp(0.0, 1.0)) } else { 0.0 };
                self.points[k].1 * (1.0 - t) + self.points[j].1 * t
            })
        })
    }

    fn best(&self) -> usize {
        (0..self.points.len()).min_by(|&a, &b| self.points[a].1.total_cmp(&self.points[b].1)).unwrap_or(0)
    }

    /// The next factor this channel wants scored, or None when its search is over: past an end of what it
    /// tried while its best is there (down to `lowest`, up to `highest`), else the middle (in log) of the
    /// wider interval beside its best while that is wider than `resolution`.
    fn wants(&self, ratio: f32, lowest: f32, highest: f32, resolution: f32) -> Option<f32> {
        let (i, n) = (self.best(), self.points.len());
        let f = |k: usize| self.points[k].0;
        if i == 0 && f(0) / ratio >= lowest * 0.999 {
            return Some(f(0) / ratio);
        }
        if i + 1 == n && f(i) * ratio <= highest * 1.001 {
            return Some(f(i) * ratio);
        }
        if i == 0 || i + 1 == n {
            return None;
        }
        let (left, right) = ((f(i) / f(i - 1)).ln(), (f(i + 1) / f(i)).ln());
        // The wider side; of equal ones, the side whose neighbour scored better (the minimum leans there).
        let go_left = left > right * 1.001 || (left >= right * 0.999 && self.points[i - 1].1 < self.points[i + 1].1);
        let (a, b, width) = if go_left { (f(i - 1), f(i), left) } else { (f(i), f(i + 1), right) };
        (width > resolution.ln() * 1.001).then(|| (a * b).sqrt())
    }

    /// The best factor refined by the parabola (in log factor) through it and its neighbours, kept between them.
    fn chosen(&self) -> f32 {
        let i = self.best();
        let x = |k: usize| f64::from(self.points[k].0.ln());
        let e = |k: usize| self.points[k].1;
        if i == 0 || i + 1 == self.points.len() {
            return self.points[i].0;
        }
        let (x0, x1, x2) = (x(i - 1), x(i), x(i + 1));
        let (d0, d2) = (e(i) - e(i - 1), e(i) - e(i + 1));
        let num = (x1 - x0).powi(2) * d2 - (x1 - x2).powi(2) * d0;
        let den = (x1 - x0) * d2 - (x1 - x2) * d0;
        // A minimum (the best scored lowest) has den < 0 here; a flat or noisy triple keeps the best.
        let v = if den < 0.0 { x1 - 0.5 * num / den } else { x1 };
        v.clamp(x0, x2).exp() as f32
    }
}

/// Per channel, the factor chosen where each channel was searched on its own: the channels' common best (the
/// parabola through the sum of their errors, each interpolated in log factor over what it tried, at the
/// factors all three tried around) and, per channel, its own best (`ChannelCurve::chosen`) where that lowers
/// the channel's error below its error at the common one by more than the fraction `min_gain`, else the
/// common one. Returns the choice, the common factor and per channel that gain. Where the lights explain the
/// photo, a channel's curve has a sharp minimum (the known-geometry room's coloured lights: green and blue
/// 15-26 % lower at their own); where their pattern is off, the error is the misfit's and each channel's
/// minimum a few percent of it, a colour the albedos then take: real room11's lights went [1.67, 0.81, 0.62]
/// (red over blue 2.7) on gains of 1.5-6.4 %, and its albedos turned blue-green (78 % off).
fn per_channel_choice(tried: &[ScalePoint], min_gain: f32) -> ([f32; 3], f32, [f32; 3]) {
    let curves: Vec<ChannelCurve> = (0..3).map(|c| ChannelCurve::new(tried, &[c])).collect();
    let lo = curves.iter().map(|c| c.points[0].0).fold(0.0f32, f32::max);
    let hi = curves.iter().map(|c| c.points[c.points.len() - 1].0).fold(f32::INFINITY, f32::min);
    let mut factors: Vec<f32> =
        curves.iter().flat_map(|c| c.points.iter().map(|p| p.0)).filter(|&f| f >= lo && f <= hi).collect();
    factors.sort_by(f32::total_cmp);
    factors.dedup_by(|a, b| (*a / *b - 1.0).abs() < 1e-5);
    let points: Vec<(f32, f64, usize)> = factors
        .iter()
        .filter_map(|&f| {
            let at: Vec<f64> = curves.iter().map(|c| c.at(f)).collect::<Option<_>>()?;
            Some((f, at.iter().sum(), 1))
        })
        .collect();
    if points.is_empty() {
        let own: [f32; 3] = std::array::from_fn(|c| curves[c].chosen());
        return (own, own[1], [f32::INFINITY; 3]);
    }
    let common = ChannelCurve { points }.chosen();
    let mut chosen = [common; 3];
    let mut gain = [0.0f32; 3];
    for (c, curve) in curves.iter().enumerate() {
        let best = curve.points[curve.best()].1;
        let Some(at_common) = curve.at(common) else { continue };
        gain[c] = ((at_common - best) / best.abs().max(1e-30)) as f32;
        if gain[c] > min_gain {
            chosen[c] = curve.chosen();
        }
    }
    (chosen, common, gain)
}

/// The factors (per channel) of the search's next render after `tried`: what each channel group wants
/// (`ChannelCurve::wants`), a group that is done at its best again; None when every group is done.
fn next_factor(
    tried: &[ScalePoint],
    groups: &[Vec<usize>],
    ratio: f32,
    (lowest, highest): (f32, f32),
    resolution: f32,
) -> Option<Vec3> {
    let curves: Vec<ChannelCurve> = groups.iter().map(|g| ChannelCurve::new(tried, g)).collect();
    let wants: Vec<Option<f32>> = curves.iter().map(|c| c.wants(ratio, lowest, highest, resolution)).collect();
    if wants.iter().all(Option::is_none) {
        return None;
    }
    let mut f = Vec3::ONE;
    for ((g, curve), want) in groups.iter().zip(&curves).zip(&wants) {
        let v = want.unwrap_or_else(|| curve.points[curve.best()].0);
        for &k in g {
            f[k] = v;
        }
    }
    Some(f)
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
    if !(opts.resolution > 1.0 && opts.resolution.is_finite()) {
        return Err(Error::Invalid(format!(
            "light scale search: the resolution is a ratio above 1 (got {})",
            opts.resolution
        )));
    }
    let w = scene.camera.width as usize;
    let agrees = |p: usize| if opts.agreement.len() == photo.len() / 3 { opts.agreement[p] } else { 1.0 };
    let recorded_rgb: Vec<f32> =
        crate::vision::unclipped(photo, w).iter().enumerate().flat_map(|(p, &u)| [u * agrees(p); 3]).collect();
    let scoring = ScaleScoring {
        lights: (0..scene.objects.len()).filter_map(|i| scene.objects[i].emitter.map(|e| (i, e.radiance))).collect(),
        photo,
        recorded_photo: photo.iter().zip(&recorded_rgb).map(|(v, u)| v * u).collect(),
        recorded_rgb,
    };
    let mut out = LightScale {
        factors: vec![],
        errors: vec![],
        standard_errors: vec![],
        chosen: [1.0; 3],
        common: 1.0,
        channel_gain: None,
    };
    if scoring.lights.is_empty() {
        return Ok(out);
    }
    let progress = crate::progress::activity("the lights' common scale, per factor", None);
    let ratio = (hi / lo).powf(1.0 / (opts.steps - 1) as f32);
    let (lowest, highest) = (lo / ratio.powi(opts.extend as i32), hi * ratio.powi(opts.extend as i32));
    let groups: Vec<Vec<usize>> = if opts.per_channel { vec![vec![0], vec![1], vec![2]] } else { vec![vec![0, 1, 2]] };
    if opts.bounce_spp > 0 {
        drop(progress);
        return search_by_bounces(backend, scene, segments, opts, &scoring, (lowest, highest), out);
    }
    // Each render's division starts, per channel, from the albedos the factors tried nearest it had, carried
    // along the line (in log albedo over log factor) through the two nearest, so its rounds land near the
    // converged albedos, and the lights from the nearest factor's, rescaled by the ratio of the factors (the
    // radiances before the search times the factor, unless the split was refitted there). The line's slope is
    // kept within -1 (no interreflection: the albedos fall as the lights rise) and 0; with one factor tried it
    // is -1. (Started from the previous albedos unchanged, one round left them a factor step off and the chosen
    // scale 15 % off; at -1 always, a bright room's division started 0.3-0.6 off in log, as most of its light
    // bounced, and needed its three rounds.)
    let mut tried: Vec<ScalePoint> = vec![];
    let start_albedos = albedos(scene, segments);
    let start = |tried: &[ScalePoint], f: Vec3, scene: &mut Scene| {
        let nearest = |c: usize| {
            let d = |p: &ScalePoint| (p.factor[c] / f[c]).ln().abs();
            let mut by_distance: Vec<&ScalePoint> = tried.iter().collect();
            by_distance.sort_by(|a, b| d(a).total_cmp(&d(b)));
            let first = by_distance.first().copied();
            let second = by_distance
                .iter()
                .copied()
                .find(|p| first.is_some_and(|q| (p.factor[c] / q.factor[c]).ln().abs() > 1e-3));
            (first, second)
        };
        let near: [(Option<&ScalePoint>, Option<&ScalePoint>); 3] = std::array::from_fn(nearest);
        let values: Vec<Vec3> = (0..segments.len())
            .map(|j| {
                Vec3::from_array(std::array::from_fn(|c| match near[c] {
                    (Some(p), Some(q)) => {
                        let (lp, lq) = (p.albedos[j][c].ln(), q.albedos[j][c].ln());
                        let slope = ((lq - lp) / (q.factor[c] / p.factor[c]).ln()).clamp(-1.0, 0.0);
                        (lp + slope * (f[c] / p.factor[c]).ln()).exp()
                    }
                    (Some(p), None) => p.albedos[j][c] * p.factor[c] / f[c],
                    _ => start_albedos[j][c] / f[c],
                }))
                .clamp(Vec3::splat(ALBEDO_RANGE.0), Vec3::splat(ALBEDO_RANGE.1))
            })
            .collect();
        set_albedos(scene, segments, &values);
        let lights: Vec<Vec3> = (0..scoring.lights.len())
            .map(|l| {
                Vec3::from_array(std::array::from_fn(|c| match near[c].0 {
                    Some(p) => p.radiances[l][c] * f[c] / p.factor[c],
                    None => scoring.lights[l].1[c] * f[c],
                }))
            })
            .collect();
        scoring.set(scene, &lights);
    };
    // The grid: every channel at the same factors.
    // Nearest the lights' present scale (factor 1) first: the scene is divided there already.
    let mut grid: Vec<f32> = (0..opts.steps).map(|step| lo * ratio.powi(step as i32)).collect();
    grid.sort_by(|a, b| a.ln().abs().total_cmp(&b.ln().abs()));
    for g in grid {
        progress.set(tried.len(), None);
        let f = Vec3::splat(g);
        start(&tried, f, scene);
        tried.push(scoring.score(backend, scene, segments, opts, f)?);
    }
    // Then per channel past the ends and into the best's interval, one render scoring every channel's next
    // factor; a channel that is done scores its best again (averaged into it). Bounded, in case noise keeps
    // moving a best: the extension steps both ways and five halvings per channel group.
    let resolution = opts.resolution.min(ratio);
    let most = opts.steps + 2 * opts.extend + 5 * groups.len();
    while tried.len() < most {
        let Some(f) = next_factor(&tried, &groups, ratio, (lowest, highest), resolution) else { break };
        progress.set(tried.len(), None);
        start(&tried, f, scene);
        tried.push(scoring.score(backend, scene, segments, opts, f)?);
    }
    drop(progress);
    choose(&tried, opts, &mut out);
    // The chosen scale starts from the albedos of the factor tried nearest it (per channel), rescaled.
    let chosen = Vec3::from_array(out.chosen);
    start(&tried, chosen, scene);
    scoring.divide(backend, scene, segments, opts)?;
    Ok(out)
}

/// Records what was tried in `out` and chooses the factor per channel (`per_channel_choice`) or one for all.
fn choose(tried: &[ScalePoint], opts: &LightScaleOptions, out: &mut LightScale) {
    out.factors = tried.iter().map(|p| p.factor.to_array()).collect();
    out.errors = tried.iter().map(|p| p.errors).collect();
    out.standard_errors = tried.iter().map(|p| p.standard_errors).collect();
    if opts.per_channel {
        let (chosen, common, gain) = per_channel_choice(tried, opts.channel_min_gain);
        (out.chosen, out.common, out.channel_gain) = (chosen, common, Some(gain));
    } else {
        out.common = ChannelCurve::new(tried, &[0, 1, 2]).chosen();
        out.chosen = [out.common; 3];
    }
}

/// The search scored from renders kept by bounce count (`light_scale_bounces`): every factor of a fine log grid
/// over `lowest..highest` predicted and scored, the choice made as the render-per-factor search makes it, and the
/// scene divided at the chosen factor from the model's albedos (the split refitted there where asked). The model
/// is exact at the scene it was rendered from and approximate away from it (the bounced light's albedo scale is
/// the segments' mean), so `bounce_passes` > 1 renders it again at the scene the pass left and searches again from
/// there (the light room of tests/tests/albedo_division.rs: one pass chose 1.38 for 1.43, its albedos 2.4 % off;
/// two 1.43 and 1.0 %). scripts/room.rhai scores it by the mean absolute error over 8x8 cells (`bounce_l1`): by
/// the squared error at 1/2 size it chose lower factors than the render search on real rooms
/// (benchmarks/README.md, "The same runs on another machine, and the light-scale search from renders kept by
/// bounce").
fn search_by_bounces(
    backend: &mut dyn Backend,
    scene: &mut Scene,
    segments: &[Segment],
    opts: &LightScaleOptions,
    scoring: &ScaleScoring,
    (lowest, highest): (f32, f32),
    mut out: LightScale,
) -> Result<LightScale> {
    if !(opts.bounce_step > 1.0 && opts.bounce_step.is_finite()) {
        return Err(Error::Invalid(format!(
            "light scale search: the bounce grid's step is a ratio above 1 (got {})",
            opts.bounce_step
        )));
    }
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let steps = ((highest / lowest).ln() / opts.bounce_step.ln()).ceil().max(2.0) as usize;
    // The factor so far: the passes' choices multiplied (per channel), relative to the lights before the search.
    let mut so_far = Vec3::ONE;
    for pass in 0..opts.bounce_passes.max(1) {
        let start = albedos(scene, segments);
        let before = scoring.radiances(scene);
        let model = {
            let what = format!("the lights' common scale: renders kept by bounce (pass {})", pass + 1);
            let _progress = crate::progress::activity(what, None);
            BounceModel::render(scene, scoring.photo, segments, start.clone(), opts.bounce_spp)?
        };
        let radiances = |f: Vec3| -> Vec<Vec3> { before.iter().map(|r| *r * f).collect() };
        let target = ScoreTarget {
            photo: scoring.photo,
            recorded_rgb: &scoring.recorded_rgb,
            recorded_photo: &scoring.recorded_photo,
            shape: (w, h, opts.downsample.max(1)),
            l1: opts.bounce_l1,
        };
        let tried: Vec<ScalePoint> = (0..=steps)
            .map(|i| {
                // The same absolute factors every pass, relative to where this pass starts.
                let f = Vec3::splat(lowest * (highest / lowest).powf(i as f32 / steps as f32)) / so_far;
                let mut p = model.score(f, &target, radiances(f));
                p.factor *= so_far;
                p
            })
            .collect();
        choose(&tried, opts, &mut out);
        let relative = Vec3::from_array(out.chosen) / so_far;
        let scaled: Vec<Vec3> = start.iter().zip(model.scales(relative)).map(|(a, s)| *a * s).collect();
        set_albedos(scene, segments, &scaled);
        scoring.set(scene, &radiances(relative));
        scoring.divide(backend, scene, segments, opts)?;
        // Where the split was refitted the lights' level is the refit's: the factor is measured from it.
        so_far = Vec3::from_array(std::array::from_fn(|c| {
            let now: f32 = scoring.radiances(scene).iter().map(|r| r[c]).sum();
            let was: f32 = scoring.lights.iter().map(|l| l.1[c]).sum();
            if was > 0.0 {
                now / was
            } else {
                out.chosen[c]
            }
        }));
    }
    Ok(out)
}

/// Sets the segments' albedos (constant ones) to `values`, in segment order.
fn set_albedos(scene: &mut Scene, segments: &[Segment], values: &[Vec3]) {
    for (s, v) in segments.iter().zip(values) {
        if let Color::Constant(a) = &mut scene.materials[s.material].albedo {
            *a = *v;
        }
    }
}

fn albedos(scene: &Scene, segments: &[Segment]) -> Vec<Vec3> {
    let albedo = |s: &Segment| match scene.materials[s.material].albedo {
        Color::Constant(a) => a,
        _ => Vec3::ZERO, // `check` admits only constant albedos
    };
    segments.iter().map(albedo).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two renders with independent noise of the same noise-free image: their product score is that image's
    /// squared error (the noise averages out), where the squared error of one render carries the noise's
    /// variance. 64x64 cells of 4 pixels, noise of standard deviation 0.3 against an error of 0.1: a cell's
    /// product has standard deviation sqrt(0.0225^2 + 2 * 0.01 * 0.0225) = 0.031 (0.0225 the variance of a
    /// 4-pixel mean), the mean over 4096 cells 5e-4, so 0.01 +- 0.003 is a 6-sigma bound.
    /// The search's per-channel steps on error curves known in closed form, e(f) = (ln f - ln m)^2 per channel
    /// (a parabola in log factor, so the final parabola through the best and its neighbours is exact): from the
    /// grid 0.71, 1, 1.41, a minimum inside it is bracketed to 2^(1/4) and found exactly; one at 3 (past the
    /// grid) is reached by extension; one past the extension's reach ends at its end. One render scores the
    /// three channels' factors at once: 3 + a few renders, not a grid for each.
    #[test]
    fn the_search_brackets_each_channel_minimum_with_few_renders() {
        let minima = [1.3f32, 3.0, 10.0];
        let score = |f: Vec3| ScalePoint {
            factor: f,
            errors: std::array::from_fn(|c| f64::from((f[c] / minima[c]).ln()).powi(2)),
            standard_errors: [0.0; 3],
            albedos: vec![],
            radiances: vec![],
        };
        let (ratio, resolution) = (2f32.sqrt(), 2f32.powf(0.25));
        let (lowest, highest) = (0.5f32.sqrt() / ratio.powi(4), 2f32.sqrt() * ratio.powi(4));
        let mut tried: Vec<ScalePoint> = [0.5f32.sqrt(), 1.0, 2f32.sqrt()].map(|f| score(Vec3::splat(f))).into();
        let groups = [vec![0usize], vec![1], vec![2]];
        while let Some(f) = next_factor(&tried, &groups, ratio, (lowest, highest), resolution) {
            tried.push(score(f));
            assert!(tried.len() < 20, "the search does not end");
        }
        let chosen: Vec<f32> = groups.iter().map(|g| ChannelCurve::new(&tried, g).chosen()).collect();
        assert!((chosen[0] / 1.3 - 1.0).abs() < 1e-3, "{chosen:?}");
        assert!((chosen[1] / 3.0 - 1.0).abs() < 1e-3, "{chosen:?}");
        assert!((chosen[2] / highest - 1.0).abs() < 1e-3, "past the reach: its end, {chosen:?}");
        // 3 of the grid, 4 extensions for the channel that runs out of reach (the others refine meanwhile).
        assert!(tried.len() <= 3 + 4 + 2, "{} renders", tried.len());
        // The bracketed channels' best neighbours are within the resolution.
        let c0 = ChannelCurve::new(&tried, &[0]);
        let i = c0.best();
        assert!(c0.points[i + 1].0 / c0.points[i - 1].0 <= resolution * resolution * 1.001);
    }

    #[test]
    fn the_two_render_score_does_not_count_the_noise() {
        let (w, h) = (128, 128);
        let photo = vec![0.5f32; w * h * 3];
        let clean: Vec<f32> = photo.iter().map(|p| p + 0.1).collect();
        let mut state = 1u64;
        let mut noisy = || -> Vec<f32> {
            clean
                .iter()
                .map(|v| {
                    // Uniform noise of standard deviation 0.3 (half-width 0.3 * sqrt 3).
                    state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    let u = (state >> 40) as f32 / (1u64 << 24) as f32;
                    v + (2.0 * u - 1.0) * 0.3 * 3f32.sqrt()
                })
                .collect()
        };
        let (a, b) = (noisy(), noisy());
        let (both, se) = squared_error_unbiased(&a, &b, &photo, w, h, 2);
        let (one, _) = squared_error_unbiased(&a, &a, &photo, w, h, 2);
        for c in 0..3 {
            assert!((both[c] - 0.01).abs() < 0.003, "two renders: {} for 0.01", both[c]);
            // Its standard error as the comment above computes it (5e-4).
            assert!((se[c] - 4.8e-4).abs() < 1e-4, "standard error {}", se[c]);
            // One render's score: 0.01 + 0.09 / 4 (the variance of a 4-pixel mean).
            assert!(one[c] > 0.025, "one render: {}", one[c]);
        }
    }

    /// Red has a sharp minimum at a factor of 2 (its error 0.001 + 0.01 per log-factor squared), green and
    /// blue are nearly flat (0.001 + 0.0001 per log-factor squared, minimum at 0.7): red takes its own factor,
    /// green and blue the three channels' common best; with no minimum gain each channel its own.
    #[test]
    fn a_channel_leaves_the_common_factor_only_where_its_own_is_clearly_better() {
        let error = |f: f32, at: f32, k: f64| 0.001 + k * f64::from((f / at).ln()).powi(2);
        let point = |f: [f32; 3]| ScalePoint {
            factor: Vec3::from(f),
            errors: [error(f[0], 2.0, 0.01), error(f[1], 0.7, 1e-4), error(f[2], 0.7, 1e-4)],
            standard_errors: [1e-4; 3],
            albedos: vec![],
            radiances: vec![],
        };
        // The grid, then each channel past its end and into its best's interval, as the search goes.
        let tried: Vec<ScalePoint> = [
            [1.0, 1.0, 1.0],
            [1.414, 1.414, 1.414],
            [0.707, 0.707, 0.707],
            [2.0, 0.5, 0.5],
            [2.828, 0.595, 0.595],
            [1.682, 0.841, 0.841],
            [2.378, 0.595, 0.595],
        ]
        .map(point)
        .into_iter()
        .collect();
        let (chosen, common, gain) = per_channel_choice(&tried, 0.1);
        // The common best is where all three tried (0.707..1.414): the red's slope puts it at the top end.
        assert!((common - 1.414).abs() < 1e-3, "common {common}");
        assert!((chosen[0] - 2.0).abs() < 0.1, "red keeps its own: {chosen:?}");
        assert!(chosen[1] == common && chosen[2] == common, "green and blue take the common: {chosen:?}");
        // Red: 0.0022 at the common factor over 0.001 at its own; green and blue 5 %.
        assert!(gain[0] > 1.0 && gain[1] < 0.06 && gain[2] < 0.06, "{gain:?}");
        let (own, _, _) = per_channel_choice(&tried, 0.0);
        assert!(own[1] < 0.9 && own[2] < 0.9, "at 0 each channel its own minimum: {own:?}");
    }
}
