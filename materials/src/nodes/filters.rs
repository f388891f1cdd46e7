//! Pointwise tone and colour filters (levels, curves, HSL, gradient map, ...).

use crate::kernel::Pointwise;
use crate::node_op::MAX_INPUTS;
use crate::real::{mix, smoothstep, Real};

type Ins<T> = [[T; 3]; MAX_INPUTS];

/// Applies `f` to every used channel of input 0.
#[inline(always)]
fn per_channel<T: Real>(ins: &Ins<T>, oc: usize, f: impl Fn(T) -> T) -> [T; 3] {
    let mut o = [T::c(0.0); 3];
    for c in 0..oc {
        o[c] = f(ins[0][c]);
    }
    o
}

/// Input range remap, gamma and output range: slots in_low, in_high, gamma, out_low, out_high.
pub struct Levels;
impl Pointwise for Levels {
    fn eval<T: Real>(&self, f: &[T], _: &[i64], ins: &Ins<T>, oc: usize) -> [T; 3] {
        let span = (f[1] - f[0]).max(T::c(1e-4));
        let inv_gamma = T::c(1.0) / f[2];
        per_channel(ins, oc, |x| {
            let t = ((x - f[0]) / span).clamp01().pow(inv_gamma);
            f[3] + (f[4] - f[3]) * t
        })
    }
}

/// Tone curve through 5 evenly spaced control values y0..y4 (Catmull-Rom).
pub struct Curves;
impl Pointwise for Curves {
    fn eval<T: Real>(&self, f: &[T], _: &[i64], ins: &Ins<T>, oc: usize) -> [T; 3] {
        let pt = |k: i64| -> T {
            match k {
                -1 => f[0] * 2.0 - f[1],
                5 => f[4] * 2.0 - f[3],
                k => f[k as usize],
            }
        };
        per_channel(ins, oc, |x| {
            let s = x.clamp01() * 4.0;
            let seg = (s.v().floor() as i64).min(3);
            let t = s - seg as f64;
            let (p0, p1, p2, p3) = (pt(seg - 1), pt(seg), pt(seg + 1), pt(seg + 2));
            let a = p1 * 2.0;
            let b = p2 - p0;
            let c = p0 * 2.0 - p1 * 5.0 + p2 * 4.0 - p3;
            let d = -p0 + p1 * 3.0 - p2 * 3.0 + p3;
            (a + b * t + c * t * t + d * t * t * t) * 0.5
        })
    }
}

/// Hue rotation (turns), saturation and lightness shifts in HSL space.
pub struct HslShift;
impl Pointwise for HslShift {
    fn eval<T: Real>(&self, f: &[T], _: &[i64], ins: &Ins<T>, _oc: usize) -> [T; 3] {
        let [r, g, b] = ins[0];
        let mx = r.max(g).max(b);
        let mn = r.min(g).min(b);
        let l = (mx + mn) * 0.5;
        let d = mx - mn;
        let (mut h, mut s) = (T::c(0.0), T::c(0.0));
        if d.v() > 1e-9 {
            let den = (T::c(1.0) - (l * 2.0 - 1.0).abs()).max(T::c(1e-9));
            s = d / den;
            h = if mx.v() == r.v() {
                ((g - b) / d / 6.0).fract()
            } else if mx.v() == g.v() {
                ((b - r) / d + 2.0) / 6.0
            } else {
                ((r - g) / d + 4.0) / 6.0
            };
        }
        let h = (h + f[0]).fract();
        let s = (s * (f[1] + 1.0)).clamp01();
        let l = if f[2].v() > 0.0 { l + f[2] * (T::c(1.0) - l) } else { l + f[2] * l };
        hsl_to_rgb(h, s, l.clamp01())
    }
}

fn hsl_to_rgb<T: Real>(h: T, s: T, l: T) -> [T; 3] {
    let c = (T::c(1.0) - (l * 2.0 - 1.0).abs()) * s;
    let hp = h * 6.0;
    let x = c * (T::c(1.0) - ((hp * 0.5).fract() * 2.0 - 1.0).abs());
    let m = l - c * 0.5;
    let z = T::c(0.0);
    let (r, g, b) = match hp.v().floor() as i64 {
        0 => (c, x, z),
        1 => (x, c, z),
        2 => (z, c, x),
        3 => (z, x, c),
        4 => (x, z, c),
        _ => (c, z, x),
    };
    [r + m, g + m, b + m]
}

/// Number of stops a gradient map can hold.
pub const GRADIENT_STOPS: usize = 6;

/// Colour ramp: grey in, colour out. Slots pos_k, color_k (4 floats per stop); int `count`.
pub struct GradientMap;
impl Pointwise for GradientMap {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], ins: &Ins<T>, _oc: usize) -> [T; 3] {
        let count = (i[0].clamp(2, GRADIENT_STOPS as i64)) as usize;
        let x = ins[0][0];
        let pos = |k: usize| f[4 * k];
        let col = |k: usize| [f[4 * k + 1], f[4 * k + 2], f[4 * k + 3]];
        if x.v() <= pos(0).v() {
            return col(0);
        }
        for k in 0..count - 1 {
            if x.v() <= pos(k + 1).v() {
                let t = (x - pos(k)) / (pos(k + 1) - pos(k)).max(T::c(1e-6));
                let (a, b) = (col(k), col(k + 1));
                return [mix(a[0], b[0], t), mix(a[1], b[1], t), mix(a[2], b[2], t)];
            }
        }
        col(count - 1)
    }
}

/// 1 - x.
pub struct Invert;
impl Pointwise for Invert {
    fn eval<T: Real>(&self, _: &[T], _: &[i64], ins: &Ins<T>, oc: usize) -> [T; 3] {
        per_channel(ins, oc, |x| T::c(1.0) - x)
    }
}

/// Smoothstep around `threshold` with half-width `softness` (a differentiable threshold).
pub struct SmoothThreshold;
impl Pointwise for SmoothThreshold {
    fn eval<T: Real>(&self, f: &[T], _: &[i64], ins: &Ins<T>, oc: usize) -> [T; 3] {
        per_channel(ins, oc, |x| smoothstep(f[0] - f[1], f[0] + f[1], x))
    }
}

/// Clamp to [min, max].
pub struct Clamp;
impl Pointwise for Clamp {
    fn eval<T: Real>(&self, f: &[T], _: &[i64], ins: &Ins<T>, oc: usize) -> [T; 3] {
        per_channel(ins, oc, |x| x.max(f[0]).min(f[1]))
    }
}

/// Rec. 709 luma of a colour (grey passes through).
pub struct Grayscale;
impl Pointwise for Grayscale {
    fn eval<T: Real>(&self, _: &[T], _: &[i64], ins: &Ins<T>, _oc: usize) -> [T; 3] {
        let [r, g, b] = ins[0];
        let y = r * 0.2126 + g * 0.7152 + b * 0.0722;
        [y, y, y]
    }
}

/// Constant grey value.
pub struct Uniform;
impl Pointwise for Uniform {
    fn eval<T: Real>(&self, f: &[T], _: &[i64], _: &Ins<T>, _oc: usize) -> [T; 3] {
        [f[0]; 3]
    }
}

/// Constant colour.
pub struct ConstColor;
impl Pointwise for ConstColor {
    fn eval<T: Real>(&self, f: &[T], _: &[i64], _: &Ins<T>, _oc: usize) -> [T; 3] {
        [f[0], f[1], f[2]]
    }
}

/// Names of the blend modes, in `mode` order.
pub const BLEND_MODES: &[&str] = &["normal", "multiply", "add", "screen", "overlay", "subtract", "lighten", "darken"];

/// Blend `b` over `a` with a mode, an opacity and an optional grey mask.
pub struct Blend;
impl Pointwise for Blend {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], ins: &Ins<T>, oc: usize) -> [T; 3] {
        let mut o = [T::c(0.0); 3];
        let w = f[0] * ins[2][0];
        for c in 0..oc {
            let (a, b) = (ins[0][c], ins[1][c]);
            let one = T::c(1.0);
            let m = match i[0] {
                0 => b,
                1 => a * b,
                2 => a + b,
                3 => one - (one - a) * (one - b),
                4 => {
                    if a.v() < 0.5 {
                        a * b * 2.0
                    } else {
                        one - (one - a) * (one - b) * 2.0
                    }
                }
                5 => a - b,
                6 => a.max(b),
                _ => a.min(b),
            };
            o[c] = a + (m - a) * w;
        }
        o
    }
}
