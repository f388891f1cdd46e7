//! Wood rings / grain for furniture surfaces: growth rings running along u,
//! bent by periodic fBm, plus fine streaks.

use crate::kernel::Generator;
use crate::noise::{octaves, perlin};
use crate::real::{mix, Real};

/// ints rings, noise_scale, seed; floats distortion, sharpness, streaks.
pub struct WoodRings;
impl Generator for WoodRings {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T {
        let rings = i[0].max(1) as f64;
        let ns = i[1].max(1);
        let seed = i[2] as u64;
        let mut n = [0.0; 3];
        octaves(u, v, ns, 2 * ns, seed, &mut n);
        let bend = n[0] + 0.5 * n[1] + 0.25 * n[2];
        let phase = (f[0] * (bend * 0.15) + v) * rings;
        // Light early wood with thin dark late-wood lines (narrower as sharpness grows).
        let ring = T::c(1.0) - ((phase * std::f64::consts::TAU).cos() * 0.5 + 0.5).pow(f[1]);
        let streak = 0.5
            + 0.3 * perlin(u * 4.0, v * 48.0, 4, 48, seed ^ 0x5EED)
            + 0.2 * perlin(u * 8.0, v * 112.0, 8, 112, seed ^ 0x5EEE);
        mix(ring, T::c(streak), f[2])
    }
}
