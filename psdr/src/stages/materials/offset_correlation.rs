//! The correlation of a tiling texture with scattered samples at every offset at once.
//!
//! Samples at texture coordinates x_i (the transform applied with offset 0) with values p_i score an offset d
//! by sum_i p_i T(x_i + d). Splatted onto the texture's n x n texel grid (P), that is the cross-correlation of
//! P with T on the torus (the texture wraps), IFFT(conj(FFT P) FFT T), n^2 offsets for three 2-D FFTs, where a
//! grid of offsets evaluated one by one costs n^2 passes over the samples and, coarse, misses a peak as narrow
//! as a brick wall's mortar. Each sample reads the mip level its footprint calls for (one spectrum per level);
//! sums of T and T^2 over the samples come the same way, for the normalisation.

use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

pub(crate) struct OffsetCorrelator {
    n: usize,
    forward: Arc<dyn Fft<f64>>,
    inverse: Arc<dyn Fft<f64>>,
    levels: Vec<LevelSpectra>,
}

/// A mip level's spectrum (each texel repeated to fill n x n) and its square's.
struct LevelSpectra {
    texture: Vec<Complex<f64>>,
    squared: Vec<Complex<f64>>,
}

/// Per offset (row-major over the n x n grid, offset (column, row) = d): sum p T, sum T, sum T^2.
pub(crate) struct OffsetSums {
    pub cov: Vec<f64>,
    pub sum: Vec<f64>,
    pub sum_sq: Vec<f64>,
}

impl OffsetCorrelator {
    /// `levels`: a square texture's mip chain, (side, texels row 0 on top), the first n x n; None unless square.
    pub fn new(levels: &[(usize, usize, Vec<f32>)]) -> Option<OffsetCorrelator> {
        let (n, h, _) = levels.first()?;
        if n != h || *n < 2 {
            return None;
        }
        let n = *n;
        let mut planner = FftPlanner::new();
        let (forward, inverse) = (planner.plan_fft_forward(n), planner.plan_fft_inverse(n));
        let mut out = OffsetCorrelator { n, forward, inverse, levels: vec![] };
        for (side, _, texels) in levels {
            let k = n / side.max(&1);
            let at = |i: usize| texels[(i / n / k) * side + (i % n) / k] as f64;
            let mut t: Vec<Complex<f64>> = (0..n * n).map(|i| Complex::new(at(i), 0.0)).collect();
            let mut t2: Vec<Complex<f64>> = t.iter().map(|v| Complex::new(v.re * v.re, 0.0)).collect();
            out.fft2(&mut t, false);
            out.fft2(&mut t2, false);
            out.levels.push(LevelSpectra { texture: t, squared: t2 });
        }
        Some(out)
    }

    pub fn side(&self) -> usize {
        self.n
    }

    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// 2-D FFT in place (rows, then columns through a transpose), unnormalised.
    fn fft2(&self, buf: &mut [Complex<f64>], inverse: bool) {
        let (n, f) = (self.n, if inverse { &self.inverse } else { &self.forward });
        f.process(buf);
        transpose(buf, n);
        f.process(buf);
        transpose(buf, n);
    }

    /// The sums at every offset for samples at texel positions `at` ((column, row), continuous: x = u' n -
    /// 1/2, y = (1 - v') n - 1/2, as the texture lookup has them), values `p` and mip levels `level`. Offset
    /// (dc, dr) moves a sample to (column + dc, row + dr): uv offset (dc / n, -dr / n).
    pub fn sums(&self, at: &[[f64; 2]], p: &[f64], level: &[usize]) -> OffsetSums {
        let n = self.n;
        let zero = Complex::new(0.0, 0.0);
        let (mut c, mut s1, mut s2) = (vec![zero; n * n], vec![zero; n * n], vec![zero; n * n]);
        for l in 0..self.levels.len() {
            let members: Vec<usize> = (0..at.len()).filter(|&i| level[i] == l).collect();
            if members.is_empty() {
                continue;
            }
            let (mut pg, mut ones) = (vec![zero; n * n], vec![zero; n * n]);
            for &i in &members {
                let wrap = |v: f64| (v.round() as i64).rem_euclid(n as i64) as usize;
                let cell = wrap(at[i][1]) * n + wrap(at[i][0]);
                pg[cell].re += p[i];
                ones[cell].re += 1.0;
            }
            self.fft2(&mut pg, false);
            self.fft2(&mut ones, false);
            let spectra = &self.levels[l];
            for k in 0..n * n {
                c[k] += pg[k].conj() * spectra.texture[k];
                s1[k] += ones[k].conj() * spectra.texture[k];
                s2[k] += ones[k].conj() * spectra.squared[k];
            }
        }
        let scale = 1.0 / (n * n) as f64;
        let back = |mut v: Vec<Complex<f64>>| {
            self.fft2(&mut v, true);
            v.iter().map(|z| z.re * scale).collect::<Vec<f64>>()
        };
        OffsetSums { cov: back(c), sum: back(s1), sum_sq: back(s2) }
    }
}

fn transpose(buf: &mut [Complex<f64>], n: usize) {
    for y in 0..n {
        for x in y + 1..n {
            buf.swap(y * n + x, x * n + y);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The spectra's sums equal the sums taken offset by offset.
    #[test]
    fn every_offset_equals_the_direct_sum() {
        let n = 16;
        let tex: Vec<f32> = (0..n * n).map(|i| ((i * 37 % 23) as f32) / 23.0).collect();
        let half: Vec<f32> = (0..(n / 2) * (n / 2))
            .map(|i| {
                let (x, y) = (2 * (i % (n / 2)), 2 * (i / (n / 2)));
                0.25 * (tex[y * n + x] + tex[y * n + x + 1] + tex[(y + 1) * n + x] + tex[(y + 1) * n + x + 1])
            })
            .collect();
        let levels = vec![(n, n, tex.clone()), (n / 2, n / 2, half.clone())];
        let c = OffsetCorrelator::new(&levels).unwrap();
        let at: Vec<[f64; 2]> = (0..40).map(|i| [(i * 7 % 16) as f64 + 0.2, (i * 5 % 16) as f64 - 0.3]).collect();
        let p: Vec<f64> = (0..40).map(|i| ((i * 13 % 9) as f64) - 4.0).collect();
        let level: Vec<usize> = (0..40).map(|i| i % 2).collect();
        let s = c.sums(&at, &p, &level);
        let texel = |l: usize, col: i64, row: i64| {
            let (col, row) = (col.rem_euclid(n as i64) as usize, row.rem_euclid(n as i64) as usize);
            if l == 0 {
                tex[row * n + col] as f64
            } else {
                half[(row / 2) * (n / 2) + col / 2] as f64
            }
        };
        for (dc, dr) in [(0i64, 0i64), (3, 1), (15, 9), (8, 8)] {
            let (mut cov, mut sum, mut sq) = (0.0, 0.0, 0.0);
            for i in 0..40 {
                let v = texel(level[i], at[i][0].round() as i64 + dc, at[i][1].round() as i64 + dr);
                (cov, sum, sq) = (cov + p[i] * v, sum + v, sq + v * v);
            }
            let k = dr as usize * n + dc as usize;
            for (a, b) in [(s.cov[k], cov), (s.sum[k], sum), (s.sum_sq[k], sq)] {
                assert!((a - b).abs() < 1e-9 * b.abs().max(1.0), "offset ({dc}, {dr}): {a} vs {b}");
            }
        }
    }
}
