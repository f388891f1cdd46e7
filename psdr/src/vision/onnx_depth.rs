//! Monocular depth from an ONNX model (`depth.onnx` in the models folder). Output contract: the first output,
//! float32 `[1, h, w]` or `[1, 1, h, w]`, relative inverse depth (larger = nearer, any scale and shift), as
//! Depth-Anything and DPT give. It is resized to the photo (bilinear) and stored as `disparity`, mapped to
//! 0.01..1.01 (an affine change the unknown scale and shift absorb); the room stage finds the shift on the
//! room's planes and sets the scale by the camera-height prior.
//!
//! Exporting a public model: Depth-Anything-V2-Small (Apache-2.0) with
//! `torch.onnx.export(model, torch.randn(1, 3, 518, 518), "depth.onnx", input_names=["image"],
//! output_names=["depth"], opset_version=17)`; its preprocessing is this contract's.

use super::depth::{Depth, DepthUnits};
use super::onnx_model::{resize_bilinear, OnnxModel};
use crate::base::Image;
use crate::error::{Error, Result};

pub fn estimate_depth(model: &mut OnnxModel, photo: &Image) -> Result<Depth> {
    let out = model.run(photo)?;
    let (h, w) = match out.shape.as_slice() {
        [1, h, w] | [1, 1, h, w] if !out.integer => (*h, *w),
        s => {
            return Err(Error::io(
                &model.path,
                format!("a depth model's output must be float32 [1, h, w] or [1, 1, h, w], not {s:?}"),
            ))
        }
    };
    if let Some(i) = out.data.iter().position(|v| !v.is_finite()) {
        return Err(Error::io(&model.path, format!("the depth model gave a non-finite value at output index {i}")));
    }
    let (lo, hi) = out.data.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    if hi <= lo {
        return Err(Error::io(&model.path, "the depth model gave a constant map"));
    }
    let norm: Vec<f32> = out.data.iter().map(|v| (v - lo) / (hi - lo) + 0.01).collect();
    let data = resize_bilinear(&norm, w, h, 1, photo.width, photo.height);
    Ok(Depth { image: Image::new(photo.width, photo.height, 1, data)?, units: DepthUnits::Disparity, missing: 0 })
}
