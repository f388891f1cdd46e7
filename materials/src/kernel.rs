//! Adapters that turn per-texel kernels written over [`Real`] into [`NodeOp`]s:
//! generators (texel = f(params, u, v)) and pointwise filters (texel = f(params,
//! input texels at the same place)). Backward evaluates the kernel with dual
//! numbers seeded on at most 16 local variables at a time and contracts the
//! per-texel Jacobian with dL/d(output): exact reverse mode, no tape.

// Lockstep indexing over dual lanes reads clearer than zips.
#![allow(clippy::needless_range_loop)]

use crate::image::Image;
use crate::node_op::{BackwardCtx, NodeArgs, NodeOp, RowWriter, MAX_FLOAT_SLOTS, MAX_INPUTS};
use crate::real::{Dual, Real};
use rayon::prelude::*;

/// Lanes per dual pass.
const LANES: usize = 16;

/// A generator: one grey texel from parameters and texel-centre coordinates
/// (u, v) in [0, 1) (v grows downwards, like image rows).
pub trait Generator: Send + Sync + 'static {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], u: f64, v: f64) -> T;
}

/// A pointwise filter: one output texel (1 or 3 channels used) from the input
/// texels at the same place. Grey inputs arrive broadcast to 3 channels,
/// missing optional inputs as 1.0.
pub trait Pointwise: Send + Sync + 'static {
    fn eval<T: Real>(&self, f: &[T], i: &[i64], ins: &[[T; 3]; MAX_INPUTS], out_ch: usize) -> [T; 3];
}

pub struct GenNode<G>(pub G);
pub struct PointNode<P>(pub P);

#[inline]
fn coord(k: usize, n: usize) -> f64 {
    (k as f64 + 0.5) / n as f64
}

impl<G: Generator> NodeOp for GenNode<G> {
    fn forward(&self, a: &NodeArgs, _ins: &[Option<&Image>], out: &mut Image, _s: &mut Vec<f64>) {
        let n = a.size;
        out.data.par_chunks_mut(n).enumerate().for_each(|(y, row)| {
            let v = coord(y, n);
            for (x, t) in row.iter_mut().enumerate() {
                *t = self.0.eval(a.f, a.i, coord(x, n), v);
            }
        });
    }

    fn backward(&self, a: &NodeArgs, _: &[Option<&Image>], _: &Image, d_out: &Image, cx: BackwardCtx) {
        // Fixed-size lane list: no heap allocation per call.
        let mut lanes = [0usize; MAX_FLOAT_SLOTS];
        let mut nl = 0;
        for s in (0..a.f.len()).filter(|&s| cx.active[s]) {
            lanes[nl] = s;
            nl += 1;
        }
        for chunk in lanes[..nl].chunks(LANES) {
            let acc = &mut cx.row_acc[..a.size * LANES];
            match chunk.len() {
                1 => gen_chunk::<G, 1>(&self.0, a, d_out, chunk, acc),
                2 => gen_chunk::<G, 2>(&self.0, a, d_out, chunk, acc),
                3 | 4 => gen_chunk::<G, 4>(&self.0, a, d_out, chunk, acc),
                5..=8 => gen_chunk::<G, 8>(&self.0, a, d_out, chunk, acc),
                _ => gen_chunk::<G, 16>(&self.0, a, d_out, chunk, acc),
            }
            for r in 0..a.size {
                for (k, &s) in chunk.iter().enumerate() {
                    cx.d_params[s] += acc[r * LANES + k];
                }
            }
        }
    }
}

fn seeded_params<const N: usize>(f: &[f64], lanes: &[usize]) -> [Dual<N>; MAX_FLOAT_SLOTS] {
    let mut p = [Dual::<N>::c(0.0); MAX_FLOAT_SLOTS];
    for (s, &v) in f.iter().enumerate() {
        p[s] = Dual::c(v);
    }
    for (k, &s) in lanes.iter().enumerate() {
        p[s].d[k] = 1.0;
    }
    p
}

fn gen_chunk<G: Generator, const N: usize>(g: &G, a: &NodeArgs, d_out: &Image, lanes: &[usize], row_acc: &mut [f64]) {
    let n = a.size;
    let p = seeded_params::<N>(a.f, lanes);
    let nf = a.f.len();
    row_acc.par_chunks_mut(LANES).enumerate().for_each(|(y, acc_row)| {
        let v = coord(y, n);
        let mut acc = [0.0; N];
        for x in 0..n {
            let g_out = d_out.data[y * n + x];
            if g_out == 0.0 {
                continue;
            }
            let r = g.eval(&p[..nf], a.i, coord(x, n), v);
            for k in 0..N {
                acc[k] += g_out * r.d[k];
            }
        }
        acc_row[..lanes.len()].copy_from_slice(&acc[..lanes.len()]);
    });
}

/// A local variable of a pointwise kernel: a float slot or one input channel.
#[derive(Clone, Copy)]
enum Lane {
    Slot(usize),
    In(usize, usize),
}

#[inline(always)]
fn load<T: Real>(ins: &[Option<&Image>], idx: usize) -> [[T; 3]; MAX_INPUTS] {
    let mut v = [[T::c(1.0); 3]; MAX_INPUTS];
    for (j, im) in ins.iter().enumerate() {
        if let Some(im) = im {
            if im.channels == 1 {
                v[j] = [T::c(im.data[idx]); 3];
            } else {
                let b = idx * 3;
                v[j] = [T::c(im.data[b]), T::c(im.data[b + 1]), T::c(im.data[b + 2])];
            }
        }
    }
    v
}

impl<P: Pointwise> NodeOp for PointNode<P> {
    fn forward(&self, a: &NodeArgs, ins: &[Option<&Image>], out: &mut Image, _s: &mut Vec<f64>) {
        let n = a.size;
        let oc = a.out_channels;
        out.data.par_chunks_mut(n * oc).enumerate().for_each(|(y, row)| {
            for x in 0..n {
                let v = load::<f64>(ins, y * n + x);
                let r = self.0.eval(a.f, a.i, &v, oc);
                row[x * oc..x * oc + oc].copy_from_slice(&r[..oc]);
            }
        });
    }

    fn backward(&self, a: &NodeArgs, ins: &[Option<&Image>], _: &Image, d_out: &Image, cx: BackwardCtx) {
        // Fixed-size lane and writer lists: no heap allocation per call.
        let mut lanes = [Lane::Slot(0); MAX_FLOAT_SLOTS + 3 * MAX_INPUTS];
        let mut nl = 0;
        for s in (0..a.f.len()).filter(|&s| cx.active[s]) {
            lanes[nl] = Lane::Slot(s);
            nl += 1;
        }
        for (j, im) in ins.iter().enumerate() {
            if let (Some(im), true) = (im, cx.need_in[j]) {
                for c in 0..im.channels {
                    lanes[nl] = Lane::In(j, c);
                    nl += 1;
                }
            }
        }
        let mut writers: [Option<RowWriter>; MAX_INPUTS] = [None, None, None];
        for (j, d) in cx.d_ins.iter_mut().enumerate() {
            if ins[j].is_some() && cx.need_in[j] {
                writers[j] = Some(RowWriter::new(&mut d.data));
            }
        }
        for chunk in lanes[..nl].chunks(LANES) {
            let acc = &mut cx.row_acc[..a.size * LANES];
            let w = &writers[..];
            match chunk.len() {
                1 => pw_chunk::<P, 1>(&self.0, a, ins, d_out, chunk, acc, w),
                2 => pw_chunk::<P, 2>(&self.0, a, ins, d_out, chunk, acc, w),
                3 | 4 => pw_chunk::<P, 4>(&self.0, a, ins, d_out, chunk, acc, w),
                5..=8 => pw_chunk::<P, 8>(&self.0, a, ins, d_out, chunk, acc, w),
                _ => pw_chunk::<P, 16>(&self.0, a, ins, d_out, chunk, acc, w),
            }
            for r in 0..a.size {
                for (k, lane) in chunk.iter().enumerate() {
                    if let Lane::Slot(s) = lane {
                        cx.d_params[*s] += acc[r * LANES + k];
                    }
                }
            }
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn pw_chunk<P: Pointwise, const N: usize>(
    p: &P,
    a: &NodeArgs,
    ins: &[Option<&Image>],
    d_out: &Image,
    lanes: &[Lane],
    row_acc: &mut [f64],
    writers: &[Option<RowWriter>],
) {
    let n = a.size;
    let oc = a.out_channels;
    let mut fp = [Dual::<N>::c(0.0); MAX_FLOAT_SLOTS];
    for (s, &v) in a.f.iter().enumerate() {
        fp[s] = Dual::c(v);
    }
    for (k, lane) in lanes.iter().enumerate() {
        if let Lane::Slot(s) = *lane {
            fp[s].d[k] = 1.0;
        }
    }
    let nf = a.f.len();
    row_acc.par_chunks_mut(LANES).enumerate().for_each(|(y, acc_row)| {
        let mut acc = [0.0; N];
        for x in 0..n {
            let idx = y * n + x;
            let g = &d_out.data[idx * oc..idx * oc + oc];
            if g.iter().all(|&v| v == 0.0) {
                continue;
            }
            let mut v = load::<Dual<N>>(ins, idx);
            for (k, lane) in lanes.iter().enumerate() {
                if let Lane::In(j, c) = *lane {
                    if ins[j].map(|im| im.channels) == Some(1) {
                        for t in &mut v[j] {
                            t.d[k] = 1.0;
                        }
                    } else {
                        v[j][c].d[k] = 1.0;
                    }
                }
            }
            let r = p.eval(&fp[..nf], a.i, &v, oc);
            let mut lane_g = [0.0; N];
            for c in 0..oc {
                for k in 0..N {
                    lane_g[k] += g[c] * r[c].d[k];
                }
            }
            for (k, lane) in lanes.iter().enumerate() {
                match *lane {
                    Lane::Slot(_) => acc[k] += lane_g[k],
                    Lane::In(j, c) => {
                        let ch = ins[j].map_or(1, |im| im.channels);
                        if let Some(w) = &writers[j] {
                            // SAFETY: this task only touches texel `idx` of row `y`.
                            let t = unsafe { w.range(idx * ch + c, 1) };
                            t[0] += lane_g[k];
                        }
                    }
                }
            }
        }
        acc_row[..lanes.len()].copy_from_slice(&acc[..lanes.len()]);
    });
}
