//! The field of view from an ONNX model (`fov.onnx` in the models folder). Output contract: the first output,
//! float32 with one element (`[1]` or `[1, 1]`), the vertical field of view in degrees. Camera-calibration
//! networks that predict a focal length in pixels or a horizontal fov are wrapped to this with a final ONNX
//! node (vertical fov = 2 atan(H / 2f)).

use super::onnx_model::OnnxModel;
use crate::base::Image;
use crate::error::{Error, Result};

pub fn estimate_fov_onnx(model: &mut OnnxModel, photo: &Image) -> Result<f32> {
    let out = model.run(photo)?;
    match out.data.as_slice() {
        [fov] if !out.integer && fov.is_finite() && *fov > 1.0 && *fov < 179.0 => Ok(*fov),
        [fov] => {
            Err(Error::io(&model.path, format!("the fov model gave {fov}, not a vertical fov in (1, 179) degrees")))
        }
        _ => Err(Error::io(
            &model.path,
            format!("a fov model's output must be one float32 (degrees), not shape {:?}", out.shape),
        )),
    }
}
