//! Woven cloth height: warp (vertical) and weft (horizontal) threads crossing.

use crate::kernel::Generator;
use crate::real::{smoothstep, Real};

/// Weave patterns (tile when `count` is a multiple of 2, 4, 4 respectively).
pub const WEAVE_PATTERNS: &[&str] = &["plain", "twill", "basket"];

/// ints count (threads per tile), pattern; floats thread_width, crimp (dip where a thread goes under).
pub struct Weave;
impl Generator for Weave {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T {
        let n = i[0].max(1);
        let (x, y) = (u * n as f64, v * n as f64);
        let (cx, cy) = (x.floor() as i64, y.floor() as i64);
        let (a, b) = (x - cx as f64, y - cy as f64);
        let warp_on_top = match i[1] {
            1 => (cx - cy).rem_euclid(4) < 2,
            2 => (cx.div_euclid(2) + cy.div_euclid(2)).rem_euclid(2) == 0,
            _ => (cx + cy).rem_euclid(2) == 0,
        };
        // Smooth bump across a thread of width `thread_width` (cell units).
        let bump = |t: f64| {
            let d = T::c((t - 0.5).abs() * 2.0) / f[0];
            smoothstep(T::c(0.0), T::c(1.0), T::c(1.0) - d)
        };
        let arch = |t: f64| T::c(1.0) - f[1] * (1.0 - (t * std::f64::consts::PI).sin());
        let (warp_h, weft_h) =
            if warp_on_top { (bump(a) * arch(b), bump(b) * 0.55) } else { (bump(a) * 0.55, bump(b) * arch(a)) };
        warp_h.max(weft_h)
    }
}
