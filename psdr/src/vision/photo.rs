//! The photo: PNG, JPEG or EXR, EXIF orientation applied (phones store portrait shots rotated), sRGB decoded
//! to linear RGB (EXR is linear already).

use crate::base::Image;
use crate::error::{Error, Result};
use crate::scene::srgb_to_linear;
use image::ImageDecoder;
use std::path::Path;

/// The photo as linear RGB.
pub fn load_photo(path: &Path) -> Result<Image> {
    if !path.is_file() {
        return Err(Error::io(path, "photo not found"));
    }
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if ext == "exr" {
        let (w, h, data) = crate::base::read_exr_rgb(path)?;
        return Image::new(w as usize, h as usize, 3, data).map_err(|e| Error::io(path, e));
    }
    let reader = image::ImageReader::open(path).map_err(|e| Error::io(path, e))?;
    let reader = reader.with_guessed_format().map_err(|e| Error::io(path, e))?;
    let mut decoder = reader.into_decoder().map_err(|e| Error::io(path, format!("not a readable image: {e}")))?;
    let orientation = decoder.orientation().map_err(|e| Error::io(path, e))?;
    let mut img = image::DynamicImage::from_decoder(decoder).map_err(|e| Error::io(path, e))?;
    img.apply_orientation(orientation);
    let rgb = img.to_rgb32f();
    let (w, h) = rgb.dimensions();
    Image::new(w as usize, h as usize, 3, rgb.into_raw().into_iter().map(srgb_to_linear).collect())
        .map_err(|e| Error::io(path, e))
}
