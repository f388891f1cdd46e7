//! Depth observations: camera-space z per pixel, from an EXR (its `Z`, `depth`, `Y` or only channel, else R)
//! or a 16-bit PNG (metres: millimetres stored; relative or disparity: 0..65535 mapped to 0..1). Metric depth
//! fixes the scene's scale; relative depth or disparity (unknown scale and shift, as monocular estimators give)
//! only its shape, once the shift is found (`calibrate_relative_depth` in depth_calibration.rs).
//! Pixels without depth are 0 (or negative, or infinite: sensors write those); NaN is an error, because it
//! means a broken file rather than a missing measurement.

use crate::base::Image;
use crate::error::{Error, Result};
use std::path::Path;

/// What the depth values mean.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DepthUnits {
    Metres,
    /// Affine in depth with an unknown scale and shift.
    Relative,
    /// Affine in inverse depth with an unknown scale and shift (larger = nearer), as monocular depth networks
    /// (Depth-Anything, DPT) give.
    Disparity,
}

impl std::str::FromStr for DepthUnits {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "metres" | "meters" | "m" => Ok(DepthUnits::Metres),
            "relative" => Ok(DepthUnits::Relative),
            "disparity" | "inverse" => Ok(DepthUnits::Disparity),
            _ => Err(format!(
                "depth units '{s}': metres, relative (affine in depth) or disparity (affine in inverse depth)"
            )),
        }
    }
}

/// A depth map: 1 channel, 0 where there is no measurement.
#[derive(Clone, Debug, PartialEq)]
pub struct Depth {
    pub image: Image,
    pub units: DepthUnits,
    /// Pixels without a measurement (set to 0).
    pub missing: usize,
}

pub fn load_depth(path: &Path, units: DepthUnits) -> Result<Depth> {
    if !path.is_file() {
        return Err(Error::io(path, "depth file not found"));
    }
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let (w, h, mut data) = if ext == "exr" {
        let (w, h, channels) = crate::output::read_exr_channels(path)?;
        let pick = ["Z", "depth", "Y"]
            .iter()
            .find_map(|n| channels.iter().find(|c| c.0 == *n))
            .or(if channels.len() == 1 { channels.first() } else { channels.iter().find(|c| c.0 == "R") })
            .ok_or_else(|| {
                let names: Vec<&str> = channels.iter().map(|c| c.0.as_str()).collect();
                Error::io(path, format!("no depth channel (Z, depth, Y, R or a single channel) among {names:?}"))
            })?;
        (w as usize, h as usize, pick.1.clone())
    } else {
        let img = image::open(path).map_err(|e| Error::io(path, e))?;
        if !matches!(img, image::DynamicImage::ImageLuma16(_)) {
            return Err(Error::io(path, "a PNG depth map must be 16-bit grey (millimetres, or 0..65535 relative)"));
        }
        let g = img.to_luma16();
        let (w, h) = g.dimensions();
        let scale = match units {
            DepthUnits::Metres => 1e-3,
            DepthUnits::Relative | DepthUnits::Disparity => 1.0 / 65535.0,
        };
        (w as usize, h as usize, g.into_raw().into_iter().map(|v| v as f32 * scale).collect())
    };
    if let Some(i) = data.iter().position(|v| v.is_nan()) {
        let n = data.iter().filter(|v| v.is_nan()).count();
        return Err(Error::io(path, format!("{n} depth values are NaN (first at pixel {}, {})", i % w, i / w)));
    }
    let mut missing = 0;
    for v in data.iter_mut() {
        if !(v.is_finite() && *v > 0.0) {
            *v = 0.0;
            missing += 1;
        }
    }
    if missing == data.len() {
        return Err(Error::io(path, "the depth map has no valid value (all zero, negative or infinite)"));
    }
    let image = Image::new(w, h, 1, data).map_err(|e| Error::io(path, e))?;
    Ok(Depth { image, units, missing })
}
