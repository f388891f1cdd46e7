//! Textures, stored as linear f32 texels (row 0 = top of the image), 1 or 3 channels.

use crate::base::srgb_to_linear;
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextureEncoding {
    /// 8-bit colour images holding colours: decoded from sRGB to linear.
    Srgb,
    /// Data (roughness, normal maps, EXR): used as stored.
    Linear,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Where it came from (for exports and messages); `None` for generated textures.
    pub path: Option<PathBuf>,
    pub width: u32,
    pub height: u32,
    pub channels: u32,
    pub texels: Vec<f32>,
}

impl Texture {
    /// Loads PNG/JPG (8/16-bit; colour decoded per `encoding`) or EXR (always linear).
    /// `channels` is 3 for colour parameters and 1 for scalar ones.
    pub fn load(path: &Path, encoding: TextureEncoding, channels: u32) -> Result<Texture> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        let (width, height, rgb) = if ext == "exr" {
            crate::base::read_exr_rgb(path)?
        } else {
            let img = image::open(path).map_err(|e| Error::io(path, e))?;
            let rgb = img.to_rgb32f();
            let (w, h) = rgb.dimensions();
            let decode = |c: f32| match encoding {
                TextureEncoding::Srgb => srgb_to_linear(c),
                TextureEncoding::Linear => c,
            };
            (w, h, rgb.into_raw().into_iter().map(decode).collect())
        };
        if width == 0 || height == 0 {
            return Err(Error::io(path, "image has zero size"));
        }
        if let Some(bad) = rgb.iter().position(|v: &f32| !v.is_finite()) {
            return Err(Error::io(path, format!("texel {} is not finite", bad / 3)));
        }
        let texels = if channels == 1 { rgb.chunks_exact(3).map(|c| c[0]).collect() } else { rgb };
        Ok(Texture { path: Some(path.to_path_buf()), width, height, channels, texels })
    }
}
