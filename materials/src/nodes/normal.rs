//! Tangent-space normal from a height map: central differences with wrap,
//! +x along +u (right), +y along +v (up the image, OpenGL convention), +z out.

use crate::image::Image;
use crate::node_op::{BackwardCtx, NodeArgs, NodeOp};
use rayon::prelude::*;

/// float strength: tile units of relief per unit of height.
pub struct NormalFromHeight;

/// Height slopes (dh/du, dh/dv) at texel (x, y), in per-tile units.
#[inline]
fn slopes(h: &Image, x: usize, y: usize) -> (f64, f64) {
    let (xi, yi) = (x as i64, y as i64);
    let half_n = 0.5 * h.size as f64;
    let gu = (h.at_wrapped(xi + 1, yi, 0) - h.at_wrapped(xi - 1, yi, 0)) * half_n;
    let gv = (h.at_wrapped(xi, yi - 1, 0) - h.at_wrapped(xi, yi + 1, 0)) * half_n;
    (gu, gv)
}

impl NodeOp for NormalFromHeight {
    fn forward(&self, a: &NodeArgs, ins: &[Option<&Image>], out: &mut Image, _: &mut Vec<f64>) {
        let h = ins[0].expect("height input");
        let (n, s) = (a.size, a.f[0]);
        out.data.par_chunks_mut(n * 3).enumerate().for_each(|(y, row)| {
            for x in 0..n {
                let (gu, gv) = slopes(h, x, y);
                let m = [-s * gu, -s * gv, 1.0];
                let l = (m[0] * m[0] + m[1] * m[1] + 1.0).sqrt();
                for c in 0..3 {
                    row[x * 3 + c] = m[c] / l;
                }
            }
        });
    }

    fn backward(&self, a: &NodeArgs, ins: &[Option<&Image>], _: &Image, d_out: &Image, cx: BackwardCtx) {
        let h = ins[0].expect("height input");
        let (n, s) = (a.size, a.f[0]);
        // Per texel: adjoints of (gu, gv), and per row: the strength adjoint.
        cx.scratch.resize(2 * n * n, 0.0);
        let dg = &mut cx.scratch[..];
        let row_acc = &mut cx.row_acc[..n];
        dg.par_chunks_mut(2 * n).zip(row_acc.par_iter_mut()).enumerate().for_each(|(y, (row, acc))| {
            let mut ds = 0.0;
            for x in 0..n {
                let (gu, gv) = slopes(h, x, y);
                let m = [-s * gu, -s * gv, 1.0];
                let l = (m[0] * m[0] + m[1] * m[1] + 1.0).sqrt();
                let nv = [m[0] / l, m[1] / l, m[2] / l];
                let g = &d_out.data[(y * n + x) * 3..(y * n + x) * 3 + 3];
                let dot = nv[0] * g[0] + nv[1] * g[1] + nv[2] * g[2];
                let dm0 = (g[0] - nv[0] * dot) / l;
                let dm1 = (g[1] - nv[1] * dot) / l;
                ds += -dm0 * gu - dm1 * gv;
                row[2 * x] = -s * dm0;
                row[2 * x + 1] = -s * dm1;
            }
            *acc = ds;
        });
        if cx.active[0] {
            cx.d_params[0] += row_acc.iter().sum::<f64>();
        }
        if cx.need_in[0] {
            let half_n = 0.5 * n as f64;
            let dg = &cx.scratch[..];
            let at = |x: i64, y: i64, k: usize| {
                let (xi, yi) = (x.rem_euclid(n as i64) as usize, y.rem_euclid(n as i64) as usize);
                dg[2 * (yi * n + xi) + k]
            };
            cx.d_ins[0].data.par_chunks_mut(n).enumerate().for_each(|(y, row)| {
                let yi = y as i64;
                for (x, t) in row.iter_mut().enumerate() {
                    let xi = x as i64;
                    *t += half_n * (at(xi - 1, yi, 0) - at(xi + 1, yi, 0) + at(xi, yi + 1, 1) - at(xi, yi - 1, 1));
                }
            });
        }
    }
}
