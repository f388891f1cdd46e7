//! Noise generators: gradient (Perlin) noise, fBm clouds and grunge.

use crate::kernel::Generator;
use crate::noise::{octaves, perlin};
use crate::real::{smoothstep, Real};

/// Single-octave gradient noise; ints scale_x, scale_y, seed.
pub struct Perlin;
impl Generator for Perlin {
    fn eval<T: Real>(&self, _: &[T], i: &[i64], u: f64, v: f64) -> T {
        let (px, py) = (i[0].max(1), i[1].max(1));
        T::c(0.5 + 0.5 * perlin(u * px as f64, v * py as f64, px, py, i[2] as u64))
    }
}

/// Weighted octave sum, normalised by the total weight: `sum r^k n_k / sum r^k`.
fn fbm_sum<T: Real>(n: &[f64], roughness: T) -> T {
    let mut w = T::c(1.0);
    let mut sum = T::c(0.0);
    let mut norm = T::c(0.0);
    for &x in n {
        sum = sum + w * x;
        norm = norm + w;
        w = w * roughness;
    }
    sum / norm
}

/// Fractal Brownian motion ("clouds"); ints scale_x, scale_y, octaves, seed; float roughness.
pub struct Fbm;
impl Generator for Fbm {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T {
        let mut n = [0.0; 10];
        let oct = i[2].clamp(1, 10) as usize;
        octaves(u, v, i[0].max(1), i[1].max(1), i[3] as u64, &mut n[..oct]);
        fbm_sum(&n[..oct], f[0]) * 0.5 + 0.5
    }
}

/// Patchy dirt mask: thresholded fBm plus fine speckle; int scale, seed;
/// floats threshold, softness, speckle.
pub struct Grunge;
impl Generator for Grunge {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T {
        let s = i[0].max(1);
        let mut n = [0.0; 6];
        octaves(u, v, s, s, i[1] as u64, &mut n);
        let base = fbm_sum(&n, T::c(0.6)) * 0.5 + 0.5;
        let fine = 8 * s;
        let speck = perlin(u * fine as f64, v * fine as f64, fine, fine, i[1] as u64 ^ 0xABCD);
        let x = base + f[2] * (speck * 0.35);
        smoothstep(f[0] - f[1], f[0] + f[1], x)
    }
}
