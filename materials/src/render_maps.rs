//! The renderer-facing maps (linear albedo, roughness, tangent-space normal,
//! optional height) and the first link of the backward chain from them.

use crate::graph::OutputNodes;
use crate::image::Image;
use rayon::prelude::*;

/// Maps for the renderer: row-major, row 0 = top of the image, f32.
#[derive(Clone, Debug)]
pub struct RenderMaps {
    pub size: usize,
    /// Linear RGB albedo, N*N*3 (sRGB base colour clamped to 0..1 and linearised).
    pub albedo_linear: Vec<f32>,
    /// Roughness in 0..1, N*N.
    pub roughness: Vec<f32>,
    /// Unit tangent-space normals, N*N*3: +z out, x along +u, y along +v (up the image).
    pub normal: Vec<f32>,
    /// Height in 0..1 when the graph exposes one, N*N.
    pub height: Option<Vec<f32>>,
}

/// dL/d(maps) from the renderer's adjoint; `None` means zero.
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderGrads<'a> {
    pub albedo_linear: Option<&'a [f32]>,
    pub roughness: Option<&'a [f32]>,
    pub normal: Option<&'a [f32]>,
    pub height: Option<&'a [f32]>,
}

/// sRGB transfer function (decode) and its derivative.
#[inline]
pub fn srgb_to_linear(c: f64) -> (f64, f64) {
    if c <= 0.04045 {
        (c / 12.92, 1.0 / 12.92)
    } else {
        let b = (c + 0.055) / 1.055;
        (b.powf(2.4), 2.4 / 1.055 * b.powf(1.4))
    }
}

pub(crate) fn fill_maps(
    maps: &mut RenderMaps,
    base: &Image,
    rough: &Image,
    normal: Option<&Image>,
    height: Option<&Image>,
) {
    let bc = base.channels;
    maps.albedo_linear.par_chunks_mut(3).enumerate().for_each(|(i, t)| {
        for (c, v) in t.iter_mut().enumerate() {
            let s = base.data[i * bc + if bc == 1 { 0 } else { c }];
            *v = srgb_to_linear(s.clamp(0.0, 1.0)).0 as f32;
        }
    });
    maps.roughness.par_iter_mut().zip(rough.data.par_iter()).for_each(|(r, &v)| *r = v.clamp(0.0, 1.0) as f32);
    match normal {
        Some(nm) => maps.normal.par_iter_mut().zip(nm.data.par_iter()).for_each(|(r, &v)| *r = v as f32),
        None => maps.normal.par_chunks_mut(3).for_each(|t| t.copy_from_slice(&[0.0, 0.0, 1.0])),
    }
    if let (Some(h), Some(dst)) = (height, maps.height.as_mut()) {
        dst.par_iter_mut().zip(h.data.par_iter()).for_each(|(r, &v)| *r = v as f32);
    }
}

fn check_len(name: &str, got: usize, want: usize) {
    assert_eq!(got, want, "RenderGrads::{name} has {got} values, expected {want}");
}

/// Adds the gradient arriving at output node `k` from the maps it feeds.
pub(crate) fn seed(k: usize, o: OutputNodes, g: &RenderGrads, img: &Image, grad: &mut Image) {
    let n2 = img.size * img.size;
    if k == o.base_color {
        if let Some(ga) = g.albedo_linear {
            check_len("albedo_linear", ga.len(), n2 * 3);
            let ch = img.channels;
            grad.data.par_chunks_mut(ch).enumerate().for_each(|(i, d)| {
                for c in 0..3 {
                    let s = img.data[i * ch + if ch == 1 { 0 } else { c }];
                    // Clamped outside [0, 1]: zero derivative there (one-sided at
                    // the bounds, so a value resting on a bound can move back).
                    if (0.0..=1.0).contains(&s) {
                        d[if ch == 1 { 0 } else { c }] += ga[i * 3 + c] as f64 * srgb_to_linear(s).1;
                    }
                }
            });
        }
    }
    if k == o.roughness {
        if let Some(gr) = g.roughness {
            check_len("roughness", gr.len(), n2);
            grad.data.par_iter_mut().enumerate().for_each(|(i, d)| {
                let s = img.data[i];
                if (0.0..=1.0).contains(&s) {
                    *d += gr[i] as f64;
                }
            });
        }
    }
    if Some(k) == o.normal {
        if let Some(gn) = g.normal {
            check_len("normal", gn.len(), n2 * 3);
            grad.data.par_iter_mut().zip(gn.par_iter()).for_each(|(d, &v)| *d += v as f64);
        }
    }
    if Some(k) == o.height {
        if let Some(gh) = g.height {
            check_len("height", gh.len(), n2);
            grad.data.par_iter_mut().zip(gh.par_iter()).for_each(|(d, &v)| *d += v as f64);
        }
    }
}
