//! Resampling: box downsampling, Gaussian blur and pyramid, crops.

use crate::base::Image;
use crate::error::{Error, Result};
use crate::loss::tape::{record, Kind, Tensor};
use rayon::prelude::*;

/// k x k box average; the output is ceil(W/k) x ceil(H/k), border blocks average the pixels they have.
pub fn downsample(a: &Tensor, k: usize) -> Result<Tensor> {
    if k == 0 {
        return Err(Error::Invalid("downsample: factor 0".into()));
    }
    let v = a.value();
    let (w, h, c) = (v.width, v.height, v.channels);
    let (ow, oh) = (w.div_ceil(k), h.div_ceil(k));
    let count = move |ox: usize, oy: usize| ((w.min(ox * k + k) - ox * k) * (h.min(oy * k + k) - oy * k)) as f32;
    let mut out = vec![0.0f32; ow * oh * c];
    for y in 0..h {
        for x in 0..w {
            for ch in 0..c {
                out[((y / k) * ow + x / k) * c + ch] += v.data[(y * w + x) * c + ch];
            }
        }
    }
    for oy in 0..oh {
        for ox in 0..ow {
            let n = count(ox, oy);
            out[(oy * ow + ox) * c..(oy * ow + ox + 1) * c].iter_mut().for_each(|o| *o /= n);
        }
    }
    let value = Image { width: ow, height: oh, channels: c, data: out };
    record(
        "downsample",
        &[a],
        value,
        Kind::Other,
        Box::new(move |g, ops, _| {
            let mut gi = vec![0.0f32; ops[0].data.len()];
            for y in 0..h {
                for x in 0..w {
                    let (ox, oy) = (x / k, y / k);
                    let n = count(ox, oy);
                    for ch in 0..c {
                        gi[(y * w + x) * c + ch] = g.data[(oy * ow + ox) * c + ch] / n;
                    }
                }
            }
            vec![Some(ops[0].like(gi))]
        }),
    )
}

/// Gaussian weights for offsets −r..=r, r = ceil(3σ).
fn kernel(sigma: f32) -> Vec<f32> {
    let r = (3.0 * sigma).ceil() as i64;
    (-r..=r).map(|j| (-(j as f32).powi(2) / (2.0 * sigma * sigma)).exp()).collect()
}

/// One pass of the normalised separable blur along x (`horizontal`) or y, or its transpose. Row `r` of the
/// operator is w_j / N_r over the in-image offsets j, so the transpose first divides by N then scatters.
fn pass(v: &[f32], w: usize, h: usize, c: usize, kern: &[f32], horizontal: bool, transpose: bool) -> Vec<f32> {
    let r = (kern.len() / 2) as i64;
    let (len, lines) = if horizontal { (w, h) } else { (h, w) };
    let at = move |line: usize, i: usize| if horizontal { line * w + i } else { i * w + line };
    let norm = |i: usize| -> f32 {
        let lo = (i as i64 - r).max(0);
        let hi = (i as i64 + r).min(len as i64 - 1);
        (lo..=hi).map(|j| kern[(j - i as i64 + r) as usize]).sum()
    };
    let norms: Vec<f32> = (0..len).map(norm).collect();
    let mut out = vec![0.0f32; v.len()];
    let results: Vec<Vec<f32>> = (0..lines)
        .into_par_iter()
        .map(|line| {
            let mut res = vec![0.0f32; len * c];
            for i in 0..len {
                let lo = (i as i64 - r).max(0) as usize;
                let hi = (i as i64 + r).min(len as i64 - 1) as usize;
                for j in lo..=hi {
                    let wgt = kern[(j as i64 - i as i64 + r) as usize];
                    // Forward: out_i = Σ_j w_{j−i} v_j / N_i. Transpose: out_i = Σ_j w_{i−j} v_j / N_j.
                    let f = if transpose { wgt / norms[j] } else { wgt / norms[i] };
                    for ch in 0..c {
                        res[i * c + ch] += f * v[at(line, j) * c + ch];
                    }
                }
            }
            res
        })
        .collect();
    for (line, res) in results.into_iter().enumerate() {
        for i in 0..len {
            out[at(line, i) * c..at(line, i) * c + c].copy_from_slice(&res[i * c..i * c + c]);
        }
    }
    out
}

/// Separable Gaussian blur of standard deviation `sigma` pixels, radius ceil(3σ), weights renormalised inside
/// the image at its borders (a constant image stays constant). Cost O(W·H·C·σ).
pub fn blur(a: &Tensor, sigma: f32) -> Result<Tensor> {
    if !(sigma > 0.0 && sigma.is_finite()) {
        return Err(Error::Invalid(format!("blur: sigma {sigma} must be positive")));
    }
    let v = a.value();
    let (w, h, c) = (v.width, v.height, v.channels);
    let kern = kernel(sigma);
    let x = pass(&v.data, w, h, c, &kern, true, false);
    let y = pass(&x, w, h, c, &kern, false, false);
    record(
        "blur",
        &[a],
        v.like(y),
        Kind::Other,
        Box::new(move |g, ops, _| {
            let gy = pass(&g.data, w, h, c, &kern, false, true);
            vec![Some(ops[0].like(pass(&gy, w, h, c, &kern, true, true)))]
        }),
    )
}

/// Level 0 is the image; each next level is the previous one blurred (σ = 1) and halved.
pub fn gaussian_pyramid(a: &Tensor, levels: usize) -> Result<Vec<Tensor>> {
    if levels == 0 {
        return Err(Error::Invalid("gaussian_pyramid: levels must be at least 1".into()));
    }
    let mut out = vec![a.clone()];
    for _ in 1..levels {
        let prev = out.last().expect("level 0");
        out.push(downsample(&blur(prev, 1.0)?, 2)?);
    }
    Ok(out)
}

/// The rectangle (x, y, w, h); it must lie inside the image and not be empty.
pub fn crop(a: &Tensor, x: usize, y: usize, w: usize, h: usize) -> Result<Tensor> {
    let v = a.value();
    if w == 0 || h == 0 || x + w > v.width || y + h > v.height {
        return Err(Error::Invalid(format!(
            "crop: rectangle ({x}, {y}, {w}x{h}) is empty or leaves the {} image",
            v.shape()
        )));
    }
    let (iw, c) = (v.width, v.channels);
    let mut data = Vec::with_capacity(w * h * c);
    for row in y..y + h {
        data.extend_from_slice(&v.data[(row * iw + x) * c..(row * iw + x + w) * c]);
    }
    record(
        "crop",
        &[a],
        Image { width: w, height: h, channels: c, data },
        Kind::Other,
        Box::new(move |g, ops, _| {
            let mut gi = vec![0.0f32; ops[0].data.len()];
            for row in 0..h {
                gi[((y + row) * iw + x) * c..((y + row) * iw + x + w) * c]
                    .copy_from_slice(&g.data[row * w * c..(row + 1) * w * c]);
            }
            vec![Some(ops[0].like(gi))]
        }),
    )
}
