//! 8-bit sRGB PNG output of linear RGB (clamped; no tone mapping beyond an optional exposure).

use super::linear_to_srgb as to_srgb;
use super::write_atomically;
use crate::error::{Error, Result};
use std::path::Path;

pub fn write_png_srgb(path: &Path, width: u32, height: u32, rgb: &[f32]) -> Result<()> {
    let bytes: Vec<u8> = rgb.iter().map(|&c| (to_srgb(c).clamp(0.0, 1.0) * 255.0 + 0.5) as u8).collect();
    let img = image::RgbImage::from_raw(width, height, bytes).ok_or_else(|| Error::io(path, "image size mismatch"))?;
    write_atomically(path, |tmp| img.save_with_format(tmp, image::ImageFormat::Png).map_err(|e| Error::io(path, e)))
}
