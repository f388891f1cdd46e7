//! Loss ops in scripts: every op of `crate::loss` under its own name, arithmetic operators on tensors and
//! numbers, and the crop strategies. A loss closure composes these; each call is recorded on the iteration's
//! tape when one of its inputs is a rendered output.

use super::api_support::{rhai_err, Rr};
use super::crops::{largest_rect, load_rects, random_crops, Rect};
use crate::error::Error;
use crate::loss::{self, Tensor};
use rhai::{Array, Dynamic, Engine, Map};
use std::path::Path;

fn usize_arg(v: i64, what: &str) -> Rr<usize> {
    usize::try_from(v).map_err(|_| rhai_err(Error::Invalid(format!("{what} must not be negative, got {v}"))))
}

fn rect_map(r: Rect) -> Dynamic {
    let mut m = Map::new();
    for (k, v) in [("x", r.x), ("y", r.y), ("w", r.w), ("h", r.h)] {
        m.insert(k.into(), Dynamic::from_int(v as i64));
    }
    Dynamic::from_map(m)
}

fn map_rect(m: &Map) -> Rr<Rect> {
    let get = |k: &str| -> Rr<usize> {
        let v = m.get(k).and_then(|v| v.as_int().ok()).ok_or_else(|| {
            rhai_err(Error::Invalid(format!("a crop rectangle needs integer fields x, y, w, h; '{k}' is missing")))
        })?;
        usize_arg(v, k)
    };
    Ok(Rect { x: get("x")?, y: get("y")?, w: get("w")?, h: get("h")? })
}

fn scalar(v: f64) -> Tensor {
    Tensor::scalar(v as f32)
}

macro_rules! binary_ops {
    ($engine:ident, $($op:literal => $f:path),*) => {$(
        $engine.register_fn($op, |a: Tensor, b: Tensor| $f(&a, &b).map_err(rhai_err));
        $engine.register_fn($op, |a: Tensor, b: f64| $f(&a, &scalar(b)).map_err(rhai_err));
        $engine.register_fn($op, |a: f64, b: Tensor| $f(&scalar(a), &b).map_err(rhai_err));
        $engine.register_fn($op, |a: Tensor, b: i64| $f(&a, &scalar(b as f64)).map_err(rhai_err));
        $engine.register_fn($op, |a: i64, b: Tensor| $f(&scalar(a as f64), &b).map_err(rhai_err));
    )*};
}

macro_rules! unary_fns {
    ($engine:ident, $($name:literal => $f:path),*) => {$(
        $engine.register_fn($name, |a: Tensor| $f(&a).map_err(rhai_err));
    )*};
}

macro_rules! binary_fns {
    ($engine:ident, $($name:literal => $f:path),*) => {$(
        $engine.register_fn($name, |a: Tensor, b: Tensor| $f(&a, &b).map_err(rhai_err));
    )*};
}

pub fn register(engine: &mut Engine) {
    engine.register_type_with_name::<Tensor>("Tensor");
    binary_ops!(engine, "+" => loss::add, "-" => loss::sub, "*" => loss::mul, "/" => loss::div);
    engine.register_fn("-", |a: Tensor| loss::neg(&a).map_err(rhai_err));
    unary_fns!(engine, "sqr" => loss::sqr, "abs" => loss::abs, "sqrt" => loss::sqrt, "sum" => loss::sum,
        "mean" => loss::mean, "normalize" => loss::normalize, "texture_descriptor" => loss::texture_descriptor);
    binary_fns!(engine, "l1" => loss::l1, "l2" => loss::l2, "weighted_mean" => loss::weighted_mean,
        "masked_mean" => loss::masked_mean, "mean_color" => loss::mean_color, "soft_iou" => loss::soft_iou,
        "normalize_in" => loss::normalize_in, "texture_loss" => loss::texture_loss);
    engine.register_fn("charbonnier", |a: Tensor, b: Tensor, eps: f64| {
        loss::charbonnier(&a, &b, eps as f32).map_err(rhai_err)
    });
    engine.register_fn("scale", |a: Tensor, k: f64| loss::scale(&a, k as f32).map_err(rhai_err));
    for name in ["down", "downsample"] {
        engine.register_fn(name, |a: Tensor, k: i64| {
            loss::downsample(&a, usize_arg(k, "downsample factor")?).map_err(rhai_err)
        });
    }
    engine.register_fn("blur", |a: Tensor, sigma: f64| loss::blur(&a, sigma as f32).map_err(rhai_err));
    engine.register_fn("pyramid", |a: Tensor, levels: i64| -> Rr<Array> {
        let v = loss::gaussian_pyramid(&a, usize_arg(levels, "pyramid levels")?).map_err(rhai_err)?;
        Ok(v.into_iter().map(Dynamic::from).collect())
    });
    engine.register_fn("crop", |a: Tensor, x: i64, y: i64, w: i64, h: i64| -> Rr<Tensor> {
        let (x, y, w, h) = (usize_arg(x, "x")?, usize_arg(y, "y")?, usize_arg(w, "w")?, usize_arg(h, "h")?);
        loss::crop(&a, x, y, w, h).map_err(rhai_err)
    });
    engine.register_fn("crop", |a: Tensor, r: Map| -> Rr<Tensor> {
        let r = map_rect(&r)?;
        loss::crop(&a, r.x, r.y, r.w, r.h).map_err(rhai_err)
    });
    engine.register_fn("item", |a: &mut Tensor| -> Rr<f64> {
        a.item().map(|v| v as f64).ok_or_else(|| {
            let v = a.value();
            rhai_err(Error::Invalid(format!("item: a {}x{}x{} image is not a scalar", v.width, v.height, v.channels)))
        })
    });
    // The values of a small tensor (a mean colour, a descriptor) as numbers, row by row, channels interleaved.
    engine.register_fn("values", |a: &mut Tensor| -> Rr<Array> {
        let v = a.value();
        if v.data.len() > 65536 {
            return Err(rhai_err(Error::Invalid(format!(
                "values: a {}x{}x{} image is too large to list (at most 65536 numbers)",
                v.width, v.height, v.channels
            ))));
        }
        Ok(v.data.iter().map(|&x| Dynamic::from(x as f64)).collect())
    });
    engine.register_get("width", |a: &mut Tensor| a.value().width as i64);
    engine.register_get("height", |a: &mut Tensor| a.value().height as i64);
    engine.register_get("channels", |a: &mut Tensor| a.value().channels as i64);
    engine.register_fn("to_string", |a: &mut Tensor| match a.item() {
        Some(v) => format!("{v}"),
        None => {
            let v = a.value();
            format!("Tensor({}x{}x{})", v.width, v.height, v.channels)
        }
    });
    engine.register_fn("constant", |v: f64| scalar(v));

    // Crop strategies.
    engine.register_fn("largest_rect", |mask: Tensor| -> Rr<Dynamic> {
        Ok(largest_rect(mask.value()).map_err(rhai_err)?.map_or(Dynamic::UNIT, rect_map))
    });
    engine.register_fn("random_crops", |mask: Tensor, k: i64, w: i64, h: i64, seed: i64| -> Rr<Array> {
        let r = random_crops(mask.value(), usize_arg(k, "k")?, usize_arg(w, "w")?, usize_arg(h, "h")?, seed as u64)
            .map_err(rhai_err)?;
        Ok(r.into_iter().map(rect_map).collect())
    });
    engine.register_fn("load_rects", |path: &str| -> Rr<Array> {
        Ok(load_rects(Path::new(path)).map_err(rhai_err)?.into_iter().map(rect_map).collect())
    });
}
