//! A weight-free texture descriptor: Gram matrices of a fixed bank of random convolution filters with ReLU, at
//! three scales (Ustyuzhaninov et al., "What does it take to generate natural textures?", ICLR 2017, show such
//! random single-layer banks capture texture statistics well enough to synthesise textures; no VGG weights
//! exist here). Gram matrices are averaged over positions, so the descriptor's size does not depend on the
//! crop's and crops of different sizes compare.

use super::pointwise::{div, sqr};
use super::reduce::{l2, mean};
use crate::base::Image;
use crate::error::{Error, Result};
use crate::loss::tape::{record, Kind, Tensor};
use rayon::prelude::*;

/// Filters per scale, filter size, and the box-downsampling factor of each scale.
const FILTERS: usize = 16;
const SIZE: usize = 5;
const SCALES: [usize; 3] = [1, 2, 4];
/// The bank's seed: fixed, so descriptors are comparable across runs and machines.
const SEED: u64 = 0x7e57_u64 << 32 | 0x0de5;

/// Smallest crop side: the coarsest scale must leave 2 filter positions per axis.
pub const MIN_CROP: usize = (SIZE + 1) * 4;

/// The bank for `channels` input channels: FILTERS zero-mean filters of SIZE x SIZE x channels, unit norm.
fn bank(channels: usize) -> Vec<Vec<f32>> {
    let mut state = SEED ^ channels as u64;
    let mut uniform = || {
        // PCG-style LCG with an xorshift output (identical on every platform).
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let x = ((state >> 22) ^ state) >> 11;
        (x as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..FILTERS)
        .map(|_| {
            // Box-Muller normals.
            let mut f: Vec<f32> = (0..SIZE * SIZE * channels)
                .map(|_| {
                    let (u, v) = (uniform(), uniform());
                    ((-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()) as f32
                })
                .collect();
            let m = f.iter().sum::<f32>() / f.len() as f32;
            f.iter_mut().for_each(|x| *x -= m);
            let norm = f.iter().map(|x| x * x).sum::<f32>().sqrt();
            f.iter_mut().for_each(|x| *x /= norm);
            f
        })
        .collect()
}

/// Box-downsampled copy (floor size: partial blocks dropped) and its transpose.
fn box_down(v: &[f32], w: usize, h: usize, c: usize, k: usize) -> (Vec<f32>, usize, usize) {
    let (ow, oh) = (w / k, h / k);
    let mut out = vec![0.0f32; ow * oh * c];
    let inv = 1.0 / (k * k) as f32;
    for oy in 0..oh {
        for ox in 0..ow {
            for dy in 0..k {
                for dx in 0..k {
                    let i = ((oy * k + dy) * w + ox * k + dx) * c;
                    for ch in 0..c {
                        out[(oy * ow + ox) * c + ch] += v[i + ch] * inv;
                    }
                }
            }
        }
    }
    (out, ow, oh)
}

fn box_down_transpose(g: &[f32], w: usize, h: usize, c: usize, k: usize, into: &mut [f32]) {
    let (ow, oh) = (w / k, h / k);
    let inv = 1.0 / (k * k) as f32;
    for oy in 0..oh {
        for ox in 0..ow {
            for dy in 0..k {
                for dx in 0..k {
                    let i = ((oy * k + dy) * w + ox * k + dx) * c;
                    for ch in 0..c {
                        into[i + ch] += g[(oy * ow + ox) * c + ch] * inv;
                    }
                }
            }
        }
    }
}

/// Feature maps of one scale: ReLU(filter ⊛ x) at every 'valid' position, [position][filter]. Each input value
/// is multiplied into all filters at once (the bank transposed, `by_tap`), so the sixteen sums vectorize; each
/// sum still adds its taps in the same order, so the maps are the ones a filter-by-filter loop gives.
fn features(x: &[f32], w: usize, h: usize, c: usize, bank: &[Vec<f32>]) -> (Vec<[f32; FILTERS]>, usize, usize) {
    let (fw, fh) = (w + 1 - SIZE, h + 1 - SIZE);
    let by_tap: Vec<[f32; FILTERS]> = (0..SIZE * SIZE * c).map(|t| std::array::from_fn(|k| bank[k][t])).collect();
    let f: Vec<[f32; FILTERS]> = (0..fw * fh)
        .into_par_iter()
        .map(|p| {
            let (px, py) = (p % fw, p / fw);
            let mut out = [0.0f32; FILTERS];
            for dy in 0..SIZE {
                let row = ((py + dy) * w + px) * c;
                let taps = &by_tap[dy * SIZE * c..(dy + 1) * SIZE * c];
                for (tap, &v) in taps.iter().zip(&x[row..row + SIZE * c]) {
                    for k in 0..FILTERS {
                        out[k] += tap[k] * v;
                    }
                }
            }
            out.map(|s| s.max(0.0))
        })
        .collect();
    (f, fw, fh)
}

/// Entries of the upper triangle (with the diagonal) of a FILTERS x FILTERS matrix.
const TRI: usize = FILTERS * (FILTERS + 1) / 2;

/// 1 x 1 x D descriptor (D = 3 scales x 136 Gram entries) of an image of 1 or 3 channels, at least
/// `MIN_CROP` pixels on each side.
pub fn texture_descriptor(a: &Tensor) -> Result<Tensor> {
    let v = a.value();
    let (w, h, c) = (v.width, v.height, v.channels);
    if w < MIN_CROP || h < MIN_CROP {
        return Err(Error::Invalid(format!(
            "texture_descriptor: a {w}x{h} crop is too small; the coarsest scale needs at least {MIN_CROP}x{MIN_CROP}"
        )));
    }
    if c != 1 && c != 3 {
        return Err(Error::Invalid(format!("texture_descriptor: {c} channels (1 or 3 expected)")));
    }
    let bank = bank(c);
    let mut desc = Vec::with_capacity(SCALES.len() * TRI);
    for &k in &SCALES {
        let (x, sw, sh) = box_down(&v.data, w, h, c, k);
        let (f, fw, fh) = features(&x, sw, sh, c, &bank);
        let n = (fw * fh) as f64;
        for i in 0..FILTERS {
            for j in i..FILTERS {
                desc.push((f.iter().map(|p| p[i] as f64 * p[j] as f64).sum::<f64>() / n) as f32);
            }
        }
    }
    let value = Image { width: 1, height: 1, channels: desc.len(), data: desc };
    record(
        "texture_descriptor",
        &[a],
        value,
        Kind::Other,
        Box::new(move |g, ops, _| {
            let src = &ops[0];
            let mut gin = vec![0.0f32; src.data.len()];
            for (s, &k) in SCALES.iter().enumerate() {
                let gd = &g.data[s * TRI..(s + 1) * TRI];
                // Symmetric Gram gradient: dL/dG_ij for both orders.
                let mut gg = [[0.0f32; FILTERS]; FILTERS];
                let pairs = (0..FILTERS).flat_map(|i| (i..FILTERS).map(move |j| (i, j)));
                for ((i, j), g) in pairs.zip(gd) {
                    gg[i][j] += g;
                    gg[j][i] += g;
                }
                let (x, sw, sh) = box_down(&src.data, w, h, c, k);
                let (f, fw, _) = features(&x, sw, sh, c, &bank);
                let n = f.len() as f32;
                // dL/dF_i(p) = Σ_j gg_ij F_j(p) / n, through the ReLU, then the filters' transpose.
                let mut gx = vec![0.0f32; x.len()];
                for (p, fp) in f.iter().enumerate() {
                    let (px, py) = (p % fw, p / fw);
                    for i in 0..FILTERS {
                        if fp[i] <= 0.0 {
                            continue;
                        }
                        let gf: f32 = (0..FILTERS).map(|j| gg[i][j] * fp[j]).sum::<f32>() / n;
                        let filt = &bank[i];
                        for dy in 0..SIZE {
                            let row = ((py + dy) * sw + px) * c;
                            for jj in 0..SIZE * c {
                                gx[row + jj] += gf * filt[dy * SIZE * c + jj];
                            }
                        }
                    }
                }
                box_down_transpose(&gx, w, h, c, k, &mut gin);
            }
            vec![Some(src.like(gin))]
        }),
    )
}

/// ‖desc(a) − desc(b)‖² / ‖desc(b)‖² (both as means over entries): a scale-free texture distance between two
/// crops of any sizes.
pub fn texture_loss(a: &Tensor, b: &Tensor) -> Result<Tensor> {
    texture_loss_to(a, &texture_descriptor(b)?)
}

/// `texture_loss(a, b)` given b's descriptor (`texture_descriptor(b)`): the material search and the graph fit
/// compare a thousand views with one crop, whose descriptor was half of each comparison's work.
pub fn texture_loss_to(a: &Tensor, b_descriptor: &Tensor) -> Result<Tensor> {
    let da = texture_descriptor(a)?;
    let denom = mean(&sqr(b_descriptor)?)?;
    if denom.item().unwrap_or(0.0) <= 0.0 {
        return Err(Error::Invalid("texture_loss: the reference crop has no texture energy (all black?)".into()));
    }
    div(&l2(&da, b_descriptor)?, &denom)
}
