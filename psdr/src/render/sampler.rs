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

    /// pcg4d transcribed directly from Jarzynski & Olano 2020 (JCGT 9(3), listing "pcg4d"), in u64 arithmetic
    /// reduced mod 2^32, independently of the implementation above:
    ///     v = v * 1664525u + 1013904223u;
    ///     v.x += v.y*v.w; v.y += v.z*v.x; v.z += v.x*v.y; v.w += v.y*v.z;
    ///     v ^= v >> 16u;
    ///     v.x += v.y*v.w; v.y += v.z*v.x; v.z += v.x*v.y; v.w += v.y*v.z;
    fn pcg4d_reference(v: [u32; 4]) -> [u32; 4] {
        const M: u64 = 0xFFFF_FFFF;
        let mut v = v.map(|x| (x as u64 * 1664525 + 1013904223) & M);
        let mix = |v: &mut [u64; 4]| {
            v[0] = (v[0] + v[1] * v[3]) & M;
            v[1] = (v[1] + v[2] * v[0]) & M;
            v[2] = (v[2] + v[0] * v[1]) & M;
            v[3] = (v[3] + v[1] * v[2]) & M;
        };
        mix(&mut v);
        for x in v.iter_mut() {
            *x ^= *x >> 16;
        }
        mix(&mut v);
        v.map(|x| x as u32)
    }

    #[test]
    fn known_values_pin_the_hash() {
        // Exact bits, computed once with a third, Python transcription of the published pcg4d; the GLSL twin is
        // checked against the same numbers.
        assert_eq!(pcg4d([0, 0, 0, 0]), [0x0f02f829, 0x2d568769, 0x32b0c43b, 0xd32548ea]);
        assert_eq!(pcg4d([1, 2, 3, 4]), [0x3622cd16, 0xf11471d8, 0xe1109b3f, 0x02b94c2f]);
        assert_eq!(pcg4d([0xffffffff, 0, 0x12345678, 7]), [0x2d999d5f, 0xb5a5b800, 0xd97ec3f8, 0x161cb4f9]);
        // sample_1d(seed, pixel, sample, dim) = (pcg4d([pixel, sample, dim, seed]).x >> 8) / 2^24.
        assert_eq!(sample_1d(1, 2, 3, 4), 3715389.0 / 16777216.0);
        assert_eq!(sample_1d(0, 0, 0, 0), 983800.0 / 16777216.0);
        assert_eq!(sample_1d(7, 1000, 65535, 41), 9464709.0 / 16777216.0);
        // And the implementation equals the transcription on 100k scattered inputs.
        let mut x = 0x1234_5678u32;
        for _ in 0..100_000 {
            let v = [0, 1, 2, 3].map(|k| {
                x = x.wrapping_mul(747796405).wrapping_add(2891336453 + k);
                x
            });
            assert_eq!(pcg4d(v), pcg4d_reference(v), "input {v:?}");
        }
    }

    /// Upper chi-square quantile at p = 1e-6 (standard-normal z = 4.753), Wilson-Hilferty approximation (accurate
    /// to ~1 % of the quantile for these degrees of freedom).
    fn chi2_limit(dof: f64) -> f64 {
        let a = 2.0 / (9.0 * dof);
        dof * (1.0 - a + 4.753 * a.sqrt()).powi(3)
    }

    fn chi2(counts: &[u32], expected: f64) -> f64 {
        counts.iter().map(|&c| (c as f64 - expected).powi(2) / expected).sum()
    }

    /// A named counter axis of the sampler and the draw it produces for index i.
    type Axis = (&'static str, fn(u32) -> f32);

    #[test]
    fn one_dimensional_marginals_are_uniform_chi_square() {
        // 256 bins, 2^16 draws (256 expected per bin) along each counter axis: pixel, sample, dimension, seed.
        // The statistic must stay below the chi-square quantile of p = 1e-6 with 255 degrees of freedom.
        let n = 1u32 << 16;
        let axes: [Axis; 4] = [
            ("pixel", |i| sample_1d(7, i, 3, 4)),
            ("sample", |i| sample_1d(7, 11, i, 4)),
            ("dimension", |i| sample_1d(7, 11, 3, i)),
            ("seed", |i| sample_1d(i, 11, 3, 4)),
        ];
        for (name, f) in axes {
            let mut counts = vec![0u32; 256];
            for i in 0..n {
                let u = f(i);
                assert!((0.0..1.0).contains(&u));
                counts[(u * 256.0) as usize] += 1;
            }
            let stat = chi2(&counts, n as f64 / 256.0);
            eprintln!("{name}: chi2 {stat:.1} (255 dof)");
            assert!(stat < chi2_limit(255.0), "{name}: chi2 {stat:.1} >= {:.1} (p < 1e-6)", chi2_limit(255.0));
        }
    }

    #[test]
    fn two_dimensional_marginals_are_uniform_chi_square() {
        // 32 x 32 bins, 2^18 draws (256 expected per bin), for the pairs a path actually uses together: pixel
        // jitter (dims 0, 1), a light sample (DIM_LIGHT_U, DIM_LIGHT_V of bounce 0) and a BSDF sample of bounce 1;
        // chi-square below its p = 1e-6 quantile with 1023 degrees of freedom.
        let n = 1u32 << 18;
        let pairs = [
            (DIM_PIXEL_X, DIM_PIXEL_Y),
            (DIM_BOUNCE_BASE + DIM_LIGHT_U, DIM_BOUNCE_BASE + DIM_LIGHT_V),
            (DIM_BOUNCE_BASE + DIMS_PER_BOUNCE + DIM_BSDF_U, DIM_BOUNCE_BASE + DIMS_PER_BOUNCE + DIM_BSDF_V),
        ];
        for (da, db) in pairs {
            let mut counts = vec![0u32; 32 * 32];
            for i in 0..n {
                // 65536 pixels x 4 samples, so both the pixel and the sample counter vary.
                let (pixel, sample) = (i % 65536, i / 65536);
                let a = sample_1d(3, pixel, sample, da);
                let b = sample_1d(3, pixel, sample, db);
                counts[(a * 32.0) as usize * 32 + (b * 32.0) as usize] += 1;
            }
            let stat = chi2(&counts, n as f64 / 1024.0);
            eprintln!("dims ({da}, {db}): chi2 {stat:.1} (1023 dof)");
            assert!(stat < chi2_limit(1023.0), "dims ({da}, {db}): chi2 {stat:.1} >= {:.1}", chi2_limit(1023.0));
        }
    }
}
