//! Wooden boards: staggered floor planks and herringbone parquet. Both locate
//! the board under a texel (canonical id wrapped to the tile, so patterns tile)
//! and then shade it with the same mask / per-board random / grain code.

use crate::kernel::Generator;
use crate::noise::{hash01, perlin_free};
use crate::real::{smoothstep, Real};

/// Output modes of board generators.
pub const BOARD_MODES: &[&str] = &["mask", "random", "grain"];

/// A texel located on one board.
struct Board<T> {
    /// Position along the board in board widths, and the board length in widths.
    along: T,
    length: f64,
    /// Position across the board in [0, 1).
    across: f64,
    /// Canonical board id.
    id: (i64, i64),
}

/// Float slots shared by board generators: gap, bevel, grain_warp.
/// Int slots: ..., seed, mode, grain_scale (the last three).
fn shade<T: Real>(b: &Board<T>, f: &[T], seed: u64, mode: i64, grain_scale: i64) -> T {
    let rnd = |k| hash01(b.id.0, b.id.1, seed, k);
    match mode {
        0 => {
            let da = b.along.min(T::c(b.length) - b.along);
            let dc = T::c(b.across.min(1.0 - b.across));
            smoothstep(f[0], f[0] + f[1], da.min(dc))
        }
        1 => T::c(rnd(0)),
        _ => {
            // Flat-sawn grain: thin dark late-wood lines across the board, bent by
            // low-frequency noise (cathedrals), plus fine pores along it and a
            // per-board tone; per-board offsets make boards differ.
            let gs = grain_scale.max(1) as f64;
            let a = b.along.v();
            let warp = perlin_free(a * 0.25 + 17.0 * rnd(1), b.across * 1.2, seed ^ 0x51);
            let phase = f[2] * (warp * 0.8) + (b.across + 3.0 * rnd(2)) * gs * 0.5;
            let lines = ((phase * std::f64::consts::TAU).sin() * 0.5 + 0.5).powf(4.0);
            let pores = perlin_free(a * 0.5 + 31.0 * rnd(3), b.across * gs * 1.5, seed ^ 0x77)
                + 0.5 * perlin_free(a * 1.1 + 7.0 * rnd(3), b.across * gs * 3.0, seed ^ 0x78);
            let tone = perlin_free(a * 0.15 + 5.0 * rnd(4), b.across * 0.5, seed ^ 0x79);
            (lines * -0.45 + 0.78) + 0.12 * pores + 0.08 * tone
        }
    }
}

/// ints rows, per_row, seed, mode, grain_scale; floats gap, bevel (board widths), grain_warp.
pub struct Planks;
impl Generator for Planks {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T {
        let (rows, per_row) = (i[0].max(1), i[1].max(1));
        let yr = v * rows as f64;
        let r = yr.floor() as i64;
        let stagger = hash01(r.rem_euclid(rows), 7, i[2] as u64, 9);
        let x = u * per_row as f64 + stagger;
        let bx = x.floor() as i64;
        let length = rows as f64 / per_row as f64;
        let board = Board {
            along: T::c((x - bx as f64) * length),
            length,
            across: yr - r as f64,
            id: (bx.rem_euclid(per_row), r.rem_euclid(rows)),
        };
        shade(&board, f, i[2] as u64, i[3], i[4])
    }
}

/// ints ratio (board length / width), repeat, seed, mode, grain_scale; floats gap, bevel, grain_warp.
/// Horizontal boards [0,k]x0..1 and vertical boards [k,k+1]x[1-k,1] on the lattice
/// spanned by (1,1) and (k,-k) (units of board width); the tile is 2k*repeat wide.
pub struct Herringbone;
impl Generator for Herringbone {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T {
        let k = i[0].max(1);
        let rep = i[1].max(1);
        let w = 2 * k * rep;
        let (x, y) = (u * w as f64, v * w as f64);
        let n = y.floor() as i64;
        let xp = x - n as f64;
        let r = xp.rem_euclid(2.0 * k as f64);
        let canon = |row: i64, q: i64| {
            let t = row.div_euclid(w);
            (row - t * w, (q + t * rep).rem_euclid(rep))
        };
        let board = if r < k as f64 {
            let q = (xp / (2 * k) as f64).floor() as i64;
            let (a, b) = canon(n, q);
            Board { along: T::c(r), length: k as f64, across: y - n as f64, id: (a, 2 * b) }
        } else {
            let m = r.floor() as i64 - k;
            let base = n + m;
            let x_start = x.floor() as i64;
            let q = (x_start - k - base).div_euclid(2 * k);
            let (a, b) = canon(base, q);
            Board {
                along: T::c(y - (1 - k + base) as f64),
                length: k as f64,
                across: x - x_start as f64,
                id: (a, 2 * b + 1),
            }
        };
        shade(&board, f, i[2] as u64, i[3], i[4])
    }
}
