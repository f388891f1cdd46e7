//! Nodes that resample their input at moved positions with bilinear wrap-around
//! lookups: warp (displace by another map) and transform (scale/rotate/offset).

use crate::image::Image;
use crate::node_op::{BackwardCtx, NodeArgs, NodeOp};
use rayon::prelude::*;
use std::f64::consts::TAU;

/// Bilinear lookup at texel-space position (px, py) (texel centres at integers),
/// wrapping; returns the value and its derivatives in px and py.
#[inline]
fn bilerp(im: &Image, px: f64, py: f64, c: usize) -> (f64, f64, f64) {
    let (x0, y0) = (px.floor(), py.floor());
    let (tx, ty) = (px - x0, py - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let a = im.at_wrapped(x0, y0, c);
    let b = im.at_wrapped(x0 + 1, y0, c);
    let d = im.at_wrapped(x0, y0 + 1, c);
    let e = im.at_wrapped(x0 + 1, y0 + 1, c);
    let top = a + (b - a) * tx;
    let bot = d + (e - d) * tx;
    let dx = (b - a) * (1.0 - ty) + (e - d) * ty;
    (top + (bot - top) * ty, dx, bot - top)
}

/// Adjoint of `bilerp`: adds g times the bilinear weights into `d_im`.
#[inline]
fn scatter(d_im: &mut Image, px: f64, py: f64, c: usize, g: f64) {
    let n = d_im.size as i64;
    let ch = d_im.channels;
    let (x0, y0) = (px.floor(), py.floor());
    let (tx, ty) = (px - x0, py - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    for (dx, dy, w) in
        [(0, 0, (1.0 - tx) * (1.0 - ty)), (1, 0, tx * (1.0 - ty)), (0, 1, (1.0 - tx) * ty), (1, 1, tx * ty)]
    {
        let xi = (x0 + dx).rem_euclid(n) as usize;
        let yi = (y0 + dy).rem_euclid(n) as usize;
        d_im.data[(yi * n as usize + xi) * ch + c] += g * w;
    }
}

/// Where output texel (x, y) samples from, and the derivative of that position
/// with respect to each float slot (and to the displacement texel, for warp).
trait Mapping: Send + Sync {
    /// Returns (px, py) and fills `jac[s] = (dpx, dpy)` per float slot; the last
    /// entry of `jac` is the derivative in the auxiliary input texel, if any.
    fn map(&self, a: &NodeArgs, aux: Option<&Image>, x: usize, y: usize, jac: &mut [(f64, f64); 5]) -> (f64, f64);
}

fn forward_mapped<M: Mapping>(m: &M, a: &NodeArgs, ins: &[Option<&Image>], out: &mut Image) {
    let src = ins[0].expect("resample input");
    let (n, oc) = (a.size, a.out_channels);
    out.data.par_chunks_mut(n * oc).enumerate().for_each(|(y, row)| {
        let mut jac = [(0.0, 0.0); 5];
        for x in 0..n {
            let (px, py) = m.map(a, ins.get(1).copied().flatten(), x, y, &mut jac);
            for c in 0..oc {
                row[x * oc + c] = bilerp(src, px, py, c).0;
            }
        }
    });
}

fn backward_mapped<M: Mapping>(m: &M, a: &NodeArgs, ins: &[Option<&Image>], d_out: &Image, cx: BackwardCtx) {
    let src = ins[0].expect("resample input");
    let aux = ins.get(1).copied().flatten();
    let (n, oc) = (a.size, a.out_channels);
    let nf = a.f.len();
    let mut jac = [(0.0, 0.0); 5];
    // Serial on purpose: the bilinear scatter writes neighbouring texels, and a
    // fixed order keeps the sums bit-identical on any thread count.
    for y in 0..n {
        for x in 0..n {
            let idx = y * n + x;
            let g = &d_out.data[idx * oc..idx * oc + oc];
            if g.iter().all(|&v| v == 0.0) {
                continue;
            }
            let (px, py) = m.map(a, aux, x, y, &mut jac);
            let (mut gx, mut gy) = (0.0, 0.0);
            for (c, &gc) in g.iter().enumerate() {
                let (_, dx, dy) = bilerp(src, px, py, c);
                gx += gc * dx;
                gy += gc * dy;
                if cx.need_in[0] {
                    scatter(&mut cx.d_ins[0], px, py, c, gc);
                }
            }
            for (s, j) in jac.iter().enumerate().take(nf) {
                if cx.active[s] {
                    cx.d_params[s] += gx * j.0 + gy * j.1;
                }
            }
            if aux.is_some() && cx.need_in.get(1) == Some(&true) {
                cx.d_ins[1].data[idx] += gx * jac[4].0 + gy * jac[4].1;
            }
        }
    }
}

/// Directional warp: inputs input, displacement (grey); floats amount (tile units), angle (turns).
/// Texel moves by amount * 2 (d - 0.5) along the angle.
pub struct Warp;
impl Mapping for Warp {
    fn map(&self, a: &NodeArgs, aux: Option<&Image>, x: usize, y: usize, jac: &mut [(f64, f64); 5]) -> (f64, f64) {
        let n = a.size as f64;
        let d = aux.map_or(0.5, |im| im.data[y * a.size + x]);
        let (amount, th) = (a.f[0], a.f[1] * TAU);
        let (cs, sn) = (th.cos(), th.sin());
        let k = 2.0 * (d - 0.5) * n;
        jac[0] = (k * cs, k * sn);
        jac[1] = (-amount * k * sn * TAU, amount * k * cs * TAU);
        jac[4] = (amount * 2.0 * n * cs, amount * 2.0 * n * sn);
        (x as f64 + amount * k * cs, y as f64 + amount * k * sn)
    }
}

/// Affine transform: floats scale (repeats), rotation (turns), offset_x, offset_y (tile units).
/// Integer scales with rotations by quarter turns keep the result tileable.
pub struct Transform;
impl Mapping for Transform {
    fn map(&self, a: &NodeArgs, _: Option<&Image>, x: usize, y: usize, jac: &mut [(f64, f64); 5]) -> (f64, f64) {
        let n = a.size as f64;
        let (s, th, ox, oy) = (a.f[0], a.f[1] * TAU, a.f[2], a.f[3]);
        let (cs, sn) = (th.cos(), th.sin());
        let (u, v) = ((x as f64 + 0.5) / n - 0.5, (y as f64 + 0.5) / n - 0.5);
        let (ru, rv) = (cs * u - sn * v, sn * u + cs * v);
        let su = (ru * s + 0.5 - ox) * n - 0.5;
        let sv = (rv * s + 0.5 - oy) * n - 0.5;
        jac[0] = (ru * n, rv * n);
        jac[1] = ((-sn * u - cs * v) * s * n * TAU, (cs * u - sn * v) * s * n * TAU);
        jac[2] = (-n, 0.0);
        jac[3] = (0.0, -n);
        (su, sv)
    }
}

impl NodeOp for Warp {
    fn forward(&self, a: &NodeArgs, ins: &[Option<&Image>], out: &mut Image, _: &mut Vec<f64>) {
        forward_mapped(self, a, ins, out)
    }
    fn backward(&self, a: &NodeArgs, ins: &[Option<&Image>], _: &Image, d_out: &Image, cx: BackwardCtx) {
        backward_mapped(self, a, ins, d_out, cx)
    }
}

impl NodeOp for Transform {
    fn forward(&self, a: &NodeArgs, ins: &[Option<&Image>], out: &mut Image, _: &mut Vec<f64>) {
        forward_mapped(self, a, ins, out)
    }
    fn backward(&self, a: &NodeArgs, ins: &[Option<&Image>], _: &Image, d_out: &Image, cx: BackwardCtx) {
        backward_mapped(self, a, ins, d_out, cx)
    }
}
