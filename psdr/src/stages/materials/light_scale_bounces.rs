//! The light-scale search scored without a render per factor: the image kept by bounce.
//!
//! A path that reflects off k surfaces carries k albedos, so with every light scaled by f and the divided
//! albedos (the segments') by their scales, its contribution scales by f times those scales. One render
//! whose paths' light is sorted by what it reflected off predicts the image at any factor: per pixel and
//! channel f [B_0 + σ (C_0 + s̄ C_1 + s̄² C_2 + ...)], B_0 the emitters seen, σ the albedo scale of the
//! surface the pixel shows, C_m the light that then reflected off m more divided surfaces (surfaces in no
//! segment keep their albedo, as they do in the division) and s̄ those surfaces' scale, the segments'
//! pixel-weighted mean (the one approximation). At each factor the segments' scales are those that reproduce
//! the photo's mean colour over each segment (the albedo division, solved in closed form per segment), and
//! the prediction is scored as a render would be (`squared_error_unbiased` on two independent halves).
//! Every factor is scored from the same paths, so the curve carries no render noise between factors. The
//! sorting needs the integrator's events (`PathObserver`), so these renders run on the CPU on either backend.
//!
//! Light past the last bin is one tail, scaled as a geometric series whose ratio is the image's last two
//! bins' (light falls by about the same fraction at every further bounce).

use super::albedo_division::{squared_error_unbiased, ScalePoint, Segment, ALBEDO_RANGE};
use crate::error::Result;
use crate::render::bvh::Hit;
use crate::render::cpu::frame_params;
use crate::render::path_trace::{trace_path_observed, NeeEvent, PathObserver};
use crate::render::shading::SurfacePoint;
use crate::render::SceneData;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// Bins kept apart: B_0 (emitters seen) and the reflected light by how many divided surfaces it bounced off
/// after the first, 0 to BINS - 2; the rest is the tail.
const BINS: usize = 5;

/// One render's light split by bounce: `bins[0]` the emitters seen, `bins[1 + m]` light reflected off the
/// pixel's surface and then off m divided surfaces (those of a segment: their albedo moves with the factor;
/// the others keep theirs), `tail` off BINS - 1 or more (RGB, interleaved).
struct BounceImage {
    bins: Vec<Vec<f32>>,
    tail: Vec<f32>,
}

/// Sorts one path's contributions into the bins as the integrator reports them (`PathObserver`): emission
/// found at a vertex has reflected off the vertices before it, a next-event estimate off those and its own.
struct BinObserver<'a> {
    d: &'a SceneData,
    divided: &'a [bool],
    vertex: usize,
    beta: Vec3,
    /// Divided surfaces among the vertices after the first and before the current one, and whether the
    /// current one is one.
    after_first: usize,
    current: bool,
    sums: [Vec3; BINS + 1],
}

impl BinObserver<'_> {
    fn add(&mut self, reflected_after_first: Option<usize>, v: Vec3) {
        let bin = match reflected_after_first {
            None => 0,
            Some(m) => (1 + m).min(BINS),
        };
        self.sums[bin] += v;
    }
}

impl PathObserver for BinObserver<'_> {
    fn start(&mut self, _origin: Vec3, _dir: Vec3) {
        (self.vertex, self.after_first, self.current) = (0, 0, false);
    }

    fn hit(&mut self, hit: &Hit, _sp: &SurfacePoint, beta: Vec3) {
        self.after_first += usize::from(self.current);
        let material = self.d.triangles[hit.triangle as usize].material as usize;
        self.current = self.vertex >= 1 && self.divided.get(material).copied().unwrap_or(false);
        self.beta = beta;
        self.vertex += 1;
    }

    fn emission(&mut self, _emitter: u32, le: Vec3, _shape: Vec3, mis: f32) {
        let reflected = (self.vertex > 1).then_some(self.after_first);
        self.add(reflected, self.beta * le * mis);
    }

    fn nee(&mut self, e: &NeeEvent) {
        let m = self.after_first + usize::from(self.current);
        self.add(Some(m), self.beta * e.f * e.radiance * e.w_over_pdf);
    }
}

/// The scene rendered on the CPU (whatever the run's backend: the split needs the integrator's events) at
/// `spp` with `seed`, its light sorted into bins; `divided[material]`: the segments' materials.
fn render_bounces(scene: &Scene, divided: &[bool], spp: u32, seed: u32) -> Result<BounceImage> {
    let d = SceneData::build(scene)?;
    let mut settings = scene.settings.clone();
    (settings.spp, settings.seed) = (spp, seed);
    let fp = frame_params(&d, &settings);
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let rows: Vec<Vec<[Vec3; BINS + 1]>> = (0..h)
        .into_par_iter()
        .map(|y| {
            (0..w)
                .map(|x| {
                    let mut obs = BinObserver {
                        d: &d,
                        divided,
                        vertex: 0,
                        beta: Vec3::ONE,
                        after_first: 0,
                        current: false,
                        sums: [Vec3::ZERO; BINS + 1],
                    };
                    for sample in 0..spp {
                        trace_path_observed(&d, &fp, x as u32, y as u32, sample, &mut obs);
                    }
                    obs.sums.map(|v| v / spp.max(1) as f32)
                })
                .collect()
        })
        .collect();
    let channel = |bin: usize| -> Vec<f32> { rows.iter().flatten().flat_map(|p| p[bin].to_array()).collect() };
    Ok(BounceImage { bins: (0..BINS).map(channel).collect(), tail: channel(BINS) })
}

/// Means of an interleaved RGB image over a mask (one channel).
fn masked_mean(img: &[f32], mask: &[f32], c: usize) -> f32 {
    let (mut sum, mut weight) = (0.0f64, 0.0f64);
    for (p, &m) in mask.iter().enumerate() {
        if m > 0.0 {
            sum += f64::from(m * img[3 * p + c]);
            weight += f64::from(m);
        }
    }
    (sum / weight.max(1e-12)) as f32
}

/// The prediction's inputs: two independent bounce images, the segments (their full masks for the pixels
/// they cover, their recorded masks and the photo's mean over those for the division) and their albedos.
pub(super) struct BounceModel {
    halves: [BounceImage; 2],
    /// Per segment, per channel, the bins' means over its recorded pixels (both halves together) and the
    /// photo's mean there.
    bin_means: Vec<[[f32; BINS]; 3]>,
    tail_means: Vec<[f32; 3]>,
    want: Vec<Vec3>,
    weights: Vec<f32>,
    albedos: Vec<Vec3>,
    /// Per pixel, the segments covering it (index, weight).
    cover: Vec<Vec<(usize, f32)>>,
    /// Per channel, the tail's geometric ratio (the last bin over the one before, over the image).
    tail_ratio: [f32; 3],
}

impl BounceModel {
    /// The model of `scene` (its segments' albedos `albedos`) from two renders of `spp` / 2 samples by bounce.
    /// The division's means are over the segments' pixels the photo records (clipped ones left out); a
    /// segment the photo shows only clipped keeps its albedo, as in `divide_albedos`.
    pub(super) fn render(
        scene: &Scene,
        photo: &[f32],
        segments: &[Segment],
        albedos: Vec<Vec3>,
        spp: u32,
    ) -> Result<BounceModel> {
        let unclipped = crate::vision::unclipped(photo, scene.camera.width as usize);
        let recorded: Vec<Vec<f32>> =
            segments.iter().map(|s| s.mask.iter().zip(&unclipped).map(|(m, u)| m * u).collect()).collect();
        let half = (spp / 2).max(1);
        let seed = scene.settings.seed;
        let mut divided = vec![false; scene.materials.len()];
        for s in segments {
            divided[s.material] = true;
        }
        let halves = [
            render_bounces(scene, &divided, half, seed)?,
            render_bounces(scene, &divided, half, seed.wrapping_add(0x9e37_79b9))?,
        ];
        let both = |f: &dyn Fn(&BounceImage) -> &Vec<f32>| -> Vec<f32> {
            f(&halves[0]).iter().zip(f(&halves[1])).map(|(a, b)| 0.5 * (a + b)).collect()
        };
        let bins: Vec<Vec<f32>> = (0..BINS).map(|k| both(&|h: &BounceImage| &h.bins[k])).collect();
        let tail = both(&|h: &BounceImage| &h.tail);
        let bin_means = recorded
            .iter()
            .map(|m| std::array::from_fn(|c| std::array::from_fn(|k| masked_mean(&bins[k], m, c))))
            .collect();
        let tail_means = recorded.iter().map(|m| std::array::from_fn(|c| masked_mean(&tail, m, c))).collect();
        let want =
            recorded.iter().map(|m| Vec3::from_array(std::array::from_fn(|c| masked_mean(photo, m, c)))).collect();
        let weights = recorded.iter().map(|m| m.iter().sum()).collect();
        let pixels = (scene.camera.width * scene.camera.height) as usize;
        let mut cover: Vec<Vec<(usize, f32)>> = vec![vec![]; pixels];
        for (i, s) in segments.iter().enumerate() {
            for (p, &m) in s.mask.iter().enumerate() {
                if m > 0.0 {
                    cover[p].push((i, m));
                }
            }
        }
        let total = |k: usize, c: usize| bins[k].iter().skip(c).step_by(3).map(|&v| f64::from(v)).sum::<f64>();
        let tail_ratio = std::array::from_fn(|c| {
            let (last, before) = (total(BINS - 1, c), total(BINS - 2, c));
            if before > 0.0 {
                (last / before).clamp(0.0, 0.9) as f32
            } else {
                0.0
            }
        });
        Ok(BounceModel { halves, bin_means, tail_means, want, weights, albedos, cover, tail_ratio })
    }

    /// The light that reflected at least once, per unit of the first surface's albedo scale, at bounced
    /// surfaces' scale `s`: B_1 + s B_2 + ... + s^(BINS-2) B_{BINS-1} + the tail at s.
    fn bounced(&self, bins: [f32; BINS], tail: f32, s: f32, c: usize) -> f32 {
        let mut sum = 0.0;
        let mut power = 1.0;
        for &b in &bins[1..] {
            sum += power * b;
            power *= s;
        }
        // Tail: sum over k >= BINS of s^(k-1) B_k with B_k = B_BINS a^(k-BINS), relative to its value at s = 1.
        let a = self.tail_ratio[c];
        let tail_gain = power * (1.0 - a) / (1.0 - (a * s).min(0.95));
        sum + tail * tail_gain
    }

    /// Per segment, the albedo scale (per channel) that reproduces its mean colour under lights at factor
    /// `f`: s_i = (photo / f - B_0) / bounced(s̄), with s̄ the segments' pixel-weighted mean scale. The mean
    /// of the s_i falls as s̄ rises (more bounced light, smaller scales), so the fixed point s̄ = mean s_i(s̄)
    /// is found by bisection (plain iteration oscillates where most light bounces). Scales keep the albedos
    /// within the division's bounds; a segment the photo shows only clipped keeps its albedo.
    pub(super) fn scales(&self, f: Vec3) -> Vec<Vec3> {
        let n = self.want.len();
        let total: f32 = self.weights.iter().sum::<f32>().max(1e-12);
        let mut scales = vec![Vec3::ONE; n];
        for c in 0..3 {
            let at = |mean: f32, scales: &mut [Vec3]| -> f32 {
                for i in (0..n).filter(|&i| self.weights[i] > 0.0) {
                    let bounced = self.bounced(self.bin_means[i][c], self.tail_means[i][c], mean, c);
                    let direct = self.want[i][c] / f[c] - self.bin_means[i][c][0];
                    let a = self.albedos[i][c].max(1e-6);
                    let s = if bounced > 1e-9 { direct / bounced } else { 1.0 };
                    scales[i][c] = s.clamp(ALBEDO_RANGE.0 / a, ALBEDO_RANGE.1 / a);
                }
                (0..n).map(|i| scales[i][c] * self.weights[i]).sum::<f32>() / total
            };
            let (mut lo, mut hi) = (1e-3f32, 1e3f32);
            for _ in 0..60 {
                let mid = (lo * hi).sqrt();
                if at(mid, &mut scales) > mid {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            at((lo * hi).sqrt(), &mut scales);
        }
        scales
    }

    fn mean_scale(&self, scales: &[Vec3]) -> Vec3 {
        let total: f32 = self.weights.iter().sum::<f32>().max(1e-12);
        scales.iter().zip(&self.weights).map(|(s, w)| *s * *w).sum::<Vec3>() / total
    }

    /// One half's predicted image at factor `f` with the segments' albedos scaled by `scales`.
    fn predict(&self, half: usize, f: Vec3, scales: &[Vec3]) -> Vec<f32> {
        let h = &self.halves[half];
        let mean = self.mean_scale(scales);
        let mut out = vec![0.0f32; h.tail.len()];
        for (p, cover) in self.cover.iter().enumerate() {
            let covered: f32 = cover.iter().map(|&(_, m)| m).sum::<f32>().min(1.0);
            let first = cover.iter().map(|&(i, m)| scales[i] * m).sum::<Vec3>()
                / cover.iter().map(|&(_, m)| m).sum::<f32>().max(1.0)
                + Vec3::splat(1.0 - covered);
            for c in 0..3 {
                let v = 3 * p + c;
                let bins: [f32; BINS] = std::array::from_fn(|k| h.bins[k][v]);
                out[v] = f[c] * (bins[0] + first[c] * self.bounced(bins, h.tail[v], mean[c], c));
            }
        }
        out
    }

    /// The factor's scale point: the segments' albedos divided by the model and its two halves' predictions
    /// scored as `ScaleScoring::score` scores renders (clipped like the photo, the photo's clipped pixels out).
    pub(super) fn score(&self, f: Vec3, target: &ScoreTarget, radiances: Vec<Vec3>) -> ScalePoint {
        let scales = self.scales(f);
        let recorded = |img: Vec<f32>| -> Vec<f32> {
            let img = crate::vision::clip_like_photo(&img, target.photo);
            img.iter().zip(target.recorded_rgb).map(|(v, u)| v * u).collect()
        };
        let (a, b) = (recorded(self.predict(0, f, &scales)), recorded(self.predict(1, f, &scales)));
        let (w, h, k) = target.shape;
        let (errors, standard_errors) = if target.l1 {
            absolute_error(&a, &b, target.recorded_photo, w, h, k)
        } else {
            squared_error_unbiased(&a, &b, target.recorded_photo, w, h, k)
        };
        let albedos = self.albedos.iter().zip(&scales).map(|(a, s)| *a * *s).collect();
        ScalePoint { factor: f, errors, standard_errors, albedos, radiances }
    }
}

/// What a prediction is scored against: the photo, its recorded pixels (per value) and the photo there, the
/// image's width, height and the cells' size, and the loss (mean absolute error, else the squared error).
pub(super) struct ScoreTarget<'a> {
    pub(super) photo: &'a [f32],
    pub(super) recorded_rgb: &'a [f32],
    pub(super) recorded_photo: &'a [f32],
    pub(super) shape: (usize, usize, usize),
    pub(super) l1: bool,
}

/// The mean absolute distance between the two halves' mean and the photo after k x k box downsampling, per
/// channel, and its standard error. Not unbiased in the renders' noise (which adds to any |residual|), so
/// only for cells large enough that the noise is small beside the residuals.
fn absolute_error(a: &[f32], b: &[f32], photo: &[f32], w: usize, h: usize, k: usize) -> ([f64; 3], [f64; 3]) {
    let (sw, sh) = ((w / k).max(1), (h / k).max(1));
    let cells = (sw * sh) as f64;
    let (mut e, mut e2) = ([0.0f64; 3], [0.0f64; 3]);
    for y in 0..sh {
        for x in 0..sw {
            let mut d = [0.0f64; 3];
            let mut n = 0.0f64;
            for yy in y * k..((y + 1) * k).min(h) {
                for xx in x * k..((x + 1) * k).min(w) {
                    let p = 3 * (yy * w + xx);
                    for c in 0..3 {
                        d[c] += f64::from(0.5 * (a[p + c] + b[p + c]) - photo[p + c]);
                    }
                    n += 1.0;
                }
            }
            for c in 0..3 {
                let v = (d[c] / n).abs();
                e[c] += v / cells;
                e2[c] += v * v / cells;
            }
        }
    }
    let se = std::array::from_fn(|c| ((e2[c] - e[c] * e[c]).max(0.0) / cells).sqrt());
    (e, se)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bins hold the render's light, path for path: their sum is the renderer's image from the same seed
    /// (to float rounding), and with no surface divided all reflected light is in the first reflected bin.
    /// The example room at 16x12, 8-vertex paths, every material divided, then none.
    #[test]
    fn the_bins_sum_to_the_render() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/room/scene.json");
        let mut scene = crate::scene::load_scene(std::path::Path::new(path)).unwrap();
        (scene.camera.width, scene.camera.height) = (16, 12);
        scene.settings.max_depth = 8;
        (scene.settings.spp, scene.settings.seed) = (8, 3);
        let render = crate::render::render_cpu(&SceneData::build(&scene).unwrap(), &scene.settings, &|_, _| {});
        let n = scene.materials.len();
        for divided in [vec![true; n], vec![false; n]] {
            let b = render_bounces(&scene, &divided, 8, 3).unwrap();
            let sum: Vec<f32> =
                (0..b.tail.len()).map(|v| b.bins.iter().map(|bin| bin[v]).sum::<f32>() + b.tail[v]).collect();
            for (v, (s, r)) in sum.iter().zip(&render.radiance).enumerate() {
                assert!((s - r).abs() <= 1e-4 * r.abs().max(1.0), "value {v}: bins {s}, render {r}");
            }
            let beyond: f32 = b.bins[2..].iter().flatten().chain(&b.tail).sum();
            let reflected: f32 = b.bins[1..].iter().flatten().chain(&b.tail).sum();
            assert!(reflected > 0.0);
            if divided[0] {
                assert!(beyond > 0.05 * reflected, "every surface divided: light past one bounce {beyond}");
            } else {
                assert_eq!(beyond, 0.0, "nothing divided: every reflected path in the first bin");
            }
        }
    }

    /// Two segments of one pixel each, their light split by bounce in closed form: at every factor the scales
    /// reproduce each segment's photo colour (the division's condition, f (B_0 + s_i bounced(s̄)) = photo), s̄
    /// is their weighted mean, the prediction at the factor is the photo there, and at the scene's own factor
    /// and albedos (photo = the render) every scale is 1. The tail at s = 1 is the tail as rendered.
    #[test]
    fn the_scales_reproduce_each_segments_colour_at_every_factor() {
        // Bins per pixel (one channel's values repeated in RGB): 0.05 emitted, 0.3 direct, then falling by half.
        let pixel = [0.05f32, 0.3, 0.12, 0.06, 0.03];
        let rgb = |v: f32| vec![v, v, v, v, v, v];
        let bins: Vec<Vec<f32>> = pixel.iter().map(|&v| rgb(v)).collect();
        let tail = rgb(0.03);
        let image = BounceImage { bins: bins.clone(), tail: tail.clone() };
        let rendered: f32 = pixel.iter().sum::<f32>() + 0.03;
        let model = BounceModel {
            halves: [BounceImage { bins: bins.clone(), tail: tail.clone() }, image],
            bin_means: vec![[pixel; 3]; 2],
            tail_means: vec![[0.03; 3]; 2],
            want: vec![Vec3::splat(rendered), Vec3::splat(0.8 * rendered)],
            weights: vec![1.0, 3.0],
            albedos: vec![Vec3::splat(0.5); 2],
            cover: vec![vec![(0, 1.0)], vec![(1, 1.0)]],
            tail_ratio: [0.5; 3],
        };
        assert!((model.bounced(pixel, 0.03, 1.0, 0) - (rendered - 0.05)).abs() < 1e-6);
        for f in [0.7f32, 1.0, 1.6] {
            let scales = model.scales(Vec3::splat(f));
            let mean = (scales[0].x + 3.0 * scales[1].x) / 4.0;
            for (i, (s, want)) in scales.iter().zip(&model.want).enumerate() {
                let got = f * (pixel[0] + s.x * model.bounced(pixel, 0.03, mean, 0));
                assert!((got / want.x - 1.0).abs() < 1e-4, "factor {f}, segment {i}: {got}");
            }
            let predicted = model.predict(0, Vec3::splat(f), &scales);
            assert!(
                (predicted[0] / model.want[0].x - 1.0).abs() < 1e-4
                    && (predicted[3] / model.want[1].x - 1.0).abs() < 1e-4
            );
            // Brighter lights, darker albedos.
            if f > 1.0 {
                assert!(scales[0].x < 1.0, "{scales:?}");
            }
        }
        // The first segment's photo is the render: with both segments at the render (want 1x), scales are 1.
        let at_render = BounceModel { want: vec![Vec3::splat(rendered); 2], ..model };
        for s in at_render.scales(Vec3::ONE) {
            assert!((s - Vec3::ONE).abs().max_element() < 1e-4, "{s}");
        }
    }
}
