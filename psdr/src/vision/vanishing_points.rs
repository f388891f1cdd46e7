//! Field of view from vanishing points, when nothing else gives it. Line segments of a room run along three
//! orthogonal (Manhattan) directions; each direction's segments meet in a vanishing point. Two orthogonal
//! directions with finite vanishing points v1, v2 (relative to the principal point, assumed at the image
//! centre, square pixels) fix the focal length: f² = −v1·v2. Vanishing points are found by sequential RANSAC over
//! segment pairs and refined by least squares; the focal length's uncertainty comes from a bootstrap over each
//! direction's segments. The failure modes are reported, not guessed: too few lines for two directions, or a
//! frontal view whose vanishing points lie at infinity (lines parallel to the image plane carry no focal length).

use super::line_segments::{detect_segments, Segment, SegmentOptions};
use crate::base::symmetric_eigen;
use crate::base::Image;
use glam::{DMat3, DVec3};

/// A vanishing point and the segments that meet in it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct VanishingPoint {
    /// Homogeneous, in image-height units about the image centre (x right, y up): (x, y, w).
    pub point: [f64; 3],
    pub segments: usize,
    /// Their summed length in pixels.
    pub length: f32,
}

/// The estimate and what it rests on.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FovEstimate {
    pub fov_y_deg: f32,
    /// One standard deviation (bootstrap over the segments), degrees.
    pub sigma_deg: f32,
    pub segments: usize,
    pub vanishing_points: Vec<VanishingPoint>,
}

/// Why no estimate could be made, with what was found.
#[derive(Clone, Debug, PartialEq)]
pub struct FovFailure {
    pub reason: String,
    pub segments: usize,
    pub vanishing_points: usize,
}

impl std::fmt::Display for FovFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({} line segments, {} vanishing directions)", self.reason, self.segments, self.vanishing_points)
    }
}

/// Knobs of the estimator.
#[derive(Clone, Copy, Debug)]
pub struct VanishingOptions {
    pub segments: SegmentOptions,
    /// A segment belongs to a vanishing point when its endpoints are within this many pixels of the line from
    /// its midpoint to the point.
    pub inlier_px: f32,
    /// Segments a direction needs to count.
    pub min_segments: usize,
    pub ransac_iters: usize,
    pub bootstrap: usize,
    /// An estimate whose bootstrap standard deviation exceeds this (degrees) is reported as a failure.
    pub max_sigma_deg: f32,
    pub seed: u64,
}

impl Default for VanishingOptions {
    fn default() -> Self {
        VanishingOptions {
            segments: SegmentOptions::default(),
            inlier_px: 1.5,
            min_segments: 4,
            ransac_iters: 1500,
            bootstrap: 64,
            max_sigma_deg: 1.0,
            seed: 1,
        }
    }
}

/// A segment in image-height units about the centre (y up): its line (a² + b² = 1), midpoint and half length.
struct Line {
    l: DVec3,
    mid: DVec3,
    a: DVec3,
    len: f64,
}

fn to_lines(segs: &[Segment], w: usize, h: usize) -> Vec<Line> {
    let (cx, cy, s) = (w as f64 / 2.0, h as f64 / 2.0, h as f64);
    let norm = |p: [f32; 2]| DVec3::new((p[0] as f64 - cx) / s, (cy - p[1] as f64) / s, 1.0);
    segs.iter()
        .filter_map(|g| {
            let (a, b) = (norm(g.a), norm(g.b));
            let l = a.cross(b);
            let n = (l.x * l.x + l.y * l.y).sqrt();
            (n > 0.0).then(|| Line { l: l / n, mid: 0.5 * (a + b), a, len: g.length() as f64 })
        })
        .collect()
}

/// Distance (image-height units) of a segment's endpoint from the line through its midpoint and `v`.
fn misfit(line: &Line, v: DVec3) -> f64 {
    let l = line.mid.cross(v);
    let n = (l.x * l.x + l.y * l.y).sqrt();
    if n < 1e-12 {
        return 0.0; // the point is the midpoint itself
    }
    (l.dot(line.a) / n).abs()
}

/// The point nearest (weighted least squares) to the lines: the smallest eigenvector of Σ len · l lᵀ.
fn fit_point(lines: &[&Line]) -> DVec3 {
    let mut m = DMat3::ZERO;
    for ln in lines {
        m += DMat3::from_cols(ln.l * ln.l.x, ln.l * ln.l.y, ln.l * ln.l.z) * ln.len;
    }
    let (vals, vecs) = symmetric_eigen(m);
    let i = (0..3).min_by(|&a, &b| vals[a].total_cmp(&vals[b])).unwrap_or(0);
    vecs.col(i)
}

struct Rng(u64);
impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 33) % n.max(1) as u64) as usize
    }
}

/// The vertical fov (degrees) for focal length from two vanishing points, if they give one.
fn fov_from_pair(a: DVec3, b: DVec3) -> Option<f64> {
    if a.z.abs() < 1e-6 * a.length() || b.z.abs() < 1e-6 * b.length() {
        return None;
    }
    let (pa, pb) = (a / a.z, b / b.z);
    let f2 = -(pa.x * pb.x + pa.y * pb.y);
    // f in image heights; fov_y = 2 atan(0.5 / f).
    let fov = (2.0 * (0.5 / f2.sqrt()).atan()).to_degrees();
    (f2 > 0.0 && (10.0..150.0).contains(&fov)).then_some(fov)
}

/// Direction clusters by sequential RANSAC over segment pairs (sampled in proportion to length: long segments
/// carry the directions), each refined by least squares: up to four, a non-Manhattan one (shadow edges, a
/// rotated piece of furniture) may come first.
fn direction_clusters(lines: &[Line], tol: f64, opts: &VanishingOptions, rng: &mut Rng) -> Vec<(DVec3, Vec<usize>)> {
    let total: f64 = lines.iter().map(|l| l.len).sum();
    let mut free: Vec<bool> = vec![true; lines.len()];
    let mut clusters: Vec<(DVec3, Vec<usize>)> = vec![];
    while clusters.len() < 4 {
        let pick = |rng: &mut Rng| {
            let mut t = rng.below(1 << 20) as f64 / (1 << 20) as f64 * total;
            for (i, l) in lines.iter().enumerate() {
                t -= l.len;
                if t <= 0.0 {
                    return i;
                }
            }
            lines.len() - 1
        };
        let inliers = |v: DVec3, free: &[bool]| -> Vec<usize> {
            (0..lines.len()).filter(|&i| free[i] && misfit(&lines[i], v) < tol).collect()
        };
        let mut best: Option<(f64, DVec3)> = None;
        for _ in 0..opts.ransac_iters {
            if lines.len() < 2 {
                break;
            }
            let (i, j) = (pick(rng), pick(rng));
            if i == j || !free[i] || !free[j] {
                continue;
            }
            let v = lines[i].l.cross(lines[j].l);
            if v.length() < 1e-9 {
                continue;
            }
            let score: f64 = inliers(v, &free).iter().map(|&k| lines[k].len).sum();
            if best.is_none_or(|b| score > b.0) {
                best = Some((score, v.normalize()));
            }
        }
        let Some((_, mut v)) = best else { break };
        let mut members = inliers(v, &free);
        for _ in 0..3 {
            if members.len() < 2 {
                break;
            }
            v = fit_point(&members.iter().map(|&k| &lines[k]).collect::<Vec<_>>());
            members = inliers(v, &free);
        }
        if members.len() < opts.min_segments {
            break;
        }
        for &k in &members {
            free[k] = false;
        }
        clusters.push((v, members));
    }
    clusters
}

/// The room's three Manhattan directions in camera coordinates (x right, y up, z forward) from the photo's
/// lines at a known field of view, with the segments behind each.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ManhattanFrame {
    /// Unit directions, each up to sign; mutually orthogonal.
    pub axes: [[f32; 3]; 3],
    /// Segments assigned to each direction (a direction with fewer than `min_segments` follows from the
    /// other two by orthogonality).
    pub segments: [usize; 3],
}

/// The Manhattan frame of the photo's lines at vertical fov `fov_y_deg`: the joint rotation fit of
/// `estimate_fov` with the focal length held. Needs two directions with `min_segments` each.
pub fn estimate_frame(photo: &Image, fov_y_deg: f32, opts: &VanishingOptions) -> Result<ManhattanFrame, FovFailure> {
    let segs = detect_segments(photo, &opts.segments);
    let lines = to_lines(&segs, photo.width, photo.height);
    let tol = opts.inlier_px as f64 / photo.height as f64;
    let mut rng = Rng(opts.seed ^ 0x9E37_79B9_7F4A_7C15);
    let clusters = direction_clusters(&lines, tol, opts, &mut rng);
    let fail = |reason: &str, found: usize| FovFailure {
        reason: reason.to_string(),
        segments: segs.len(),
        vanishing_points: found,
    };
    if clusters.len() < 2 {
        return Err(fail("too few lines: fewer than two directions with enough segments", clusters.len()));
    }
    let f = 0.5 / (0.5 * (fov_y_deg as f64).to_radians()).tan();
    let mut best: Option<ManhattanFit> = None;
    for a in 0..clusters.len() {
        for b in a + 1..clusters.len() {
            let fit = manhattan_fit(&lines, &clusters, (a, b), f, tol, true);
            if best.as_ref().is_none_or(|x| fit.support > x.support) {
                best = Some(fit);
            }
        }
    }
    let fit = best.ok_or_else(|| fail("no fit", clusters.len()))?;
    let count = |k: usize| fit.assignment.iter().filter(|a| **a == Some(k)).count();
    let segments = [count(0), count(1), count(2)];
    if segments.iter().filter(|&&n| n >= opts.min_segments).count() < 2 {
        return Err(fail("too few lines: the fitted frame has fewer than two directions with enough segments", 1));
    }
    let col = |k: usize| {
        let c = fit.r.col(k);
        [c.x as f32, c.y as f32, c.z as f32]
    };
    Ok(ManhattanFrame { axes: [col(0), col(1), col(2)], segments })
}

/// Estimates the vertical field of view from the photo's vanishing points.
pub fn estimate_fov(photo: &Image, opts: &VanishingOptions) -> Result<FovEstimate, FovFailure> {
    let segs = detect_segments(photo, &opts.segments);
    let lines = to_lines(&segs, photo.width, photo.height);
    let tol = opts.inlier_px as f64 / photo.height as f64;
    let mut rng = Rng(opts.seed ^ 0x9E37_79B9_7F4A_7C15);
    let clusters = direction_clusters(&lines, tol, opts, &mut rng);
    let fail = |reason: &str| FovFailure {
        reason: reason.to_string(),
        segments: segs.len(),
        vanishing_points: clusters.len(),
    };
    if clusters.len() < 2 {
        return Err(fail("too few lines: fewer than two directions with enough segments to meet in a point"));
    }
    // Starts: the focal length of each pair of directions that gives one, and a sweep of fovs.
    let mut starts: Vec<f64> = (0..7).map(|i| 35.0 + 10.0 * i as f64).collect();
    for a in 0..clusters.len() {
        for b in a + 1..clusters.len() {
            starts.extend(fov_from_pair(clusters[a].0, clusters[b].0));
        }
    }
    let f_of = |fov: f64| 0.5 / (0.5 * fov.to_radians()).tan();
    let mut fits = vec![];
    for a in 0..clusters.len() {
        for b in a + 1..clusters.len() {
            for &fov in &starts {
                fits.push(manhattan_fit(&lines, &clusters, (a, b), f_of(fov), tol, false));
            }
        }
    }
    let Some(fit) = fits
        .into_iter()
        .filter(|fit| fit.f.is_finite())
        .max_by(|a, b| a.support.total_cmp(&b.support).then(b.cost.total_cmp(&a.cost)))
    else {
        return Err(fail("the joint fit of focal length and rotation did not converge"));
    };
    let sigma_fov = bootstrap_sigma(&lines, &fit, tol, opts.bootstrap, &mut rng);
    let fov = (2.0 * (0.5 / fit.f).atan()).to_degrees();
    let axes =
        (0..3).filter(|&k| fit.assignment.iter().filter(|a| **a == Some(k)).count() >= opts.min_segments).count();
    if axes < 2 {
        return Err(fail("too few lines: the fitted frame has fewer than two directions with enough segments"));
    }
    // A frontal view's lines fit any focal length; the fit then drifts to an extreme.
    if !(20.0..=120.0).contains(&fov) {
        return Err(fail(&format!(
            "uncertain: the fit ran to fov {fov:.1} degrees, outside 20-120; a frontal view (the vanishing points of \
             lines parallel to the image plane lie at infinity) does not fix the focal length"
        )));
    }
    if sigma_fov.is_nan() || sigma_fov > opts.max_sigma_deg as f64 {
        return Err(fail(&format!(
            "uncertain: fov {fov:.1} ± {sigma_fov:.1} degrees, above the {:.1} degree limit; a frontal view (the \
             vanishing points of lines parallel to the image plane lie at infinity) does not fix the focal length",
            opts.max_sigma_deg
        )));
    }
    let (f, assignment) = (fit.f, fit.assignment);
    let mut members: Vec<Vec<usize>> = vec![vec![]; 3];
    for (i, a) in assignment.iter().enumerate() {
        if let Some(k) = a {
            members[*k].push(i);
        }
    }
    let vanishing_points = (0..3)
        .filter(|&k| !members[k].is_empty())
        .map(|k| {
            let v = fit_point(&members[k].iter().map(|&i| &lines[i]).collect::<Vec<_>>());
            VanishingPoint {
                point: [v.x, v.y, v.z],
                segments: members[k].len(),
                length: members[k].iter().map(|&i| lines[i].len as f32).sum(),
            }
        })
        .collect();
    debug_assert!((fov - (2.0 * (0.5 / f).atan()).to_degrees()).abs() < 1e-9);
    Ok(FovEstimate { fov_y_deg: fov as f32, sigma_deg: sigma_fov as f32, segments: segs.len(), vanishing_points })
}

/// A rotation vector's matrix (Rodrigues).
fn rotation(w: DVec3) -> DMat3 {
    let t = w.length();
    if t < 1e-12 {
        return DMat3::IDENTITY;
    }
    DMat3::from_axis_angle(w / t, t)
}

/// The vanishing point of axis k of rotation r at focal length f (image heights), homogeneous.
fn axis_point(r: &DMat3, f: f64, k: usize) -> DVec3 {
    let c = r.col(k);
    DVec3::new(f * c.x, f * c.y, c.z)
}

/// Levenberg-Marquardt over (rotation vector applied on the left of r0, log f): each assigned segment's
/// endpoint distance from the line through its midpoint and its axis' vanishing point, in units of the inlier
/// tolerance, weighted by the square root of its length (times `weights`, a bootstrap's multiplicities).
/// Returns the rotation, f and the final cost.
fn refine(
    lines: &[Line],
    assignment: &[Option<usize>],
    weights: &[f64],
    r0: DMat3,
    f0: f64,
    tol: f64,
    fixed_f: bool,
) -> (DMat3, f64, f64) {
    let mean_len = lines.iter().map(|l| l.len).sum::<f64>() / lines.len().max(1) as f64;
    let residuals = |p: &[f64; 4]| -> Vec<f64> {
        let r = rotation(DVec3::new(p[0], p[1], p[2])) * r0;
        let f = p[3].exp();
        assignment
            .iter()
            .enumerate()
            .filter_map(|(i, a)| {
                a.map(|k| misfit(&lines[i], axis_point(&r, f, k)) / tol * (weights[i] * lines[i].len / mean_len).sqrt())
            })
            .collect()
    };
    let cost = |p: &[f64; 4]| residuals(p).iter().map(|r| r * r).sum::<f64>();
    let mut p = [0.0, 0.0, 0.0, f0.ln()];
    let mut lambda = 1e-3;
    let mut c = cost(&p);
    for _ in 0..30 {
        let r = residuals(&p);
        let mut jac = vec![[0.0f64; 4]; r.len()];
        for j in 0..4 {
            let (mut a, mut b) = (p, p);
            a[j] += 1e-6;
            b[j] -= 1e-6;
            let (ra, rb) = (residuals(&a), residuals(&b));
            for i in 0..r.len() {
                jac[i][j] = (ra[i] - rb[i]) / 2e-6;
            }
        }
        let mut g = [0.0f64; 4];
        let mut m = [[0.0f64; 4]; 4];
        for (i, row) in jac.iter().enumerate() {
            for a in 0..4 {
                g[a] += row[a] * r[i];
                for b in 0..4 {
                    m[a][b] += row[a] * row[b];
                }
            }
        }
        for (a, row) in m.iter_mut().enumerate() {
            row[a] *= 1.0 + lambda;
        }
        if fixed_f {
            // The focal length is known: its row and column pinned, its step zero.
            m[3] = [0.0, 0.0, 0.0, 1.0];
            (m[0][3], m[1][3], m[2][3], g[3]) = (0.0, 0.0, 0.0, 0.0);
        }
        let Some(step) = solve4(m, g) else { break };
        let trial = [p[0] - step[0], p[1] - step[1], p[2] - step[2], p[3] - step[3]];
        let ct = cost(&trial);
        if ct < c {
            let done = c - ct < 1e-10 * c.max(1e-30);
            (p, c, lambda) = (trial, ct, lambda * 0.3);
            if done {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e8 {
                break;
            }
        }
    }
    (rotation(DVec3::new(p[0], p[1], p[2])) * r0, p[3].exp(), c)
}

/// Joint fit of focal length (held at f0 when `fixed_f`) and camera rotation, started from clusters a and b as
/// two axes at f0: refined, then every segment reassigned to the axis it fits best (if any), three rounds.
fn manhattan_fit(
    lines: &[Line],
    clusters: &[(DVec3, Vec<usize>)],
    (a, b): (usize, usize),
    f0: f64,
    tol: f64,
    fixed_f: bool,
) -> ManhattanFit {
    let dir = |v: DVec3, f: f64| DVec3::new(v.x, v.y, v.z * f).normalize();
    let d0 = dir(clusters[a].0, f0);
    let d1 = dir(clusters[b].0, f0);
    let d1 = (d1 - d0 * d0.dot(d1)).normalize();
    let mut r = DMat3::from_cols(d0, d1, d0.cross(d1));
    let mut assignment: Vec<Option<usize>> = vec![None; lines.len()];
    for (k, c) in [a, b].into_iter().enumerate() {
        for &i in &clusters[c].1 {
            assignment[i] = Some(k);
        }
    }
    let ones = vec![1.0; lines.len()];
    let (mut f, mut cost) = (f0, f64::INFINITY);
    for _round in 0..3 {
        (r, f, cost) = refine(lines, &assignment, &ones, r, f, tol, fixed_f);
        for (i, a) in assignment.iter_mut().enumerate() {
            *a = (0..3)
                .map(|k| (k, misfit(&lines[i], axis_point(&r, f, k))))
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .filter(|(_, m)| *m < tol)
                .map(|(k, _)| k);
        }
    }
    let support = assignment.iter().zip(lines).filter(|(a, _)| a.is_some()).map(|(_, l)| l.len).sum();
    ManhattanFit { r, f, assignment, support, cost }
}

/// A joint fit's result.
struct ManhattanFit {
    r: DMat3,
    f: f64,
    assignment: Vec<Option<usize>>,
    /// Summed length of the segments it explains.
    support: f64,
    cost: f64,
}

/// The fov's standard deviation (degrees) by a bootstrap over the fit's segments.
fn bootstrap_sigma(lines: &[Line], fit: &ManhattanFit, tol: f64, draws: usize, rng: &mut Rng) -> f64 {
    let used: Vec<usize> = (0..lines.len()).filter(|&i| fit.assignment[i].is_some()).collect();
    if used.len() < 5 || draws < 2 {
        return f64::INFINITY;
    }
    let fov = |f: f64| (2.0 * (0.5 / f).atan()).to_degrees();
    let samples: Vec<f64> = (0..draws)
        .map(|_| {
            let mut weights = vec![0.0; lines.len()];
            for _ in 0..used.len() {
                weights[used[rng.below(used.len())]] += 1.0;
            }
            fov(refine(lines, &fit.assignment, &weights, fit.r, fit.f, tol, false).1)
        })
        .collect();
    let mean = samples.iter().sum::<f64>() / draws as f64;
    (samples.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (draws - 1) as f64).sqrt()
}

/// Solves a 4x4 system by Gaussian elimination with partial pivoting.
fn solve4(mut m: [[f64; 4]; 4], mut b: [f64; 4]) -> Option<[f64; 4]> {
    for c in 0..4 {
        let p = (c..4).max_by(|&x, &y| m[x][c].abs().total_cmp(&m[y][c].abs()))?;
        if m[p][c].abs() < 1e-300 {
            return None;
        }
        m.swap(c, p);
        b.swap(c, p);
        for r in c + 1..4 {
            let k = m[r][c] / m[c][c];
            let pivot = m[c];
            for (v, pv) in m[r].iter_mut().zip(pivot).skip(c) {
                *v -= k * pv;
            }
            b[r] -= k * b[c];
        }
    }
    let mut x = [0.0; 4];
    for c in (0..4).rev() {
        x[c] = (b[c] - (c + 1..4).map(|j| m[c][j] * x[j]).sum::<f64>()) / m[c][c];
    }
    Some(x)
}
