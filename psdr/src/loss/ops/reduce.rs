//! Reductions to scalars: sums, means, the image distances losses are made of, weighted means.

use super::pointwise::{broadcast_shape, reduce_to, src_index};
use crate::base::Image;
use crate::error::{Error, Result};
use crate::loss::tape::{record, Kind, Tensor};

pub fn sum(a: &Tensor) -> Result<Tensor> {
    let v = a.value().data.iter().map(|&x| x as f64).sum::<f64>();
    record(
        "sum",
        &[a],
        Image::scalar(v as f32),
        Kind::Other,
        Box::new(|g, ops, _| vec![Some(ops[0].like(vec![g.data[0]; ops[0].data.len()]))]),
    )
}

pub fn mean(a: &Tensor) -> Result<Tensor> {
    let n = a.value().data.len() as f64;
    let v = a.value().data.iter().map(|&x| x as f64).sum::<f64>() / n;
    record(
        "mean",
        &[a],
        Image::scalar(v as f32),
        Kind::Other,
        Box::new(move |g, ops, _| vec![Some(ops[0].like(vec![(g.data[0] as f64 / n) as f32; ops[0].data.len()]))]),
    )
}

/// mean over elements of φ(a − b) (a and b broadcast), with φ' for the backward pass.
fn distance(
    op: &'static str,
    kind: Kind,
    a: &Tensor,
    b: &Tensor,
    phi: impl Fn(f32) -> f64,
    dphi: impl Fn(f32) -> f32 + 'static,
) -> Result<Tensor> {
    let (va, vb) = (a.value(), b.value());
    let (w, h, c) = broadcast_shape(op, va, vb)?;
    let n = w * h * c;
    let diff = move |x: &Image, y: &Image, i: usize| x.data[src_index(x, i, c)] - y.data[src_index(y, i, c)];
    let v = (0..n).map(|i| phi(diff(va, vb, i))).sum::<f64>() / n as f64;
    record(
        op,
        &[a, b],
        Image::scalar(v as f32),
        kind,
        Box::new(move |g, ops, need| {
            let k = g.data[0] / n as f32;
            let ga: Vec<f32> = (0..n).map(|i| k * dphi(diff(&ops[0], &ops[1], i))).collect();
            let gb: Vec<f32> = ga.iter().map(|v| -v).collect();
            vec![need[0].then(|| reduce_to(&ops[0], &ga, c)), need[1].then(|| reduce_to(&ops[1], &gb, c))]
        }),
    )
}

/// Mean absolute difference (subgradient 0 where equal).
pub fn l1(a: &Tensor, b: &Tensor) -> Result<Tensor> {
    distance(
        "l1",
        Kind::Other,
        a,
        b,
        |d| d.abs() as f64,
        |d| {
            if d > 0.0 {
                1.0
            } else if d < 0.0 {
                -1.0
            } else {
                0.0
            }
        },
    )
}

/// Mean squared difference.
pub fn l2(a: &Tensor, b: &Tensor) -> Result<Tensor> {
    distance("l2", Kind::L2, a, b, |d| (d as f64) * (d as f64), |d| 2.0 * d)
}

/// Mean of √(d² + ε²) − ε: L2 near zero, L1 far away (robust to outliers, smooth at 0).
pub fn charbonnier(a: &Tensor, b: &Tensor, eps: f32) -> Result<Tensor> {
    if !(eps > 0.0 && eps.is_finite()) {
        return Err(Error::Invalid(format!("charbonnier: eps {eps} must be positive")));
    }
    let e = eps as f64;
    distance(
        "charbonnier",
        Kind::Other,
        a,
        b,
        move |d| ((d as f64).powi(2) + e * e).sqrt() - e,
        move |d| d / (d * d + eps * eps).sqrt(),
    )
}

/// Σ w·a / Σ w_b: the mean of a weighted by w, where w has one channel (broadcast over a's channels, each
/// weight counting once per channel) or a's channels. Gradient to both. Σ w must be positive.
pub fn weighted_mean(a: &Tensor, w: &Tensor) -> Result<Tensor> {
    let (va, vw) = (a.value(), w.value());
    let c = va.channels;
    let ok = (va.width, va.height) == (vw.width, vw.height) && (vw.channels == 1 || vw.channels == c);
    if !ok {
        return Err(Error::Invalid(format!("weighted_mean: weights {} do not fit values {}", vw.shape(), va.shape())));
    }
    let n = va.data.len();
    let wsum: f64 = (0..n).map(|i| vw.data[src_index(vw, i, c)] as f64).sum();
    if wsum.is_nan() || wsum <= 0.0 {
        return Err(Error::Invalid(format!("weighted_mean: the weights sum to {wsum} (an empty mask?)")));
    }
    let num: f64 = (0..n).map(|i| vw.data[src_index(vw, i, c)] as f64 * va.data[i] as f64).sum();
    let value = num / wsum;
    record(
        "weighted_mean",
        &[a, w],
        Image::scalar(value as f32),
        Kind::Other,
        Box::new(move |g, ops, need| {
            let (x, wt) = (&ops[0], &ops[1]);
            let k = g.data[0] as f64 / wsum;
            let ga =
                need[0].then(|| x.like((0..n).map(|i| (k * wt.data[src_index(wt, i, c)] as f64) as f32).collect()));
            let gw = need[1].then(|| {
                let per: Vec<f32> = (0..n).map(|i| (k * (x.data[i] as f64 - value)) as f32).collect();
                reduce_to(wt, &per, c)
            });
            vec![ga, gw]
        }),
    )
}

/// `weighted_mean` with a (fractional) mask as the weights: the mean of a over the mask.
pub fn masked_mean(a: &Tensor, mask: &Tensor) -> Result<Tensor> {
    weighted_mean(a, mask).map_err(|e| Error::Invalid(e.to_string().replacen("weighted_mean", "masked_mean", 1)))
}
