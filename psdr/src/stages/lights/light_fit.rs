//! Light radiances from a photo (PSDR-Room, "Material and lighting stage", initialisation). Rendering is linear in
//! the emitters' radiances, so one render per candidate light with unit radiance gives a basis; the radiances
//! are the non-negative least-squares fit of the basis to the photo, box-downsampled (per colour channel; this
//! generalises the paper's search over one global scale). "Model no more than a scene needs": lights are then
//! removed one at a time (greedy backward elimination) while removing the least useful one raises the fit's
//! error by less than a stated fraction. A light the photo shows (`is_visible_light`: a window, a ceiling light
//! in view) is never removed: its pixels say it is there (real room00's material stage dropped one of its two
//! ceiling lights in view, the rest of the room lit by a window 4x too bright).

use super::albedo_free_split::AlbedoFreeSplit;
use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::render::SceneData;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// Knobs of the fit.
#[derive(Clone, Debug)]
pub struct LightFitOptions {
    /// The photo and the basis renders are compared at 1/downsample of the photo's size (box filter).
    pub downsample: usize,
    /// Samples per pixel of each basis render.
    pub spp: u32,
    /// Path length of the basis renders (global illumination); None: the scene's, so that the lights are fitted
    /// under the interreflections the rest of the fit renders.
    pub max_depth: Option<u32>,
    /// A light is removed when that raises the fit's relative RMS error by less than this (0 keeps all).
    pub removal_threshold: f32,
    pub seed: u32,
    /// One radiance per light for the three channels (`FitTarget::white_lights`).
    pub white: bool,
    /// With coloured lights, how strongly each light's colour is held to the photo's white balance
    /// (`FitTarget::tint_prior`; 0: free).
    pub tint_prior: f32,
    /// Where the fitted geometry and the segmentation disagree (`FitTarget::with_agreement`).
    pub agreement: Agreement,
}

/// Per photo pixel, 1 where the fitted scene shows what the segmentation says the photo shows, 0 where it does
/// not (`stages::geometry_agreement`; empty: everywhere), and the share of a compared block's pixels that must
/// agree for the block to be fitted.
#[derive(Clone, Debug, Default)]
pub struct Agreement {
    pub mask: Vec<f32>,
    pub min_share: f32,
}

impl Default for LightFitOptions {
    fn default() -> Self {
        LightFitOptions {
            downsample: 8,
            spp: 64,
            max_depth: None,
            removal_threshold: 0.01,
            seed: 0,
            white: false,
            tint_prior: 0.0,
            agreement: Agreement::default(),
        }
    }
}

/// The fit: per light its radiance (0 if removed), which lights were kept, and the error.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LightFit {
    pub names: Vec<String>,
    pub radiance: Vec<[f32; 3]>,
    pub kept: Vec<bool>,
    /// RMS of (fit - photo) over the downsampled photo, relative to the photo's RMS (clipped pixels left out).
    pub relative_rms: f32,
    /// The same with every candidate light in the fit.
    pub relative_rms_all: f32,
    /// Mean luminance of the fit over the photo's, downsampled (where the photo is not clipped).
    pub luminance_ratio: f32,
}

/// Box-downsamples an interleaved RGB image by k (partial blocks at the right and bottom edges dropped).
pub(crate) fn downsample(data: &[f32], w: usize, h: usize, k: usize) -> (Vec<f32>, usize, usize) {
    let (dw, dh) = ((w / k).max(1), (h / k).max(1));
    let k = k.min(w).min(h).max(1);
    let mut out = vec![0.0; dw * dh * 3];
    for y in 0..dh * k {
        for x in 0..dw * k {
            for c in 0..3 {
                out[((y / k) * dw + x / k) * 3 + c] += data[(y * w + x) * 3 + c] / (k * k) as f32;
            }
        }
    }
    (out, dw, dh)
}

/// The photo as the light fits compare it: box-downsampled by k, and per reduced pixel 1 where every photo
/// pixel under it records the scene, 0 where one is clipped (`vision::unclipped`): those are left out (unless
/// nearly all are).
#[derive(Clone)]
pub(crate) struct FitTarget {
    pub values: Vec<f32>,
    pub weights: Vec<f32>,
    /// Per reduced pixel, whether it is left out for the scene's geometry, not for clipping
    /// (`with_agreement`): such a pixel neither counts nor bounds the fit from below.
    pub disagrees: Vec<bool>,
    /// Per reduced pixel, the surface it shows (`with_segments`), or NO_SEGMENT.
    pub segment: Vec<u32>,
    pub segments: usize,
    /// One radiance per light for the three channels (`white_lights`).
    pub white: bool,
    /// The surface with the most pixels (NO_SEGMENT without segments): it fixes the gauge the free albedos
    /// leave open (`with_segments`).
    pub largest: u32,
    /// The weight of the coloured lights' pull toward one colour for all (`tint_prior`); 0: none.
    pub tint_prior: f64,
}

pub(crate) const NO_SEGMENT: u32 = u32::MAX;

/// A reduced pixel belongs to a segment when this share of the photo pixels under it do.
const SEGMENT_SHARE: f32 = 0.9;

impl FitTarget {
    pub(crate) fn new(photo: &[f32], w: usize, h: usize, k: usize) -> FitTarget {
        let k = k.max(1);
        let (values, _, _) = downsample(photo, w, h, k);
        let ones: Vec<f32> = crate::vision::unclipped(photo, w).iter().flat_map(|&u| [u; 3]).collect();
        let (covered, _, _) = downsample(&ones, w, h, k);
        let mut weights: Vec<f32> = covered.chunks(3).map(|c| if c[0] > 1.0 - 1e-4 { 1.0 } else { 0.0 }).collect();
        // A photo clipped nearly everywhere still gets a fit, from all of it, rather than none.
        if weights.iter().sum::<f32>() < 0.01 * weights.len() as f32 {
            weights.iter_mut().for_each(|w| *w = 1.0);
        }
        let segment = vec![NO_SEGMENT; weights.len()];
        let disagrees = vec![false; weights.len()];
        FitTarget {
            values,
            weights,
            disagrees,
            segment,
            segments: 0,
            white: false,
            largest: NO_SEGMENT,
            tint_prior: 0.0,
        }
    }

    /// The same target with the reduced pixels where under `agreement.min_share` of the photo pixels agree
    /// with the fitted geometry left out: there the photo shows another surface than the renders (a retrieved
    /// model lower than the photo's wall unit, the wall behind it rendered where the photo shows the unit), and
    /// the lights and free albedos would be fitted to that. A few disagreeing pixels along an object's outline
    /// (a pixel's misfit of the pose) leave their block in. No mask, or one of another size: unchanged.
    pub(crate) fn with_agreement(mut self, agreement: &Agreement, w: usize, h: usize, k: usize) -> FitTarget {
        if agreement.mask.len() != w * h {
            return self;
        }
        let rgb: Vec<f32> = agreement.mask.iter().flat_map(|&v| [v.clamp(0.0, 1.0); 3]).collect();
        let (share, _, _) = downsample(&rgb, w, h, k.max(1));
        for (p, s) in share.chunks(3).enumerate() {
            if s[0] < agreement.min_share {
                self.weights[p] = 0.0;
                self.disagrees[p] = true;
            }
        }
        self
    }

    /// The same target fitted by coloured lights held to one colour: each light's radiance per channel is
    /// pulled toward the white fit's radiance times a gain per channel common to all lights (the photo's white
    /// balance), with weight `weight` times the squared norm of the light's render (a ridge in the least
    /// squares). Two lights that light the room alike (a ceiling light and a window, after many bounces)
    /// cannot be told apart per channel: fitted free, real room01's ceiling light took the red and the
    /// window the blue ([11.4, 4.3, 0.0] and [3.4, 6.0, 6.7] from white [7.7] and [5.7]), and the albedos
    /// turned blue to match. Where the photo does tell a light's colour (a window's cool light on one side of
    /// the room, a warm lamp on the other) a small weight leaves it that colour.
    pub(crate) fn tint_prior(mut self, weight: f32) -> FitTarget {
        self.tint_prior = weight.max(0.0) as f64;
        self
    }

    /// The same target fitted by white lights: a light's colour and the colour of the surfaces it lights
    /// cannot be told apart while the surfaces' albedos are free, so a coloured light may take on the colour
    /// of the surface under it; white lights leave the colours to the material stage's fits.
    pub(crate) fn white_lights(mut self, white: bool) -> FitTarget {
        self.white = white;
        self
    }

    /// The same target, told which surface each pixel shows (`masks`: one per surface, 1 where the photo
    /// shows it, the photo's size): then each surface's albedo is a free factor per colour channel of the fit,
    /// relative to the scene's material now, and the lights explain only how the light varies across each
    /// surface, not its colour (with the scene's materials still grey, a dark floor would
    /// otherwise pull lights away from it). What the photo cannot tell, a common factor of the lights against
    /// one of the albedos, is fixed on the largest surface: with coloured lights it keeps its material's
    /// albedo (the factor 1 per channel), which fixes the radiances' scale and colour; with white lights
    /// (`white_lights`) only its factors' mean over the channels is 1, so its colour comes from the photo (a
    /// grey start on an orange floor would otherwise make every light orange).
    pub(crate) fn with_segments(mut self, masks: &[Vec<f32>], w: usize, h: usize, k: usize) -> FitTarget {
        let k = k.max(1);
        let mut best = vec![(0.0f32, NO_SEGMENT); self.weights.len()];
        for (s, m) in masks.iter().enumerate().filter(|(_, m)| m.len() == w * h) {
            let rgb: Vec<f32> = m.iter().flat_map(|&v| [v.clamp(0.0, 1.0); 3]).collect();
            let (share, _, _) = downsample(&rgb, w, h, k);
            for (b, c) in best.iter_mut().zip(share.chunks(3)) {
                if c[0] > b.0 {
                    *b = (c[0], s as u32);
                }
            }
        }
        self.segment = best.iter().map(|&(share, s)| if share >= SEGMENT_SHARE { s } else { NO_SEGMENT }).collect();
        self.segments = masks.len();
        let count = |s: u32| self.segment.iter().filter(|&&x| x == s).count();
        self.largest = (0..self.segments as u32).max_by_key(|&s| count(s)).unwrap_or(NO_SEGMENT);
        self
    }

    /// Sum of the squared weighted values: the norm the fits' relative errors divide by.
    pub(crate) fn norm(&self) -> f64 {
        let w = |i: usize| self.weights[i / 3] as f64;
        self.values.iter().enumerate().map(|(i, v)| w(i) * (*v as f64).powi(2)).sum::<f64>().max(1e-30)
    }
}

/// Non-negative least squares min |A x - b|, x >= 0, for a few columns (Lawson-Hanson active set). `a` is
/// column-major: a[j] is column j.
pub fn nnls(a: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
    let n = a.len();
    let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(x, y)| x * y).sum::<f64>();
    let ata: Vec<Vec<f64>> = (0..n).map(|i| (0..n).map(|j| dot(&a[i], &a[j])).collect()).collect();
    let atb: Vec<f64> = (0..n).map(|i| dot(&a[i], b)).collect();
    // Unconstrained least squares on the passive set (normal equations, Gaussian elimination).
    let solve = |set: &[usize]| -> Vec<f64> {
        let mat: Vec<Vec<f64>> = set.iter().map(|&i| set.iter().map(|&j| ata[i][j]).collect()).collect();
        solve_dense(mat, set.iter().map(|&i| atb[i]).collect())
    };
    let mut x = vec![0.0; n];
    let mut passive: Vec<usize> = vec![];
    for _ in 0..3 * n + 10 {
        // Gradient of -1/2 |Ax - b|^2: w = A^T (b - A x).
        let w: Vec<f64> = (0..n).map(|i| atb[i] - (0..n).map(|j| ata[i][j] * x[j]).sum::<f64>()).collect();
        let Some(t) = (0..n).filter(|i| !passive.contains(i)).max_by(|&p, &q| w[p].total_cmp(&w[q])) else { break };
        if w[t] <= 1e-12 * atb.iter().map(|v| v.abs()).fold(1e-30, f64::max) {
            break;
        }
        passive.push(t);
        loop {
            let z = solve(&passive);
            if z.iter().all(|&v| v > 0.0) {
                for (k, &i) in passive.iter().enumerate() {
                    x[i] = z[k];
                }
                break;
            }
            // Step toward z until a variable hits zero; drop it from the passive set.
            let alpha = passive
                .iter()
                .enumerate()
                .filter(|(k, _)| z[*k] <= 0.0)
                .map(|(k, &i)| x[i] / (x[i] - z[k]).max(1e-300))
                .fold(1.0f64, f64::min);
            for (k, &i) in passive.iter().enumerate() {
                x[i] += alpha * (z[k] - x[i]);
            }
            passive.retain(|&i| x[i] > 1e-12);
            for (i, v) in x.iter_mut().enumerate() {
                if !passive.contains(&i) {
                    *v = 0.0;
                }
            }
            if passive.is_empty() {
                break;
            }
        }
    }
    x
}

/// Solves m x = rhs by Gaussian elimination with partial pivoting; a singular pivot leaves its unknown at 0.
pub(crate) fn solve_dense(mut m: Vec<Vec<f64>>, mut rhs: Vec<f64>) -> Vec<f64> {
    let n = rhs.len();
    for c in 0..n {
        let p = (c..n).max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs())).unwrap_or(c);
        m.swap(c, p);
        rhs.swap(c, p);
        if m[c][c].abs() < 1e-300 {
            continue;
        }
        for r in c + 1..n {
            let f = m[r][c] / m[c][c];
            let row = m[c].clone();
            for (v, pv) in m[r].iter_mut().zip(row).skip(c) {
                *v -= f * pv;
            }
            rhs[r] -= f * rhs[c];
        }
    }
    let mut z = vec![0.0; n];
    for c in (0..n).rev() {
        let s: f64 = (c + 1..n).map(|j| m[c][j] * z[j]).sum();
        z[c] = if m[c][c].abs() < 1e-300 { 0.0 } else { (rhs[c] - s) / m[c][c] };
    }
    z
}

/// `scene` lit by object `light` alone at unit radiance, with the fit's render settings.
pub(crate) fn lit_by(scene: &Scene, light: usize, opts: &LightFitOptions) -> Scene {
    let mut s = scene.clone();
    for (oi, o) in s.objects.iter_mut().enumerate() {
        if let Some(e) = o.emitter.as_mut() {
            e.radiance = if oi == light { Vec3::ONE } else { Vec3::ZERO };
        }
    }
    (s.settings.spp, s.settings.seed) = (opts.spp, opts.seed);
    if let Some(d) = opts.max_depth {
        s.settings.max_depth = d;
    }
    s
}

/// The renders of `scene` lit by each of objects `lights` alone at unit radiance, at the size the fit compares
/// them (1/k of the camera's, k = `downsample`): rendered at that size where k divides the camera's sides (`spp`
/// per small pixel), else at the camera's size with spp/k^2 per pixel and box-downsampled, the same samples per
/// block (a full-size render at `spp` would cost k^2 times as much for the same comparison). The geometry is
/// flattened once and only the emitters' radiances change between lights (`SceneData::set_emitter_radiances`;
/// the same data as building each lit scene). `each` is called before each render.
pub(crate) fn unit_renders(
    backend: &mut dyn Backend,
    scene: &Scene,
    lights: &[usize],
    opts: &LightFitOptions,
    mut each: impl FnMut(),
) -> Result<Vec<Vec<f32>>> {
    let Some(&first) = lights.first() else { return Ok(vec![]) };
    let mut s = lit_by(scene, first, opts);
    let k = opts.downsample.max(1);
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let at_small_size = w % k == 0 && h % k == 0;
    if at_small_size {
        (s.camera.width, s.camera.height) = ((w / k) as u32, (h / k) as u32);
    } else {
        s.settings.spp = opts.spp.div_ceil((k * k) as u32).max(1);
    }
    let mut data = SceneData::build(&s)?;
    let emitting: Vec<usize> = (0..scene.objects.len()).filter(|&i| scene.objects[i].emitter.is_some()).collect();
    // Each light's emitter (a light asked for twice is rendered once; one that does not emit is black).
    let emitter = |light: usize| emitting.iter().position(|&i| i == light);
    let mut rendered: Vec<usize> = lights.iter().filter_map(|&l| emitter(l)).collect();
    rendered.sort_unstable();
    rendered.dedup();
    lights.iter().for_each(|_| each());
    let radiances = backend.unit_radiances(&mut data, &s.settings, &rendered)?;
    Ok(lights
        .iter()
        .map(|&light| {
            let Some(e) = emitter(light) else { return vec![0.0; (w / k).max(1) * (h / k).max(1) * 3] };
            let r = &radiances[rendered.binary_search(&e).expect("rendered")];
            if at_small_size {
                r.clone()
            } else {
                downsample(r, w, h, k).0
            }
        })
        .collect())
}

/// `unit_renders` of one light.
pub(crate) fn unit_render(
    backend: &mut dyn Backend,
    scene: &Scene,
    light: usize,
    opts: &LightFitOptions,
) -> Result<Vec<f32>> {
    Ok(unit_renders(backend, scene, &[light], opts, || {})?.remove(0))
}

/// Per channel, the non-negative least-squares radiances of the `active` basis images for `target` (its
/// left-out pixels dropped): the radiances (zero for inactive ones) and the squared error summed over channels.
/// With segments (`FitTarget::with_segments`) each segment's albedo factor per channel is fitted too, jointly
/// with the radiances (`AlbedoFreeSplit`: the radiances with each factor at its closed-form best); with
/// `FitTarget::white_lights` each light has one radiance for the three channels.
/// The error also counts every left-out (clipped) pixel the fit leaves darker than the photo: a clipped value
/// is a lower bound, so a window or lamp the photo shows must stay at least that bright where it shows (without
/// this, the light placement shrank a visible window freely, its own pixels being all clipped).
pub(crate) fn nnls_fit(basis: &[Vec<f32>], target: &FitTarget, active: &[usize]) -> (Vec<[f32; 3]>, f64) {
    let kept: Vec<usize> = (0..target.weights.len()).filter(|&p| target.weights[p] > 0.0).collect();
    let free = target.segments > 0;
    let groups: Vec<Vec<usize>> = if target.white { vec![vec![0, 1, 2]] } else { vec![vec![0], vec![1], vec![2]] };
    let anchor = if target.white || target.tint_prior <= 0.0 { None } else { Some(tint_anchor(basis, target, active)) };
    let mut rad = vec![[0.0f32; 3]; basis.len()];
    // Per channel and segment, the albedo factor.
    let mut albedo = vec![vec![1.0f64; target.segments]; 3];
    let factor = |albedo: &[Vec<f64>], c: usize, p: usize| match target.segment[p] {
        NO_SEGMENT => 1.0,
        s => albedo[c][s as usize],
    };
    let mut err = 0.0f64;
    for g in &groups {
        // Rows: every kept pixel of every channel of the group.
        let rows: Vec<(usize, usize)> = g.iter().flat_map(|&c| kept.iter().map(move |&p| (c, p))).collect();
        let unit = |i: usize, (c, p): (usize, usize)| basis[i][p * 3 + c] as f64;
        let b: Vec<f64> = rows.iter().map(|&(c, p)| target.values[p * 3 + c] as f64).collect();
        let scaled = |albedo: &[Vec<f64>]| -> Vec<Vec<f64>> {
            active.iter().map(|&i| rows.iter().map(|&r| unit(i, r) * factor(albedo, r.0, r.1)).collect()).collect()
        };
        let solve = |cols: Vec<Vec<f64>>| match &anchor {
            Some(anchor) => {
                nnls_toward(cols, &b, &anchor.iter().map(|a| a[g[0]]).collect::<Vec<_>>(), target.tint_prior)
            }
            None => nnls(&cols, &b),
        };
        let mut x = solve(scaled(&albedo));
        if free {
            // The radiances with every free factor at its best (variable projection), then the factors.
            let block = |c: usize, s: u32| -> Option<usize> {
                let free = s != NO_SEGMENT && (target.white || s != target.largest);
                let k = g.iter().position(|&gc| gc == c)?;
                free.then_some(k * target.segments + s as usize)
            };
            let mut split = AlbedoFreeSplit::new(active.len(), g.len() * target.segments);
            for (q, &(c, p)) in rows.iter().enumerate() {
                let u: Vec<f64> = active.iter().map(|&i| unit(i, (c, p))).collect();
                match block(c, target.segment[p]) {
                    Some(k) => split.blocks[k].add(b[q], &u),
                    None => split.fixed.add(b[q], &u),
                }
            }
            if let Some(anchor) = &anchor {
                let cols = scaled(&albedo);
                split.ridge = (0..active.len())
                    .map(|k| (target.tint_prior * cols[k].iter().map(|v| v * v).sum::<f64>(), anchor[k][g[0]]))
                    .collect();
            }
            x = split.solve(&x);
            for (k, &c) in g.iter().enumerate() {
                for s in (0..target.segments).filter(|&s| block(c, s as u32).is_some()) {
                    if let Some((f, _)) = split.blocks[k * target.segments + s].factor(&x) {
                        albedo[c][s] = f.clamp(0.02, 50.0);
                    }
                }
            }
            if target.white && target.largest != NO_SEGMENT {
                let l = target.largest as usize;
                let m = (albedo[0][l] + albedo[1][l] + albedo[2][l]) / 3.0;
                albedo.iter_mut().flatten().for_each(|a| *a /= m);
                x = solve(scaled(&albedo));
            }
        }
        for (k, &i) in active.iter().enumerate() {
            g.iter().for_each(|&c| rad[i][c] = x[k] as f32);
        }
        let model = |c: usize, p: usize| -> f64 {
            factor(&albedo, c, p) * active.iter().zip(&x).map(|(&i, xk)| unit(i, (c, p)) * xk).sum::<f64>()
        };
        for (q, &(c, p)) in rows.iter().enumerate() {
            err += (model(c, p) - b[q]).powi(2);
        }
        for c in g.iter().copied() {
            for p in (0..target.weights.len()).filter(|&p| target.weights[p] == 0.0 && !target.disagrees[p]) {
                err += (target.values[p * 3 + c] as f64 - model(c, p)).max(0.0).powi(2);
            }
        }
    }
    (rad, err)
}

/// Per active light and channel, what `FitTarget::tint_prior` pulls a coloured light toward: its radiance in
/// the white fit times the channel's gain for all lights (least squares of the photo against the white fit's
/// render, per channel).
fn tint_anchor(basis: &[Vec<f32>], target: &FitTarget, active: &[usize]) -> Vec<[f64; 3]> {
    let white_target = FitTarget { white: true, tint_prior: 0.0, ..target.clone() };
    let (white, _) = nnls_fit(basis, &white_target, active);
    let gain: [f64; 3] = std::array::from_fn(|c| {
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for p in (0..target.weights.len()).filter(|&p| target.weights[p] > 0.0) {
            let m: f64 = active.iter().map(|&i| basis[i][p * 3 + c] as f64 * white[i][c] as f64).sum();
            num += target.values[p * 3 + c] as f64 * m;
            den += m * m;
        }
        if den > 1e-30 {
            num / den
        } else {
            1.0
        }
    });
    active.iter().map(|&i| std::array::from_fn(|c| white[i][c] as f64 * gain[c])).collect()
}

/// `nnls` with a ridge toward `anchor`: min |A x - b|^2 + weight * sum_k |A_k|^2 (x_k - anchor_k)^2, x >= 0
/// (rows appended to the system: each column's penalty scales with how much that light shows).
fn nnls_toward(mut cols: Vec<Vec<f64>>, b: &[f64], anchor: &[f64], weight: f64) -> Vec<f64> {
    let n = cols.len();
    let norms: Vec<f64> = cols.iter().map(|c| c.iter().map(|v| v * v).sum::<f64>()).collect();
    let mut b = b.to_vec();
    for k in 0..n {
        let r = (weight * norms[k]).sqrt();
        for (j, col) in cols.iter_mut().enumerate() {
            col.push(if j == k { r } else { 0.0 });
        }
        b.push(r * anchor[k]);
    }
    nnls(&cols, &b)
}

/// Fits the radiances of the emitters named `lights` (objects of `scene` with an emitter) to `photo` (linear RGB,
/// the camera's size), then removes the lights the photo does not need. With `segments` (masks of the surfaces
/// the photo shows; may be empty) each surface's albedo is free in the fit (`FitTarget::with_segments`).
/// The unit renders run on `backend`.
pub fn fit_lights(
    backend: &mut dyn Backend,
    scene: &Scene,
    lights: &[String],
    photo: &[f32],
    segments: &[Vec<f32>],
    opts: &LightFitOptions,
) -> Result<LightFit> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    if photo.len() != w * h * 3 {
        return Err(Error::Invalid(format!(
            "light fit: the photo has {} values, the camera renders {w}x{h} RGB",
            photo.len()
        )));
    }
    if lights.is_empty() {
        return Err(Error::Invalid("light fit: no candidate lights".into()));
    }
    let index: Vec<usize> = lights
        .iter()
        .map(|n| {
            scene
                .objects
                .iter()
                .position(|o| &o.name == n && o.emitter.is_some())
                .ok_or_else(|| Error::Invalid(format!("light fit: '{n}' is not an emitter of the scene")))
        })
        .collect::<Result<_>>()?;
    let target = FitTarget::new(photo, w, h, opts.downsample)
        .with_segments(segments, w, h, opts.downsample)
        .with_agreement(&opts.agreement, w, h, opts.downsample)
        .white_lights(opts.white)
        .tint_prior(opts.tint_prior);
    let progress = crate::progress::activity(format!("unit renders of {} lights", index.len()), Some(index.len()));
    let basis = unit_renders(backend, scene, &index, opts, || progress.advance())?;
    drop(progress);
    let fit = |active: &[usize]| nnls_fit(&basis, &target, active);
    let norm = target.norm();
    let rel = |err: f64| (err / norm).sqrt() as f32;
    let mut active: Vec<usize> = (0..index.len()).collect();
    let (mut rad, mut err) = fit(&active);
    let all = rel(err);
    // Backward elimination: drop the light whose removal costs least, while that cost stays under the threshold.
    // A light the photo shows (a window, a ceiling light in view) is there whatever the fit says: it stays.
    // The trials are fitted in parallel and the least kept in their order (the first of equals, as before).
    while active.len() > 1 {
        let droppable: Vec<usize> =
            active.iter().copied().filter(|&drop| !super::is_visible_light(&lights[drop])).collect();
        let trials: Vec<(usize, Vec<[f32; 3]>, f64)> = droppable
            .par_iter()
            .map(|&drop| {
                let rest: Vec<usize> = active.iter().copied().filter(|&i| i != drop).collect();
                let (r, e) = fit(&rest);
                (drop, r, e)
            })
            .collect();
        let trial = trials.into_iter().min_by(|a, b| a.2.total_cmp(&b.2));
        let Some((drop, r, e)) = trial else { break };
        if rel(e) - rel(err) >= opts.removal_threshold {
            break;
        }
        active.retain(|&i| i != drop);
        (rad, err) = (r, e);
    }
    let lum = |v: &[f32]| {
        let l = |c: &[f32]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        v.chunks(3).zip(&target.weights).map(|(c, w)| w * l(c)).sum::<f32>()
    };
    let fitted: Vec<f32> =
        (0..target.values.len()).map(|k| active.iter().map(|&i| basis[i][k] * rad[i][k % 3]).sum()).collect();
    Ok(LightFit {
        names: lights.to_vec(),
        kept: (0..index.len()).map(|i| active.contains(&i)).collect(),
        radiance: rad,
        relative_rms: rel(err),
        relative_rms_all: all,
        luminance_ratio: lum(&fitted) / lum(&target.values).max(1e-30),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two lights, two surfaces (3 and 1 blocks of 8x8 pixels): the photo is light A's render at radiance 0.5,
    /// with the smaller surface's albedo 0.4 of the scene's (the larger keeps the scene's). With the surfaces' albedos free the fit finds light A alone and no
    /// error; with the scene's albedos as they are it needs light B to darken the second surface.
    #[test]
    fn free_surface_albedos_keep_the_lights_from_explaining_colour() {
        let (w, h, k) = (32, 8, 8);
        let a = [1.0f32, 0.8, 0.5, 0.3];
        let b = [0.2f32, 0.3, 0.9, 0.6];
        let block = |v: &[f32; 4]| -> Vec<f32> { (0..w * h).flat_map(|p| [v[(p % w) / k]; 3]).collect() };
        let (ua, ub) = (downsample(&block(&a), w, h, k).0, downsample(&block(&b), w, h, k).0);
        let albedo = [1.0f32, 1.0, 1.0, 0.4];
        let photo: Vec<f32> = (0..w * h).flat_map(|p| [a[(p % w) / k] * albedo[(p % w) / k] * 0.5; 3]).collect();
        let masks: Vec<Vec<f32>> = [[1.0f32, 1.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
            .iter()
            .map(|m| (0..w * h).map(|p| m[(p % w) / k]).collect())
            .collect();
        let free = FitTarget::new(&photo, w, h, k).with_segments(&masks, w, h, k);
        let (rad, err) = nnls_fit(&[ua.clone(), ub.clone()], &free, &[0, 1]);
        assert!(err < 1e-10 && (rad[0][0] - 0.5).abs() < 1e-4 && rad[1][0] < 1e-4, "{rad:?} {err}");
        let fixed = FitTarget::new(&photo, w, h, k);
        let (rad, err) = nnls_fit(&[ua, ub], &fixed, &[0, 1]);
        assert!(err > 1e-3 || rad[1][0] > 1e-3, "the scene's albedos must need B or leave an error: {rad:?} {err}");
    }

    /// One light, two surfaces of grey material: in the photo the larger is orange and the smaller blue
    /// under a white light. With coloured lights the larger surface keeps its grey and the light turns orange;
    /// with white lights the light stays white and each surface takes its colour, the larger keeping only its
    /// brightness (its factors' mean 1).
    #[test]
    fn white_lights_leave_the_largest_surface_its_colour() {
        let (w, h, k) = (32, 8, 8);
        let unit = [1.0f32, 0.8, 0.6, 0.4];
        let orange = [1.4f32, 1.0, 0.6];
        let blue = [0.5f32, 0.7, 1.2];
        let colour = |p: usize| if (p % w) / k < 3 { orange } else { blue };
        let photo: Vec<f32> =
            (0..w * h).flat_map(|p| (0..3).map(move |c| 0.3 * unit[(p % w) / k] * colour(p)[c])).collect();
        let basis = downsample(&(0..w * h).flat_map(|p| [unit[(p % w) / k]; 3]).collect::<Vec<_>>(), w, h, k).0;
        let masks: Vec<Vec<f32>> = [[1.0f32, 1.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
            .iter()
            .map(|m| (0..w * h).map(|p| m[(p % w) / k]).collect())
            .collect();
        let target = || FitTarget::new(&photo, w, h, k).with_segments(&masks, w, h, k);
        let (coloured, err) = nnls_fit(std::slice::from_ref(&basis), &target(), &[0]);
        assert!(err < 1e-6, "{err}");
        let c = coloured[0];
        assert!((c[0] / c[2] - orange[0] / orange[2]).abs() < 1e-3, "the light takes the surface's colour: {c:?}");
        let (white, err) = nnls_fit(&[basis], &target().white_lights(true), &[0]);
        assert!(err < 1e-6, "{err}");
        let l = white[0];
        assert!(l[0] == l[1] && l[1] == l[2], "{l:?}");
        // The larger surface's mean factor is 1: the light is 0.3 times the orange's channel mean.
        assert!((l[0] - 0.3 * (orange[0] + orange[1] + orange[2]) / 3.0).abs() < 1e-4, "{l:?}");
    }

    /// Two lights whose renders differ by a few percent (a ceiling light and a window after many bounces),
    /// both white in truth (the photo below the 8-bit white, where pixels count as clipped), the photo 1 % off
    /// in one block's red by 2 % (noise, a model's error): per channel and
    /// free, the fit splits the channels between the two lights (a channel 28 % and 23 % off the light's
    /// mean); held to one colour (`tint_prior` 0.1) both stay within 5 % of white (measured 0.3 and 0.5 %).
    /// Two lights that light different halves of the room keep their own colours (a warm and a cool light, red
    /// over blue 1.5 and 0.67) within 10 % under the same prior (measured 1.44 and 0.70).
    #[test]
    fn the_tint_prior_holds_alike_lights_to_one_colour_and_leaves_distinct_ones_theirs() {
        let (w, h, k) = (32, 8, 8);
        let blocks = |v: [f32; 4], colour: [f32; 3]| -> Vec<f32> {
            (0..w * h).flat_map(|p| colour.map(|c| c * v[(p % w) / k])).collect()
        };
        let (a, b) = ([1.0f32, 0.8, 0.6, 0.4], [0.96f32, 0.82, 0.61, 0.41]);
        let (ua, ub) = (downsample(&blocks(a, [1.0; 3]), w, h, k).0, downsample(&blocks(b, [1.0; 3]), w, h, k).0);
        let mut photo: Vec<f32> = blocks(a, [0.3; 3]).iter().zip(blocks(b, [0.3; 3])).map(|(x, y)| x + y).collect();
        (0..w * h).filter(|p| (p % w) / k == 1).for_each(|p| photo[p * 3] *= 1.02);
        let tint = |r: [f32; 3]| {
            let m = (r[0] + r[1] + r[2]) / 3.0;
            r.iter().map(|v| (v / m - 1.0).abs()).fold(0.0f32, f32::max)
        };
        let (free, _) = nnls_fit(&[ua.clone(), ub.clone()], &FitTarget::new(&photo, w, h, k), &[0, 1]);
        assert!(tint(free[0]).max(tint(free[1])) > 0.2, "free: {free:?}");
        let held = FitTarget::new(&photo, w, h, k).tint_prior(0.1);
        let (rad, _) = nnls_fit(&[ua, ub], &held, &[0, 1]);
        assert!(tint(rad[0]) < 0.05 && tint(rad[1]) < 0.05, "held: {rad:?}");
        // Distinct lights, distinct colours.
        let (a, b) = ([1.0f32, 0.9, 0.1, 0.05], [0.05f32, 0.1, 0.9, 1.0]);
        let (warm, cool) = ([0.6f32, 0.5, 0.4], [0.4f32, 0.5, 0.6]);
        let photo: Vec<f32> = blocks(a, warm).iter().zip(blocks(b, cool)).map(|(x, y)| x + y).collect();
        let (ua, ub) = (downsample(&blocks(a, [1.0; 3]), w, h, k).0, downsample(&blocks(b, [1.0; 3]), w, h, k).0);
        let (rad, _) = nnls_fit(&[ua, ub], &FitTarget::new(&photo, w, h, k).tint_prior(0.1), &[0, 1]);
        let (ra, rb) = (rad[0][0] / rad[0][2], rad[1][0] / rad[1][2]);
        assert!(ra > 1.5 * 0.9 && rb < 0.667 / 0.9, "distinct: {rad:?} (red over blue {ra}, {rb})");
    }

    #[test]
    fn clipped_pixels_bound_the_fit_from_below_only() {
        // Two reduced pixels, grey: the first records the scene (0.5), the second is clipped (reads 1.0).
        let target = FitTarget {
            values: vec![0.5; 3].into_iter().chain(vec![1.0; 3]).collect(),
            weights: vec![1.0, 0.0],
            disagrees: vec![false; 2],
            segment: vec![NO_SEGMENT; 2],
            segments: 0,
            white: false,
            largest: NO_SEGMENT,
            tint_prior: 0.0,
        };
        // A light that lights the first pixel 1.0 and the second 3.0 per unit radiance: the radiance comes from
        // the recorded pixel alone (0.5), and the clipped one, rendered 1.5 >= 1, costs nothing.
        let bright = vec![1.0, 1.0, 1.0, 3.0, 3.0, 3.0];
        let (rad, err) = nnls_fit(&[bright], &target, &[0]);
        assert!((rad[0][0] - 0.5).abs() < 1e-6 && err < 1e-12, "{rad:?} {err}");
        // One that lights the clipped pixel only 1.0 per unit: rendered 0.5 there, 0.5 below the bound, per channel.
        let dim = vec![1.0; 6];
        let (_, err) = nnls_fit(&[dim], &target, &[0]);
        assert!((err - 3.0 * 0.25).abs() < 1e-9, "{err}");
    }

    /// Four 8x8 blocks, two lights: the photo is light A at radiance 0.5, except that the fitted geometry is
    /// wrong over the third block (the photo shows a bright object there, the render the wall behind it, which
    /// only light B lights) and a few pixels of the fourth (an outline's misfit). Fitted everywhere, B takes a
    /// share; with the disagreeing block left out the fit is exact and B is off. A disagreeing block neither
    /// counts nor bounds the fit from below, as a clipped one would (its photo value here is white).
    #[test]
    fn blocks_where_the_geometry_disagrees_are_left_out() {
        let (w, h, k) = (32, 8, 8);
        let a = [1.0f32, 0.8, 0.1, 0.3];
        let b = [0.0f32, 0.1, 0.9, 0.05];
        let block = |v: &[f32; 4]| -> Vec<f32> { (0..w * h).flat_map(|p| [v[(p % w) / k]; 3]).collect() };
        let (ua, ub) = (downsample(&block(&a), w, h, k).0, downsample(&block(&b), w, h, k).0);
        let photo_with = |bright: f32| -> Vec<f32> {
            (0..w * h).flat_map(|p| [if (p % w) / k == 2 { bright } else { a[(p % w) / k] * 0.5 }; 3]).collect()
        };
        let photo = photo_with(0.9);
        // The third block disagrees everywhere, the fourth on its first column (an eighth of it).
        let mask: Vec<f32> = (0..w * h).map(|p| if (p % w) / k == 2 || p % w == 24 { 0.0 } else { 1.0 }).collect();
        let everywhere = FitTarget::new(&photo, w, h, k);
        let (rad, _) = nnls_fit(&[ua.clone(), ub.clone()], &everywhere, &[0, 1]);
        assert!(rad[1][0] > 0.3, "fitted where the geometry is wrong, B lights the wrong block: {rad:?}");
        let agreement = Agreement { mask, min_share: 0.75 };
        let target = FitTarget::new(&photo, w, h, k).with_agreement(&agreement, w, h, k);
        assert_eq!(target.weights, [1.0, 1.0, 0.0, 1.0]);
        assert_eq!(target.disagrees, [false, false, true, false]);
        let (rad, err) = nnls_fit(&[ua.clone(), ub.clone()], &target, &[0, 1]);
        assert!(err < 1e-10 && (rad[0][0] - 0.5).abs() < 1e-5 && rad[1][0] < 1e-6, "{rad:?} {err}");
        // The same with that block clipped white: left out, it is no lower bound either.
        let clipped = FitTarget::new(&photo_with(1.0), w, h, k).with_agreement(&agreement, w, h, k);
        let (rad, err) = nnls_fit(&[ua, ub], &clipped, &[0, 1]);
        assert!(err < 1e-10 && (rad[0][0] - 0.5).abs() < 1e-5 && rad[1][0] < 1e-6, "{rad:?} {err}");
        // A mask of another size changes nothing.
        let other = Agreement { mask: vec![0.0; 7], min_share: 0.75 };
        assert_eq!(FitTarget::new(&photo, w, h, k).with_agreement(&other, w, h, k).weights, [1.0; 4]);
    }
}
