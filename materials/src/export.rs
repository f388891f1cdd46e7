//! Conversions of evaluated maps to 8/16-bit pixels and a lit preview.

use crate::evaluator::{Evaluator, MapKind};
use crate::render_maps::srgb_to_linear;

fn to_u8(x: f64) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

fn linear_to_srgb(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Base colour as 8-bit sRGB RGB.
pub fn base_color_rgb8(ev: &Evaluator) -> Vec<u8> {
    let img = ev.output_image(MapKind::BaseColor).expect("base colour");
    let n2 = img.size * img.size;
    (0..n2 * 3).map(|i| to_u8(img.data[if img.channels == 1 { i / 3 } else { i }])).collect()
}

/// Roughness as 8-bit grey.
pub fn roughness_gray8(ev: &Evaluator) -> Vec<u8> {
    ev.output_image(MapKind::Roughness).expect("roughness").data.iter().map(|&x| to_u8(x)).collect()
}

/// Normal encoded as RGB = 0.5 + 0.5 n (OpenGL convention, flat when absent).
pub fn normal_rgb8(ev: &Evaluator) -> Vec<u8> {
    let n2 = ev.size() * ev.size();
    match ev.output_image(MapKind::Normal) {
        Some(img) => img.data.iter().map(|&x| to_u8(0.5 + 0.5 * x)).collect(),
        None => (0..n2).flat_map(|_| [128, 128, 255]).collect(),
    }
}

/// Height as 16-bit grey, if the graph has one.
pub fn height_gray16(ev: &Evaluator) -> Option<Vec<u16>> {
    ev.output_image(MapKind::Height)
        .map(|img| img.data.iter().map(|&x| (x.clamp(0.0, 1.0) * 65535.0 + 0.5) as u16).collect())
}

/// A lit preview (8-bit sRGB RGB): Lambert plus a roughness-dependent highlight
/// from a light at the upper left, so relief and gloss show in thumbnails.
pub fn preview_rgb8(ev: &Evaluator) -> Vec<u8> {
    let base = ev.output_image(MapKind::BaseColor).expect("base colour");
    let rough = ev.output_image(MapKind::Roughness).expect("roughness");
    let normal = ev.output_image(MapKind::Normal);
    let n2 = base.size * base.size;
    let l = {
        let v: [f64; 3] = [-0.45, 0.55, 0.7];
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / len, v[1] / len, v[2] / len]
    };
    // Half vector between the light and a viewer straight above.
    let hv = {
        let v = [l[0], l[1], l[2] + 1.0];
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / len, v[1] / len, v[2] / len]
    };
    let mut out = Vec::with_capacity(n2 * 3);
    for i in 0..n2 {
        let nrm = normal.map_or([0.0, 0.0, 1.0], |im| [im.data[i * 3], im.data[i * 3 + 1], im.data[i * 3 + 2]]);
        let ndl = (nrm[0] * l[0] + nrm[1] * l[1] + nrm[2] * l[2]).max(0.0);
        let ndh = (nrm[0] * hv[0] + nrm[1] * hv[1] + nrm[2] * hv[2]).max(0.0);
        let r = rough.data[i].clamp(0.05, 1.0);
        let shininess = 2.0 / (r * r * r * r) - 2.0;
        let spec = 0.04 * (shininess + 2.0) / 8.0 * ndh.powf(shininess) * ndl;
        let shade = 0.35 + 0.85 * ndl / l[2];
        for c in 0..3 {
            let s = base.data[i * base.channels + if base.channels == 1 { 0 } else { c }];
            let lin = srgb_to_linear(s.clamp(0.0, 1.0)).0;
            out.push(to_u8(linear_to_srgb(lin * shade * 0.8 + spec.min(1.0))));
        }
    }
    out
}
