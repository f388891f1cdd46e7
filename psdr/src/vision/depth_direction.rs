//! Whether a depth map runs the way its units say. On a floor seen from above, distance grows from the bottom
//! of the image towards the horizon (for a plane, 1/z is affine in the pixel's position), so the floor's depth,
//! read in the given units, must rise with the pixel's height in the image. A map of distances given as
//! `disparity`, or a network's disparity given as `metres` or `relative`, falls instead: every later step
//! would fit a room turned inside out, so it is stopped with the flag that fixes it.

use super::depth::DepthUnits;

/// At most this many floor pixels enter the rank correlation (an even stride over the floor).
const MAX_SAMPLES: usize = 4000;
/// Fewer floor pixels with depth than this say nothing.
const MIN_SAMPLES: usize = 200;
/// A rank correlation below this is a map the other way round (a true floor is near +1, noise near 0).
pub const INVERTED_BELOW: f32 = -0.5;

/// Spearman's rank correlation between the floor pixels' height in the image (rows up from the bottom) and
/// their distance as `units` reads the map (disparity negated), or None with too few floor pixels with depth.
pub fn floor_depth_trend(depth: &[f32], units: DepthUnits, floor: &[bool], width: usize) -> Option<f32> {
    let pixels: Vec<usize> = (0..depth.len()).filter(|&p| floor[p] && depth[p] > 0.0 && depth[p].is_finite()).collect();
    if pixels.len() < MIN_SAMPLES || width == 0 {
        return None;
    }
    let stride = pixels.len().div_ceil(MAX_SAMPLES);
    let height = depth.len() / width;
    let (up, far): (Vec<f32>, Vec<f32>) = pixels
        .iter()
        .step_by(stride)
        .map(|&p| {
            let distance = if units == DepthUnits::Disparity { -depth[p] } else { depth[p] };
            ((height - 1 - p / width) as f32, distance)
        })
        .unzip();
    Some(pearson(&ranks(&up), &ranks(&far)))
}

/// Ranks (0-based, ties sharing their mean rank).
fn ranks(v: &[f32]) -> Vec<f32> {
    let mut order: Vec<usize> = (0..v.len()).collect();
    order.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut out = vec![0.0; v.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        while j + 1 < order.len() && v[order[j + 1]] == v[order[i]] {
            j += 1;
        }
        for &k in &order[i..=j] {
            out[k] = (i + j) as f32 / 2.0;
        }
        i = j + 1;
    }
    out
}

fn pearson(a: &[f32], b: &[f32]) -> f32 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().map(|&x| x as f64).sum::<f64>() / n, b.iter().map(|&x| x as f64).sum::<f64>() / n);
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (&x, &y) in a.iter().zip(b) {
        let (x, y) = (x as f64 - ma, y as f64 - mb);
        (ab, aa, bb) = (ab + x * y, aa + x * x, bb + y * y);
    }
    if aa <= 0.0 || bb <= 0.0 {
        return 0.0;
    }
    (ab / (aa * bb).sqrt()) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_floor_reads_forwards_in_its_units_and_backwards_in_the_others() {
        // A floor over the bottom half of a 20 x 40 image, 1/z affine in the row (z from 1 m to 5 m).
        let (w, h) = (20, 40);
        let floor: Vec<bool> = (0..w * h).map(|p| p / w >= h / 2).collect();
        let z: Vec<f32> = (0..w * h)
            .map(|p| if floor[p] { 1.0 / (0.2 + 0.8 * ((p / w) - h / 2) as f32 / (h / 2 - 1) as f32) } else { 0.0 })
            .collect();
        assert!((floor_depth_trend(&z, DepthUnits::Metres, &floor, w).unwrap() - 1.0).abs() < 1e-5);
        assert!((floor_depth_trend(&z, DepthUnits::Disparity, &floor, w).unwrap() + 1.0).abs() < 1e-5);
        let disparity: Vec<f32> = z.iter().map(|&v| if v > 0.0 { 1.0 / v } else { 0.0 }).collect();
        assert!((floor_depth_trend(&disparity, DepthUnits::Disparity, &floor, w).unwrap() - 1.0).abs() < 1e-5);
        assert!(floor_depth_trend(&disparity, DepthUnits::Relative, &floor, w).unwrap() < INVERTED_BELOW);
        // Too few floor pixels: no verdict.
        let few: Vec<bool> = (0..w * h).map(|p| p >= w * h - 10).collect();
        assert_eq!(floor_depth_trend(&z, DepthUnits::Metres, &few, w), None);
    }
}
