//! Per-channel normalisation to [0, 1] by the channel's min and max (depth to unit range, so relative depth
//! of unknown scale and offset compares with rendered depth). Gradient flows through the min and max too.

use crate::error::{Error, Result};
use crate::loss::tape::{record, Kind, Tensor};

fn normalized(op: &'static str, a: &Tensor, select: Option<Vec<bool>>, extra: &[&Tensor]) -> Result<Tensor> {
    let v = a.value();
    let (n, c) = (v.pixels(), v.channels);
    let sel = move |p: usize| select.as_ref().is_none_or(|s| s[p]);
    // Per channel: (index of min, index of max), first index on ties.
    let mut ext = vec![];
    for ch in 0..c {
        let mut it = (0..n).filter(|&p| sel(p));
        let Some(first) = it.next() else {
            return Err(Error::Invalid(format!("{op}: the mask selects no pixel")));
        };
        let (mut lo, mut hi) = (first, first);
        for p in it {
            if v.data[p * c + ch] < v.data[lo * c + ch] {
                lo = p;
            }
            if v.data[p * c + ch] > v.data[hi * c + ch] {
                hi = p;
            }
        }
        let range = v.data[hi * c + ch] as f64 - v.data[lo * c + ch] as f64;
        if range <= 1e-12 {
            return Err(Error::Invalid(format!(
                "{op}: channel {ch} is constant (max − min = {range}); nothing to normalise"
            )));
        }
        ext.push((lo, hi, range));
    }
    let mut out = vec![0.0f32; v.data.len()];
    for p in (0..n).filter(|&p| sel(p)) {
        for (ch, &(lo, _, range)) in ext.iter().enumerate() {
            out[p * c + ch] = ((v.data[p * c + ch] as f64 - v.data[lo * c + ch] as f64) / range) as f32;
        }
    }
    let mut inputs = vec![a];
    inputs.extend_from_slice(extra);
    let parts = inputs.len();
    record(
        op,
        &inputs,
        v.like(out.clone()),
        Kind::Other,
        Box::new(move |g, ops, _| {
            let x = &ops[0];
            let mut gx = vec![0.0f64; x.data.len()];
            for (ch, &(lo, hi, range)) in ext.iter().enumerate() {
                // y_i = (x_i − x_lo) / R:  ∂/∂x_i = 1/R,  ∂/∂x_lo = −Σ g_i/R + Σ g_i y_i/R,  ∂/∂x_hi = −Σ g_i y_i/R.
                let (mut sg, mut sgy) = (0.0f64, 0.0f64);
                for p in (0..n).filter(|&p| sel(p)) {
                    let gi = g.data[p * c + ch] as f64;
                    gx[p * c + ch] += gi / range;
                    sg += gi;
                    sgy += gi * out[p * c + ch] as f64;
                }
                gx[lo * c + ch] += (-sg + sgy) / range;
                gx[hi * c + ch] -= sgy / range;
            }
            let mut r = vec![Some(x.like(gx.into_iter().map(|v| v as f32).collect()))];
            r.resize(parts, None); // the mask (if any) is a selection: no gradient
            r
        }),
    )
}

/// (x − min) / (max − min) per channel over all pixels.
pub fn normalize(a: &Tensor) -> Result<Tensor> {
    normalized("normalize", a, None, &[])
}

/// `normalize` over the pixels where mask > 0.5; zero elsewhere. The mask is a selection (no gradient).
pub fn normalize_in(a: &Tensor, mask: &Tensor) -> Result<Tensor> {
    let (v, m) = (a.value(), mask.value());
    if (v.width, v.height) != (m.width, m.height) || m.channels != 1 {
        return Err(Error::Invalid(format!(
            "normalize_in: mask {} must be one channel of the image's size {}",
            m.shape(),
            v.shape()
        )));
    }
    let select: Vec<bool> = m.data.iter().map(|&x| x > 0.5).collect();
    normalized("normalize_in", a, Some(select), &[mask])
}
