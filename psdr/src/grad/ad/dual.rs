//! Forward-mode dual numbers with one tangent: a value and its derivative along one parameter direction.
//! Geometric gradients replay a recorded path in these, one pose component at a time (few components per
//! object), which differentiates every geometric factor of the path without hand-derived formulas.

use glam::Vec3;
use std::ops::{Add, Div, Mul, Neg, Sub};

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct D {
    pub v: f32,
    pub d: f32,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct D3 {
    pub v: Vec3,
    pub d: Vec3,
}

impl D {
    pub const fn c(v: f32) -> D {
        D { v, d: 0.0 }
    }
    pub fn sqrt(self) -> D {
        let s = self.v.sqrt();
        D { v: s, d: if s > 0.0 { self.d / (2.0 * s) } else { 0.0 } }
    }
    pub fn max_c(self, m: f32) -> D {
        if self.v >= m {
            self
        } else {
            D::c(m)
        }
    }
    pub fn min_c(self, m: f32) -> D {
        if self.v <= m {
            self
        } else {
            D::c(m)
        }
    }
    pub fn clamp_c(self, lo: f32, hi: f32) -> D {
        self.max_c(lo).min_c(hi)
    }
    pub fn abs(self) -> D {
        if self.v >= 0.0 {
            self
        } else {
            -self
        }
    }
}

impl Add for D {
    type Output = D;
    fn add(self, o: D) -> D {
        D { v: self.v + o.v, d: self.d + o.d }
    }
}
impl Sub for D {
    type Output = D;
    fn sub(self, o: D) -> D {
        D { v: self.v - o.v, d: self.d - o.d }
    }
}
impl Mul for D {
    type Output = D;
    fn mul(self, o: D) -> D {
        D { v: self.v * o.v, d: self.d * o.v + self.v * o.d }
    }
}
impl Div for D {
    type Output = D;
    fn div(self, o: D) -> D {
        D { v: self.v / o.v, d: (self.d * o.v - self.v * o.d) / (o.v * o.v) }
    }
}
impl Neg for D {
    type Output = D;
    fn neg(self) -> D {
        D { v: -self.v, d: -self.d }
    }
}
impl Add<f32> for D {
    type Output = D;
    fn add(self, o: f32) -> D {
        D { v: self.v + o, d: self.d }
    }
}
impl Sub<D> for f32 {
    type Output = D;
    fn sub(self, o: D) -> D {
        D { v: self - o.v, d: -o.d }
    }
}
impl Mul<f32> for D {
    type Output = D;
    fn mul(self, o: f32) -> D {
        D { v: self.v * o, d: self.d * o }
    }
}

impl D3 {
    pub const fn c(v: Vec3) -> D3 {
        D3 { v, d: Vec3::ZERO }
    }
    pub fn dot(self, o: D3) -> D {
        D { v: self.v.dot(o.v), d: self.d.dot(o.v) + self.v.dot(o.d) }
    }
    pub fn cross(self, o: D3) -> D3 {
        D3 { v: self.v.cross(o.v), d: self.d.cross(o.v) + self.v.cross(o.d) }
    }
    pub fn length(self) -> D {
        self.dot(self).sqrt()
    }
    pub fn normalize(self) -> D3 {
        self * (D::c(1.0) / self.length())
    }
    /// Component-wise product with a constant colour.
    pub fn mul_c(self, c: Vec3) -> D3 {
        D3 { v: self.v * c, d: self.d * c }
    }
}

impl Add for D3 {
    type Output = D3;
    fn add(self, o: D3) -> D3 {
        D3 { v: self.v + o.v, d: self.d + o.d }
    }
}
impl Sub for D3 {
    type Output = D3;
    fn sub(self, o: D3) -> D3 {
        D3 { v: self.v - o.v, d: self.d - o.d }
    }
}
impl Neg for D3 {
    type Output = D3;
    fn neg(self) -> D3 {
        D3 { v: -self.v, d: -self.d }
    }
}
impl Mul<D> for D3 {
    type Output = D3;
    fn mul(self, s: D) -> D3 {
        D3 { v: self.v * s.v, d: self.d * s.v + self.v * s.d }
    }
}
/// Component-wise product of two dual colours.
impl Mul for D3 {
    type Output = D3;
    fn mul(self, o: D3) -> D3 {
        D3 { v: self.v * o.v, d: self.d * o.v + self.v * o.d }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// d/dt |a + t b|⁻¹ (a + t b) at t = 0.3 against central differences.
    #[test]
    fn normalize_derivative_matches_finite_differences() {
        let (a, b) = (Vec3::new(0.3, -1.2, 0.7), Vec3::new(0.5, 0.1, -0.9));
        let t = 0.3;
        let x = D3 { v: a + b * t, d: b };
        let n = x.normalize();
        let h = 1e-3;
        let fd = ((a + b * (t + h)).normalize() - (a + b * (t - h)).normalize()) / (2.0 * h);
        assert!((n.d - fd).length() < 1e-4, "{} vs {fd}", n.d);
        let c = x.cross(D3::c(Vec3::Y)).length();
        let fd_c = ((a + b * (t + h)).cross(Vec3::Y).length() - (a + b * (t - h)).cross(Vec3::Y).length()) / (2.0 * h);
        assert!((c.d - fd_c).abs() < 1e-4);
    }
}
