//! Random thin scratches: a few line segments per cell of a periodic grid.

use crate::kernel::Generator;
use crate::noise::hash01;
use crate::real::{smoothstep, Real};

/// ints cells, per_cell, seed; floats width (tile units), length (cells, up to 1), spread
/// (0 = all scratches horizontal, 1 = any direction).
pub struct Scratches;
impl Generator for Scratches {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T {
        let n = i[0].max(1);
        let per = i[1].clamp(1, 6);
        let seed = i[2] as u64;
        let (x, y) = (u * n as f64, v * n as f64);
        let (cx0, cy0) = (x.floor() as i64, y.floor() as i64);
        let mut best = T::c(0.0);
        let half = f[1] * 0.5;
        let width = f[0] * n as f64;
        for cy in cy0 - 1..=cy0 + 1 {
            for cx in cx0 - 1..=cx0 + 1 {
                let (wx, wy) = (cx.rem_euclid(n), cy.rem_euclid(n));
                for s in 0..per as u64 {
                    let h = |k: u64| hash01(wx, wy, seed, 4 * s + k);
                    let (px, py) = (cx as f64 + h(0), cy as f64 + h(1));
                    let ang = f[2] * ((h(2) - 0.5) * std::f64::consts::PI);
                    let (dx, dy) = (ang.cos(), ang.sin());
                    let (rx, ry) = (x - px, y - py);
                    let along = T::c(rx * dx.v() + ry * dy.v());
                    let hl = half * (0.4 + 0.6 * h(3));
                    let t = along.max(-hl).min(hl);
                    let (ex, ey) = (-(dx * t) + rx, -(dy * t) + ry);
                    let dist = (ex * ex + ey * ey).sqrt();
                    let line = (T::c(1.0) - smoothstep(T::c(0.0), width, dist)) * (0.5 + 0.5 * h(3));
                    best = best.max(line);
                }
            }
        }
        best
    }
}
