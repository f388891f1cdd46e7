//! Separable Gaussian blur with wrap-around. The Gaussian is multiplied by a
//! smooth window that reaches zero (with zero slope) at 3 sigma + 1 texels, so
//! the result is differentiable in sigma even as the tap count changes.

use crate::image::Image;
use crate::node_op::{BackwardCtx, NodeArgs, NodeOp};
use rayon::prelude::*;

/// float sigma (fraction of the tile width).
pub struct Blur;

/// Tap radius for sigma (texels): taps reach 3 sigma + 1.
fn radius(sigma: f64) -> usize {
    (3.0 * sigma.max(1e-3) + 1.0).ceil() as usize
}

/// Fills the normalised taps `k[j]`, j = 0..=2r, and their derivatives in sigma (texels).
fn kernel(sigma: f64, k: &mut [f64], dk: &mut [f64]) {
    let sigma = sigma.max(1e-3);
    let reach = 3.0 * sigma + 1.0;
    let r = (k.len() / 2) as f64;
    for j in 0..k.len() {
        let x = j as f64 - r;
        let t = x / reach;
        if t.abs() >= 1.0 {
            k[j] = 0.0;
            dk[j] = 0.0;
            continue;
        }
        let g = (-x * x / (2.0 * sigma * sigma)).exp();
        let dg = g * x * x / (sigma * sigma * sigma);
        let win = (1.0 - t * t) * (1.0 - t * t);
        let dwin = 12.0 * t * x * (1.0 - t * t) / (reach * reach);
        k[j] = g * win;
        dk[j] = dg * win + g * dwin;
    }
    let w: f64 = k.iter().sum();
    let dw: f64 = dk.iter().sum();
    for j in 0..k.len() {
        dk[j] = (dk[j] - k[j] * dw / w) / w;
        k[j] /= w;
    }
}

/// dst = src convolved with taps along x (horizontal) or y (vertical), wrapping.
fn convolve(src: &[f64], dst: &mut [f64], n: usize, c: usize, taps: &[f64], r: usize, vertical: bool) {
    dst.par_chunks_mut(n * c).enumerate().for_each(|(y, row)| {
        for x in 0..n {
            for ch in 0..c {
                let mut s = 0.0;
                for (j, &w) in taps.iter().enumerate() {
                    if w == 0.0 {
                        continue;
                    }
                    let o = j as i64 - r as i64;
                    let (sx, sy) = if vertical {
                        (x, (y as i64 + o).rem_euclid(n as i64) as usize)
                    } else {
                        ((x as i64 + o).rem_euclid(n as i64) as usize, y)
                    };
                    s += w * src[(sy * n + sx) * c + ch];
                }
                row[x * c + ch] = s;
            }
        }
    });
}

/// Per-row sums of g * (src convolved with dtaps), reduced in row order.
#[allow(clippy::too_many_arguments)]
fn dot_dconv(
    g: &[f64],
    src: &[f64],
    n: usize,
    c: usize,
    dtaps: &[f64],
    r: usize,
    vertical: bool,
    acc: &mut [f64],
) -> f64 {
    acc[..n].par_iter_mut().enumerate().for_each(|(y, a)| {
        let mut s = 0.0;
        for x in 0..n {
            for ch in 0..c {
                let gv = g[(y * n + x) * c + ch];
                if gv == 0.0 {
                    continue;
                }
                let mut v = 0.0;
                for (j, &w) in dtaps.iter().enumerate() {
                    let o = j as i64 - r as i64;
                    let (sx, sy) = if vertical {
                        (x, (y as i64 + o).rem_euclid(n as i64) as usize)
                    } else {
                        ((x as i64 + o).rem_euclid(n as i64) as usize, y)
                    };
                    v += w * src[(sy * n + sx) * c + ch];
                }
                s += gv * v;
            }
        }
        *a = s;
    });
    acc[..n].iter().sum()
}

/// Scratch layout [taps | dtaps | image | image]; the Vec grows once and is reused.
type Parts<'a> = (&'a mut [f64], &'a mut [f64], &'a mut [f64], &'a mut [f64]);
fn split(scratch: &mut Vec<f64>, taps: usize, len: usize) -> Parts<'_> {
    scratch.resize(2 * taps + 2 * len, 0.0);
    let (k, rest) = scratch.split_at_mut(taps);
    let (dk, rest) = rest.split_at_mut(taps);
    let (a, b) = rest.split_at_mut(len);
    (k, dk, a, b)
}

impl NodeOp for Blur {
    fn forward(&self, a: &NodeArgs, ins: &[Option<&Image>], out: &mut Image, scratch: &mut Vec<f64>) {
        let src = ins[0].expect("blur input");
        let (n, c) = (a.size, src.channels);
        let r = radius(a.f[0] * n as f64);
        let (k, dk, tmp, _) = split(scratch, 2 * r + 1, n * n * c);
        kernel(a.f[0] * n as f64, k, dk);
        convolve(&src.data, tmp, n, c, k, r, false);
        convolve(tmp, &mut out.data, n, c, k, r, true);
    }

    fn backward(&self, a: &NodeArgs, ins: &[Option<&Image>], _: &Image, d_out: &Image, cx: BackwardCtx) {
        let src = ins[0].expect("blur input");
        let (n, c) = (a.size, src.channels);
        let r = radius(a.f[0] * n as f64);
        let (k, dk, tmp, d_tmp) = split(cx.scratch, 2 * r + 1, n * n * c);
        kernel(a.f[0] * n as f64, k, dk);
        convolve(&src.data, tmp, n, c, k, r, false);
        // The windowed Gaussian is symmetric, so each pass is its own adjoint.
        convolve(&d_out.data, d_tmp, n, c, k, r, true);
        if cx.active[0] {
            let s = dot_dconv(&d_out.data, tmp, n, c, dk, r, true, cx.row_acc)
                + dot_dconv(d_tmp, &src.data, n, c, dk, r, false, cx.row_acc);
            cx.d_params[0] += s * n as f64;
        }
        if cx.need_in[0] {
            convolve(d_tmp, &mut cx.d_ins[0].data, n, c, k, r, false);
        }
    }
}
