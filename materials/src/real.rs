//! Scalar abstraction shared by forward evaluation (`f64`) and reverse-mode
//! adjoints (`Dual<N>`, forward-mode duals over at most N local variables).
//!
//! Node kernels are written once, generic over [`Real`]; the evaluator runs
//! them with `f64` for the forward pass and with duals for the per-texel local
//! Jacobian, which it then contracts with dL/d(output) (exact reverse mode).

// Lockstep indexing over the derivative lanes of several duals reads clearer than zips.
#![allow(clippy::needless_range_loop)]

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Number type for node kernels.
pub trait Real:
    Copy
    + Send
    + Sync
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
{
    /// A constant (zero derivative).
    fn c(v: f64) -> Self;
    /// The primal value.
    fn v(self) -> f64;
    /// `f(self)` given the primal `f` and the derivative `df` at `self`.
    fn chain(self, f: f64, df: f64) -> Self;

    fn sqrt(self) -> Self {
        let s = self.v().max(0.0).sqrt();
        self.chain(s, if s > 1e-300 { 0.5 / s } else { 0.0 })
    }
    fn sin(self) -> Self {
        self.chain(self.v().sin(), self.v().cos())
    }
    fn cos(self) -> Self {
        self.chain(self.v().cos(), -self.v().sin())
    }
    fn exp(self) -> Self {
        let e = self.v().exp();
        self.chain(e, e)
    }
    /// `self^e` for a constant exponent; 0 (with zero derivative) for a non-positive base.
    fn powf(self, e: f64) -> Self {
        let x = self.v();
        if x <= 0.0 {
            return Self::c(0.0);
        }
        let p = x.powf(e);
        self.chain(p, e * p / x)
    }
    /// `self^e` with a variable exponent; 0 for a non-positive base.
    fn pow(self, e: Self) -> Self {
        let x = self.v();
        if x <= 0.0 {
            return Self::c(0.0);
        }
        (e * self.chain(x.ln(), 1.0 / x)).exp()
    }
    fn abs(self) -> Self {
        if self.v() < 0.0 {
            -self
        } else {
            self
        }
    }
    /// Fractional part; derivative 1 almost everywhere.
    fn fract(self) -> Self {
        self - self.v().floor()
    }
    fn min(self, o: Self) -> Self {
        if self.v() <= o.v() {
            self
        } else {
            o
        }
    }
    fn max(self, o: Self) -> Self {
        if self.v() >= o.v() {
            self
        } else {
            o
        }
    }
    fn clamp(self, lo: f64, hi: f64) -> Self {
        self.max(Self::c(lo)).min(Self::c(hi))
    }
    fn clamp01(self) -> Self {
        self.clamp(0.0, 1.0)
    }
}

impl Real for f64 {
    #[inline(always)]
    fn c(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn v(self) -> f64 {
        self
    }
    #[inline(always)]
    fn chain(self, f: f64, _df: f64) -> Self {
        f
    }
}

/// Hermite smoothstep between edges `e0 < e1` (callers keep `e1 - e0` positive).
#[inline]
pub fn smoothstep<T: Real>(e0: T, e1: T, x: T) -> T {
    let t = ((x - e0) / (e1 - e0)).clamp01();
    t * t * (T::c(3.0) - t * 2.0)
}

/// Linear interpolation `a + (b - a) t`.
#[inline]
pub fn mix<T: Real>(a: T, b: T, t: T) -> T {
    a + (b - a) * t
}

/// Forward-mode dual number with N derivative lanes.
#[derive(Clone, Copy, Debug)]
pub struct Dual<const N: usize> {
    pub v: f64,
    pub d: [f64; N],
}

impl<const N: usize> Dual<N> {
    /// A variable seeded on lane `k`.
    pub fn var(v: f64, k: usize) -> Self {
        let mut d = [0.0; N];
        d[k] = 1.0;
        Dual { v, d }
    }
}

impl<const N: usize> Real for Dual<N> {
    #[inline(always)]
    fn c(v: f64) -> Self {
        Dual { v, d: [0.0; N] }
    }
    #[inline(always)]
    fn v(self) -> f64 {
        self.v
    }
    #[inline(always)]
    fn chain(self, f: f64, df: f64) -> Self {
        let mut d = self.d;
        for x in &mut d {
            *x *= df;
        }
        Dual { v: f, d }
    }
}

impl<const N: usize> Add for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        let mut d = self.d;
        for k in 0..N {
            d[k] += o.d[k];
        }
        Dual { v: self.v + o.v, d }
    }
}
impl<const N: usize> Sub for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        let mut d = self.d;
        for k in 0..N {
            d[k] -= o.d[k];
        }
        Dual { v: self.v - o.v, d }
    }
}
impl<const N: usize> Mul for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        let mut d = [0.0; N];
        for k in 0..N {
            d[k] = self.d[k] * o.v + o.d[k] * self.v;
        }
        Dual { v: self.v * o.v, d }
    }
}
impl<const N: usize> Div for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        let inv = 1.0 / o.v;
        let q = self.v * inv;
        let mut d = [0.0; N];
        for k in 0..N {
            d[k] = (self.d[k] - q * o.d[k]) * inv;
        }
        Dual { v: q, d }
    }
}
impl<const N: usize> Neg for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.chain(-self.v, -1.0)
    }
}
impl<const N: usize> Add<f64> for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: f64) -> Self {
        Dual { v: self.v + o, d: self.d }
    }
}
impl<const N: usize> Sub<f64> for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: f64) -> Self {
        Dual { v: self.v - o, d: self.d }
    }
}
impl<const N: usize> Mul<f64> for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: f64) -> Self {
        self.chain(self.v * o, o)
    }
}
impl<const N: usize> Div<f64> for Dual<N> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: f64) -> Self {
        self.chain(self.v / o, 1.0 / o)
    }
}
