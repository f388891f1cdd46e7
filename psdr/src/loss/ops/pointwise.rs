//! Elementwise ops with broadcasting: a 1x1x1 scalar against anything, a 1-channel image against a C-channel
//! image of the same size. Backward sums each output gradient into the operand element it came from.

use crate::base::Image;
use crate::error::{Error, Result};
use crate::loss::tape::{record, Kind, Tensor};

/// The output shape of a broadcast between two shapes, or an error naming the op.
pub(crate) fn broadcast_shape(op: &str, a: &Image, b: &Image) -> Result<(usize, usize, usize)> {
    let (sa, sb) = ((a.width, a.height, a.channels), (b.width, b.height, b.channels));
    if sa == sb || b.is_scalar() {
        return Ok(sa);
    }
    if a.is_scalar() {
        return Ok(sb);
    }
    if (a.width, a.height) == (b.width, b.height) && (a.channels == 1 || b.channels == 1) {
        return Ok((a.width, a.height, a.channels.max(b.channels)));
    }
    Err(Error::Invalid(format!("{op}: shapes {} and {} differ (and do not broadcast)", a.shape(), b.shape())))
}

/// Index of output element i (pixel-major, `out_c` channels) in an operand of shape `x`.
#[inline]
pub(crate) fn src_index(x: &Image, i: usize, out_c: usize) -> usize {
    if x.is_scalar() {
        0
    } else if x.channels == 1 && out_c > 1 {
        i / out_c
    } else {
        i
    }
}

/// Sums a gradient of the output shape back into an operand's shape.
pub(crate) fn reduce_to(x: &Image, g: &[f32], out_c: usize) -> Image {
    if x.data.len() == g.len() {
        return x.like(g.to_vec());
    }
    let mut r = vec![0.0f32; x.data.len()];
    for (i, v) in g.iter().enumerate() {
        r[src_index(x, i, out_c)] += v;
    }
    x.like(r)
}

/// A binary elementwise op: value f(a, b), partial derivatives (da, db) at (a, b).
fn binary(
    op: &'static str,
    kind: Kind,
    a: &Tensor,
    b: &Tensor,
    f: fn(f32, f32) -> f32,
    d: fn(f32, f32) -> (f32, f32),
) -> Result<Tensor> {
    let (va, vb) = (a.value(), b.value());
    let (w, h, c) = broadcast_shape(op, va, vb)?;
    let n = w * h * c;
    let data = (0..n).map(|i| f(va.data[src_index(va, i, c)], vb.data[src_index(vb, i, c)])).collect();
    let value = Image { width: w, height: h, channels: c, data };
    record(
        op,
        &[a, b],
        value,
        kind,
        Box::new(move |g, ops, need| {
            let (x, y) = (&ops[0], &ops[1]);
            let mut ga = vec![0.0f32; g.data.len()];
            let mut gb = vec![0.0f32; g.data.len()];
            for (i, gi) in g.data.iter().enumerate() {
                let (da, db) = d(x.data[src_index(x, i, c)], y.data[src_index(y, i, c)]);
                ga[i] = gi * da;
                gb[i] = gi * db;
            }
            vec![need[0].then(|| reduce_to(x, &ga, c)), need[1].then(|| reduce_to(y, &gb, c))]
        }),
    )
}

/// A unary elementwise op: value f(a), derivative d(a).
fn unary(
    op: &'static str,
    kind: Kind,
    a: &Tensor,
    f: impl Fn(f32) -> f32,
    d: impl Fn(f32) -> f32 + 'static,
) -> Result<Tensor> {
    let va = a.value();
    let value = va.like(va.data.iter().map(|&x| f(x)).collect());
    record(
        op,
        &[a],
        value,
        kind,
        Box::new(move |g, ops, _| {
            vec![Some(ops[0].like(g.data.iter().zip(&ops[0].data).map(|(g, &x)| g * d(x)).collect()))]
        }),
    )
}

pub fn add(a: &Tensor, b: &Tensor) -> Result<Tensor> {
    binary("add", Kind::Add, a, b, |x, y| x + y, |_, _| (1.0, 1.0))
}

pub fn sub(a: &Tensor, b: &Tensor) -> Result<Tensor> {
    binary("sub", Kind::Sub, a, b, |x, y| x - y, |_, _| (1.0, -1.0))
}

pub fn mul(a: &Tensor, b: &Tensor) -> Result<Tensor> {
    binary("mul", Kind::Mul, a, b, |x, y| x * y, |x, y| (y, x))
}

/// Elementwise quotient; a zero divisor is an error (never an infinite loss).
pub fn div(a: &Tensor, b: &Tensor) -> Result<Tensor> {
    if let Some(i) = b.value().data.iter().position(|&v| v == 0.0) {
        return Err(Error::Invalid(format!("div: divisor element {i} is zero")));
    }
    binary("div", Kind::Div, a, b, |x, y| x / y, |x, y| (1.0 / y, -x / (y * y)))
}

pub fn neg(a: &Tensor) -> Result<Tensor> {
    unary("neg", Kind::Neg, a, |x| -x, |_| -1.0)
}

pub fn scale(a: &Tensor, k: f32) -> Result<Tensor> {
    if !k.is_finite() {
        return Err(Error::Invalid(format!("scale: factor {k} is not finite")));
    }
    unary("scale", Kind::Scale(k), a, move |x| x * k, move |_| k)
}

pub fn sqr(a: &Tensor) -> Result<Tensor> {
    unary("sqr", Kind::Other, a, |x| x * x, |x| 2.0 * x)
}

/// |a|, with subgradient 0 at 0.
pub fn abs(a: &Tensor) -> Result<Tensor> {
    unary("abs", Kind::Other, a, f32::abs, |x| {
        if x > 0.0 {
            1.0
        } else if x < 0.0 {
            -1.0
        } else {
            0.0
        }
    })
}

/// √a; negative input is an error. At 0 the derivative is infinite: it is taken as 0 there (a loss over a
/// region that is exactly zero gets no push from it rather than an infinite one).
pub fn sqrt(a: &Tensor) -> Result<Tensor> {
    if let Some(i) = a.value().data.iter().position(|&v| v < 0.0) {
        return Err(Error::Invalid(format!("sqrt: element {i} is negative ({})", a.value().data[i])));
    }
    unary("sqrt", Kind::Other, a, f32::sqrt, |x| if x > 0.0 { 0.5 / x.sqrt() } else { 0.0 })
}
