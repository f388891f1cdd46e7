//! Relative depth to metres by its order alone. A depth network's output is a monotone function of distance
//! (nearer is always nearer) but not an affine one: fitting it with a shift and a scale bends the room's
//! planes. Given metric depth for some pixels (the room box of `layout_room` where the photo shows it),
//! the monotone map from the network's values to metres is fitted by isotonic regression (pool adjacent
//! violators over equal-count bins) and applied to every pixel, furniture included. Beyond the fitted range
//! the map continues as an affine one in the units' own space (depth for `relative`, inverse depth for
//! `disparity`) through its end bins.

use super::DepthUnits;

/// The fitted map: knots in increasing "farness" (the value for relative depth, minus it for disparity).
#[derive(Clone, Debug)]
pub struct MonotoneDepth {
    units: DepthUnits,
    keys: Vec<f32>,
    metres: Vec<f32>,
    /// Spearman's rank correlation of the values with the target depth on the fitted pixels (1: same order).
    pub rank_correlation: f32,
    /// Median |map(v) - target| / target on the fitted pixels.
    pub median_relative_error: f32,
}

fn farness(units: DepthUnits, v: f32) -> f32 {
    if units == DepthUnits::Disparity {
        -v
    } else {
        v
    }
}

/// Spearman's rank correlation of two equally long samples.
fn rank_correlation(a: &[f32], b: &[f32]) -> f32 {
    let ranks = |v: &[f32]| {
        let mut idx: Vec<usize> = (0..v.len()).collect();
        idx.sort_by(|&i, &j| v[i].total_cmp(&v[j]));
        let mut r = vec![0.0f64; v.len()];
        for (rank, &i) in idx.iter().enumerate() {
            r[i] = rank as f64;
        }
        r
    };
    let (ra, rb) = (ranks(a), ranks(b));
    let n = a.len() as f64;
    let mean = (n - 1.0) / 2.0;
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in ra.iter().zip(&rb) {
        ab += (x - mean) * (y - mean);
        aa += (x - mean).powi(2);
        bb += (y - mean).powi(2);
    }
    (ab / (aa * bb).sqrt().max(1e-30)) as f32
}

/// Fits the map from `values` (relative depth in `units`, 0 = none) to `target` (metres, 0 = not known) on
/// the pixels that have both. None with fewer than 100 such pixels.
pub fn fit_monotone_depth(values: &[f32], target: &[f32], units: DepthUnits) -> Option<MonotoneDepth> {
    let mut pairs: Vec<(f32, f32)> = values
        .iter()
        .zip(target)
        .filter(|(v, t)| **v > 0.0 && v.is_finite() && **t > 0.0 && t.is_finite())
        .map(|(&v, &t)| (farness(units, v), t))
        .collect();
    if pairs.len() < 100 {
        return None;
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let bins = (pairs.len() / 50).clamp(2, 256);
    // Equal-count bins: mean key and mean metres, weight the count.
    let mut blocks: Vec<(f64, f64, f64)> = (0..bins)
        .map(|b| {
            let chunk = &pairs[b * pairs.len() / bins..(b + 1) * pairs.len() / bins];
            let n = chunk.len() as f64;
            let k = chunk.iter().map(|p| p.0 as f64).sum::<f64>() / n;
            let m = chunk.iter().map(|p| p.1 as f64).sum::<f64>() / n;
            (k, m, n)
        })
        .collect();
    // Pool adjacent violators: merge neighbouring blocks until the metres do not decrease.
    let mut pooled: Vec<(f64, f64, f64)> = Vec::with_capacity(blocks.len());
    for b in blocks.drain(..) {
        pooled.push(b);
        while pooled.len() > 1 && pooled[pooled.len() - 2].1 > pooled[pooled.len() - 1].1 {
            let (k2, m2, n2) = pooled.pop().unwrap_or_default();
            if let Some(last) = pooled.last_mut() {
                let n = last.2 + n2;
                *last = ((last.0 * last.2 + k2 * n2) / n, (last.1 * last.2 + m2 * n2) / n, n);
            }
        }
    }
    let keys: Vec<f32> = pooled.iter().map(|b| b.0 as f32).collect();
    let metres: Vec<f32> = pooled.iter().map(|b| b.1 as f32).collect();
    let sample: Vec<(f32, f32)> = pairs.iter().step_by((pairs.len() / 20000).max(1)).copied().collect();
    let (a, b): (Vec<f32>, Vec<f32>) = sample.iter().copied().unzip();
    let mut map =
        MonotoneDepth { units, keys, metres, rank_correlation: rank_correlation(&a, &b), median_relative_error: 0.0 };
    let mut errs: Vec<f32> = sample.iter().map(|&(k, t)| (map.at_key(k) - t).abs() / t).collect();
    errs.sort_by(f32::total_cmp);
    map.median_relative_error = errs[errs.len() / 2];
    Some(map)
}

impl MonotoneDepth {
    /// Metres for a relative value (0 for none).
    pub fn apply(&self, v: f32) -> f32 {
        if !(v > 0.0 && v.is_finite()) {
            return 0.0;
        }
        self.at_key(farness(self.units, v))
    }

    fn at_key(&self, k: f32) -> f32 {
        let n = self.keys.len();
        if n == 1 {
            return self.metres[0];
        }
        let i = self.keys.partition_point(|&x| x < k);
        if i > 0 && i < n {
            let (k0, k1, m0, m1) = (self.keys[i - 1], self.keys[i], self.metres[i - 1], self.metres[i]);
            let t = if k1 > k0 { (k - k0) / (k1 - k0) } else { 0.5 };
            return m0 + t * (m1 - m0);
        }
        // Beyond the ends: affine through the end knots in the units' own space, never past nearer/farther.
        let (a, b) = if i == 0 { (0, 1.min(n - 1)) } else { (n - 2, n - 1) };
        let end = if i == 0 { self.metres[0] } else { self.metres[n - 1] };
        let space = |m: f32| if self.units == DepthUnits::Disparity { 1.0 / m } else { m };
        let (s0, s1) = (space(self.metres[a]), space(self.metres[b]));
        let slope = if self.keys[b] > self.keys[a] { (s1 - s0) / (self.keys[b] - self.keys[a]) } else { 0.0 };
        let anchor = if i == 0 { (self.keys[0], space(self.metres[0])) } else { (self.keys[n - 1], space(end)) };
        let s = anchor.1 + slope * (k - anchor.0);
        let m = if self.units == DepthUnits::Disparity {
            if s > 0.0 {
                1.0 / s
            } else {
                f32::INFINITY
            }
        } else {
            s
        };
        // Monotone and positive: nearer values never farther than the near end, and the other way round.
        if i == 0 {
            m.clamp(0.05 * end, end)
        } else {
            m.clamp(end, 20.0 * end)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_monotone_distortion_is_undone_and_the_order_kept() {
        // Disparity through a power (a network's compression of the far range) against true depth 1-8 m.
        let z: Vec<f32> = (0..5000).map(|i| 1.0 + 7.0 * i as f32 / 4999.0).collect();
        let v: Vec<f32> = z.iter().map(|z| (1.0 / z).powf(0.6) * 3.0 + 0.2).collect();
        let map = fit_monotone_depth(&v, &z, DepthUnits::Disparity).unwrap();
        assert!(map.rank_correlation > 0.999, "{}", map.rank_correlation);
        assert!(map.median_relative_error < 0.01, "{}", map.median_relative_error);
        for (&vi, &zi) in v.iter().zip(&z).step_by(97) {
            assert!((map.apply(vi) - zi).abs() < 0.03 * zi, "{} for {zi}", map.apply(vi));
        }
        // Beyond the range: nearer values stay nearer, farther ones farther, all finite and positive.
        let near = map.apply(v[0] * 1.2);
        let far = map.apply(v[4999] * 0.9);
        assert!(near > 0.0 && near < 1.0 && far > 8.0 && far.is_finite(), "{near} {far}");
        assert_eq!(map.apply(0.0), 0.0);
    }

    #[test]
    fn a_shuffled_depth_scores_no_rank_correlation() {
        let z: Vec<f32> = (0..2000).map(|i| 1.0 + i as f32 / 500.0).collect();
        let v: Vec<f32> = (0..2000).map(|i| 1.0 + ((i * 7919) % 2000) as f32).collect();
        let map = fit_monotone_depth(&v, &z, DepthUnits::Relative).unwrap();
        assert!(map.rank_correlation.abs() < 0.1, "{}", map.rank_correlation);
        assert!(fit_monotone_depth(&v[..50], &z[..50], DepthUnits::Relative).is_none());
    }
}
