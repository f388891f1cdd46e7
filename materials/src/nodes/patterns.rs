//! Geometric repeats: stripes, checker, dots.

use crate::kernel::Generator;
use crate::noise::hash01;
use crate::real::{smoothstep, Real};

/// ints freq_x, freq_y (stripes per tile along each axis; both integers so the
/// stripes tile); floats width (duty cycle), softness.
pub struct Stripes;
impl Generator for Stripes {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T {
        let phase = (u * i[0] as f64 + v * i[1] as f64).rem_euclid(1.0);
        let d = T::c((phase - 0.5).abs());
        T::c(1.0) - smoothstep(f[0] * 0.5 - f[1], f[0] * 0.5 + f[1], d)
    }
}

/// int count (checker periods per tile, 2 cells each); float softness.
pub struct Checker;
impl Generator for Checker {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T {
        let c = i[0].max(1) as f64;
        let sq = |t: f64| {
            let d = T::c(((t * c + 0.25).rem_euclid(1.0) - 0.5).abs());
            smoothstep(T::c(0.25) - f[0], T::c(0.25) + f[0], d) * 2.0 - 1.0
        };
        sq(u) * sq(v) * 0.5 + 0.5
    }
}

/// Dot shapes.
pub const DOT_SHAPES: &[&str] = &["circle", "square", "diamond"];

/// ints count, stagger, shape, seed; floats radius (cell units), softness, size_jitter.
pub struct Dots;
impl Generator for Dots {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T {
        let n = i[0].max(1);
        let y = v * n as f64;
        let row = y.floor() as i64;
        let shift = if i[1] != 0 && row.rem_euclid(2) == 1 { 0.5 } else { 0.0 };
        let x = u * n as f64 - shift;
        let col = x.floor() as i64;
        let (lx, ly) = (x - col as f64 - 0.5, y - row as f64 - 0.5);
        let dist = match i[2] {
            1 => lx.abs().max(ly.abs()),
            2 => (lx.abs() + ly.abs()) * 0.75,
            _ => (lx * lx + ly * ly).sqrt(),
        };
        let h = hash01(col.rem_euclid(n), row.rem_euclid(n), i[3] as u64, 0);
        let r = f[0] * (T::c(1.0) - f[2] * h);
        T::c(1.0) - smoothstep(r - f[1], r + f[1], T::c(dist))
    }
}
