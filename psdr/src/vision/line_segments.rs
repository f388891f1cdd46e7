//! Straight line segments in a photo, for vanishing points: pixels of strong gradient grouped into regions of
//! one orientation (region growing, as LSD does), each region's principal axis its segment. Regions that are not
//! long and thin are dropped.

use crate::base::Image;

/// A segment in pixel coordinates (x right, y down; pixel centres at +0.5), with the summed gradient
/// magnitude of its pixels as a strength.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub a: [f32; 2],
    pub b: [f32; 2],
    pub strength: f32,
}

impl Segment {
    pub fn length(&self) -> f32 {
        ((self.b[0] - self.a[0]).powi(2) + (self.b[1] - self.a[1]).powi(2)).sqrt()
    }
}

/// Knobs of the detector.
#[derive(Clone, Copy, Debug)]
pub struct SegmentOptions {
    /// Shortest segment kept, as a fraction of the image diagonal (and never under 8 pixels).
    pub min_length: f32,
    /// A pixel joins a region when its orientation is within this many degrees of the region's.
    pub angle_tolerance_deg: f32,
    /// Length over thickness below which a region is a blob, not a line.
    pub min_aspect: f32,
}

impl Default for SegmentOptions {
    fn default() -> Self {
        SegmentOptions { min_length: 0.03, angle_tolerance_deg: 22.5, min_aspect: 4.0 }
    }
}

/// sRGB-encoded luminance (edges in dark corners count as much as in bright ones), blurred by a 3x3 binomial.
fn grey(photo: &Image) -> Vec<f32> {
    let (w, h) = (photo.width, photo.height);
    let c = photo.channels;
    let lum: Vec<f32> = (0..w * h)
        .map(|p| {
            let v = if c >= 3 {
                0.2126 * photo.data[p * c] + 0.7152 * photo.data[p * c + 1] + 0.0722 * photo.data[p * c + 2]
            } else {
                photo.data[p * c]
            };
            crate::base::linear_to_srgb(v.clamp(0.0, 1.0))
        })
        .collect();
    let at = |x: isize, y: isize| lum[(y.clamp(0, h as isize - 1) as usize) * w + x.clamp(0, w as isize - 1) as usize];
    let mut out = vec![0.0; w * h];
    for y in 0..h as isize {
        for x in 0..w as isize {
            let mut s = 0.0;
            for (dy, wy) in [(-1, 1.0), (0, 2.0), (1, 1.0)] {
                for (dx, wx) in [(-1, 1.0), (0, 2.0), (1, 1.0)] {
                    s += wx * wy * at(x + dx, y + dy);
                }
            }
            out[y as usize * w + x as usize] = s / 16.0;
        }
    }
    out
}

/// Detects line segments, strongest first.
pub fn detect_segments(photo: &Image, opts: &SegmentOptions) -> Vec<Segment> {
    let (w, h) = (photo.width, photo.height);
    if w < 3 || h < 3 {
        return vec![];
    }
    let g = grey(photo);
    // Sobel gradient (per pixel, /8) and the orientation of the gradient modulo pi.
    let mut mag = vec![0.0f32; w * h];
    let mut ang = vec![0.0f32; w * h];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let p = |dx: isize, dy: isize| g[(y as isize + dy) as usize * w + (x as isize + dx) as usize];
            let gx = (p(1, -1) + 2.0 * p(1, 0) + p(1, 1) - p(-1, -1) - 2.0 * p(-1, 0) - p(-1, 1)) / 8.0;
            let gy = (p(-1, 1) + 2.0 * p(0, 1) + p(1, 1) - p(-1, -1) - 2.0 * p(0, -1) - p(1, -1)) / 8.0;
            mag[y * w + x] = (gx * gx + gy * gy).sqrt();
            ang[y * w + x] = gy.atan2(gx).rem_euclid(std::f32::consts::PI);
        }
    }
    // The threshold adapts to the image's noise: three times the median gradient, at least 0.02 per pixel.
    let mut sorted: Vec<f32> = mag.iter().copied().filter(|m| *m > 0.0).collect();
    sorted.sort_by(f32::total_cmp);
    let noise = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    let threshold = (3.0 * noise).max(0.02);
    let mut order: Vec<usize> = (0..w * h).filter(|&p| mag[p] > threshold).collect();
    order.sort_by(|&a, &b| mag[b].total_cmp(&mag[a]).then(a.cmp(&b)));
    let tol = opts.angle_tolerance_deg.to_radians();
    let min_len = (opts.min_length * ((w * w + h * h) as f32).sqrt()).max(8.0);
    let mut used = vec![false; w * h];
    let mut segments = vec![];
    let mut region = vec![];
    for &seed in &order {
        if used[seed] {
            continue;
        }
        // Grow: 8-neighbours above the threshold whose orientation (mod pi) is near the region's mean.
        region.clear();
        region.push(seed);
        used[seed] = true;
        let (mut s2, mut c2) = ((2.0 * ang[seed]).sin(), (2.0 * ang[seed]).cos());
        let mut k = 0;
        while k < region.len() {
            let p = region[k];
            k += 1;
            let (px, py) = ((p % w) as isize, (p / w) as isize);
            let mean = 0.5 * s2.atan2(c2);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (x, y) = (px + dx, py + dy);
                    if x < 0 || y < 0 || x >= w as isize || y >= h as isize {
                        continue;
                    }
                    let q = y as usize * w + x as usize;
                    if used[q] || mag[q] <= threshold {
                        continue;
                    }
                    let d = (ang[q] - mean).rem_euclid(std::f32::consts::PI);
                    if d.min(std::f32::consts::PI - d) < tol {
                        used[q] = true;
                        region.push(q);
                        s2 += (2.0 * ang[q]).sin();
                        c2 += (2.0 * ang[q]).cos();
                    }
                }
            }
        }
        if (region.len() as f32) < min_len {
            continue;
        }
        if let Some(s) = region_segment(&region, &mag, w, min_len, opts.min_aspect) {
            segments.push(s);
        }
    }
    segments
}

/// A region's segment: its principal axis (weighted by gradient magnitude), from the extreme projections.
fn region_segment(region: &[usize], mag: &[f32], w: usize, min_len: f32, min_aspect: f32) -> Option<Segment> {
    let (mut sw, mut mx, mut my) = (0.0f64, 0.0f64, 0.0f64);
    for &p in region {
        let m = mag[p] as f64;
        sw += m;
        mx += m * ((p % w) as f64 + 0.5);
        my += m * ((p / w) as f64 + 0.5);
    }
    let (mx, my) = (mx / sw, my / sw);
    let (mut sxx, mut sxy, mut syy) = (0.0f64, 0.0f64, 0.0f64);
    for &p in region {
        let m = mag[p] as f64;
        let (dx, dy) = ((p % w) as f64 + 0.5 - mx, (p / w) as f64 + 0.5 - my);
        sxx += m * dx * dx;
        sxy += m * dx * dy;
        syy += m * dy * dy;
    }
    // Closed-form eigen-decomposition of the 2x2 covariance: major axis angle and both spreads.
    let (a, b, c) = (sxx / sw, sxy / sw, syy / sw);
    let r = (0.25 * (a - c).powi(2) + b * b).sqrt();
    let minor = 0.5 * (a + c) - r;
    let theta = 0.5 * (2.0 * b).atan2(a - c);
    let e = (theta.cos(), theta.sin());
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    for &p in region {
        let t = ((p % w) as f64 + 0.5 - mx) * e.0 + ((p / w) as f64 + 0.5 - my) * e.1;
        lo = lo.min(t);
        hi = hi.max(t);
    }
    let length = hi - lo;
    let thickness = (12.0 * minor.max(0.0)).sqrt().max(1.0);
    if length < min_len as f64 || length / thickness < min_aspect as f64 {
        return None;
    }
    Some(Segment {
        a: [(mx + lo * e.0) as f32, (my + lo * e.1) as f32],
        b: [(mx + hi * e.0) as f32, (my + hi * e.1) as f32],
        strength: sw as f32,
    })
}
