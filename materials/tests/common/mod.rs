//! Shared test helpers: a tiny deterministic RNG and central finite differences.
#![allow(dead_code)]

use psdr_materials::{Evaluator, Params};

/// xorshift64* (tests need reproducible "random" values, not quality).
pub struct Rng(pub u64);
impl Rng {
    pub fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// Random parameters strictly inside their ranges (10% margins keep FD steps in range).
pub fn random_params(ev: &Evaluator, rng: &mut Rng) -> Params {
    let mut p = ev.graph().default_params();
    for (v, (lo, hi)) in p.floats.iter_mut().zip(ev.graph().float_ranges()) {
        let m = 0.1 * (hi - lo);
        *v = rng.range(lo + m, hi - m);
    }
    p
}

/// Compares an analytic gradient with central differences of `loss`
/// (step `1e-7 * range`: small enough that few texels cross a kink such as a bilinear cell edge, large enough for f64 round-off). Tolerance: |a - fd| <= rel * (|a| + |fd|) + abs.
/// Returns the worst offender as an error message.
pub fn check_fd(
    ev: &mut Evaluator,
    params: &Params,
    analytic: &[f64],
    rel: f64,
    abs: f64,
    mut loss: impl FnMut(&mut Evaluator, &Params) -> f64,
) -> Result<(), String> {
    let names = ev.graph().float_names();
    let ranges = ev.graph().float_ranges();
    for k in 0..params.floats.len() {
        let h = 1e-7 * (ranges[k].1 - ranges[k].0);
        let mut p = params.clone();
        p.floats[k] = params.floats[k] + h;
        let lp = loss(ev, &p);
        p.floats[k] = params.floats[k] - h;
        let lm = loss(ev, &p);
        let fd = (lp - lm) / (2.0 * h);
        let a = analytic[k];
        let ok = (a - fd).abs() <= rel * (a.abs() + fd.abs()) + abs;
        if !ok || !a.is_finite() {
            return Err(format!("param {} ({k}): analytic {a:.9e} vs FD {fd:.9e}", names[k]));
        }
    }
    Ok(())
}
