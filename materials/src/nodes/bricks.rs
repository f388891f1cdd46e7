//! Running-bond bricks and square tiles (offset 0).

use crate::kernel::Generator;
use crate::noise::hash01;
use crate::real::{smoothstep, Real};

/// Output modes of bricks-like generators.
pub const TILE_MODES: &[&str] = &["mask", "random"];

/// ints rows, cols, seed, mode; floats offset (of odd rows, in bricks), mortar and
/// bevel (both in units of brick height). Mask is 1 on bricks, 0 in mortar.
pub struct Bricks;
impl Generator for Bricks {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T {
        let (rows, cols) = (i[0].max(1), i[1].max(1));
        let yr = v * rows as f64;
        let r = yr.floor() as i64;
        let fy = yr - r as f64;
        let shift = if r.rem_euclid(2) == 1 { f[0] } else { T::c(0.0) };
        let xs = shift + u * cols as f64;
        let b = xs.v().floor() as i64;
        if i[3] == 1 {
            return T::c(hash01(b.rem_euclid(cols), r.rem_euclid(rows), i[2] as u64, 0));
        }
        let fx = xs - b as f64;
        let aspect = rows as f64 / cols as f64;
        let dx = fx.min(T::c(1.0) - fx) * aspect;
        let dy = T::c(fy.min(1.0 - fy));
        smoothstep(f[1], f[1] + f[2], dx.min(dy))
    }
}
