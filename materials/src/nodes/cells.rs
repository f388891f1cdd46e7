//! Cellular patterns on periodic jittered grids: Voronoi (F1, F2-F1, cell
//! edges, per-cell values), which with stagger and no jitter gives hexagonal tiles.

use crate::kernel::Generator;
use crate::noise::hash01;
use crate::real::{smoothstep, Real};

/// Output modes of [`Voronoi`].
pub const VORONOI_MODES: &[&str] = &["f1", "f2_f1", "edge", "cell"];

/// ints scale_x, scale_y, seed, mode, stagger; floats jitter, width, softness.
pub struct Voronoi;
impl Generator for Voronoi {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T {
        let (sx, sy, seed, mode, stagger) = (i[0].max(1), i[1].max(1), i[2] as u64, i[3], i[4]);
        let (x, y) = (u * sx as f64, v * sy as f64);
        let jitter = f[0];
        // Nearest and second nearest feature points (squared distance, position, cell value).
        let big = T::c(1e9);
        let mut best = [(big, T::c(0.0), T::c(0.0), 0.0); 2];
        let j0 = y.floor() as i64;
        for cy in j0 - 1..=j0 + 1 {
            let shift = if stagger != 0 && cy.rem_euclid(2) == 1 { 0.5 } else { 0.0 };
            let i0 = (x - shift).floor() as i64;
            for cx in i0 - 1..=i0 + 1 {
                let (wx, wy) = (cx.rem_euclid(sx), cy.rem_euclid(sy));
                let px = jitter * (hash01(wx, wy, seed, 0) - 0.5) + (cx as f64 + 0.5 + shift);
                let py = jitter * (hash01(wx, wy, seed, 1) - 0.5) + (cy as f64 + 0.5);
                let (dx, dy) = (px - x, py - y);
                let d2 = dx * dx + dy * dy;
                let cand = (d2, px, py, hash01(wx, wy, seed, 2));
                if d2.v() < best[0].0.v() {
                    best[1] = best[0];
                    best[0] = cand;
                } else if d2.v() < best[1].0.v() {
                    best[1] = cand;
                }
            }
        }
        let (a, b) = (best[0], best[1]);
        match mode {
            0 => a.0.sqrt(),
            1 => b.0.sqrt() - a.0.sqrt(),
            2 => {
                // Exact distance to the bisector of the two nearest points.
                let (ex, ey) = (b.1 - a.1, b.2 - a.2);
                let sep = (ex * ex + ey * ey).sqrt().max(T::c(1e-6));
                let edge = (b.0 - a.0) / (sep * 2.0);
                smoothstep(f[1], f[1] + f[2], edge)
            }
            _ => T::c(a.3),
        }
    }
}
