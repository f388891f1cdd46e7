//! Mask statistics: the mean colour of a region and the soft IoU of two anti-aliased masks.

use crate::base::Image;
use crate::error::{Error, Result};
use crate::loss::tape::{record, Kind, Tensor};

fn check_mask(op: &str, img: &Image, mask: &Image) -> Result<()> {
    if (img.width, img.height) != (mask.width, mask.height) || mask.channels != 1 {
        return Err(Error::Invalid(format!(
            "{op}: the mask {} must be one channel of the image's size {}",
            mask.shape(),
            img.shape()
        )));
    }
    Ok(())
}

/// 1 x 1 x C: per channel Σ m·I / Σ m over a (fractional) mask. Gradient to the image and the mask.
pub fn mean_color(img: &Tensor, mask: &Tensor) -> Result<Tensor> {
    let (vi, vm) = (img.value(), mask.value());
    check_mask("mean_color", vi, vm)?;
    let c = vi.channels;
    let msum: f64 = vm.data.iter().map(|&m| m as f64).sum();
    if msum.is_nan() || msum <= 0.0 {
        return Err(Error::Invalid("mean_color: the mask is empty".into()));
    }
    let mut mean = vec![0.0f64; c];
    for (p, &m) in vm.data.iter().enumerate() {
        for (k, acc) in mean.iter_mut().enumerate() {
            *acc += m as f64 * vi.data[p * c + k] as f64;
        }
    }
    mean.iter_mut().for_each(|v| *v /= msum);
    let value = Image { width: 1, height: 1, channels: c, data: mean.iter().map(|&v| v as f32).collect() };
    record(
        "mean_color",
        &[img, mask],
        value,
        Kind::Other,
        Box::new(move |g, ops, need| {
            let (x, m) = (&ops[0], &ops[1]);
            let gi = need[0].then(|| {
                x.like((0..x.data.len()).map(|i| (g.data[i % c] as f64 * m.data[i / c] as f64 / msum) as f32).collect())
            });
            let gm = need[1].then(|| {
                m.like(
                    (0..m.data.len())
                        .map(|p| {
                            let s: f64 = (0..c).map(|k| g.data[k] as f64 * (x.data[p * c + k] as f64 - mean[k])).sum();
                            (s / msum) as f32
                        })
                        .collect(),
                )
            });
            vec![gi, gm]
        }),
    )
}

/// Σ a·b / Σ (a + b − a·b) of two 1-channel masks with values in [0, 1] (fractional pixels, as PSDR-Room's
/// IoU). Two empty masks agree: IoU 1 with zero gradient.
pub fn soft_iou(a: &Tensor, b: &Tensor) -> Result<Tensor> {
    let (va, vb) = (a.value(), b.value());
    if !va.same_shape(vb) || va.channels != 1 {
        return Err(Error::Invalid(format!(
            "soft_iou: masks {} and {} must be one channel of one size",
            va.shape(),
            vb.shape()
        )));
    }
    let (mut inter, mut union) = (0.0f64, 0.0f64);
    for (&x, &y) in va.data.iter().zip(&vb.data) {
        inter += x as f64 * y as f64;
        union += x as f64 + y as f64 - x as f64 * y as f64;
    }
    let empty = union <= 0.0;
    let value = if empty { 1.0 } else { inter / union };
    record(
        "soft_iou",
        &[a, b],
        Image::scalar(value as f32),
        Kind::Other,
        Box::new(move |g, ops, need| {
            let (x, y) = (&ops[0], &ops[1]);
            let k = g.data[0] as f64;
            // d(I/U)/dx_i = (y_i U − I (1 − y_i)) / U²
            let d = |own: &Image, other: &Image| {
                own.like(
                    (0..own.data.len())
                        .map(|i| {
                            if empty {
                                return 0.0;
                            }
                            let o = other.data[i] as f64;
                            (k * (o * union - inter * (1.0 - o)) / (union * union)) as f32
                        })
                        .collect(),
                )
            };
            vec![need[0].then(|| d(x, y)), need[1].then(|| d(y, x))]
        }),
    )
}
