//! A frame on disk: OUT.exr holds radiance; each requested AOV gets OUT.<aov>.exr; OUT.png is a preview.

use super::{write_exr_channels, write_png_srgb};
use crate::error::{Error, Result};
use crate::render::Frame;
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aov {
    Depth,
    Id,
    Mask,
    Normal,
    Albedo,
}

impl std::str::FromStr for Aov {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "depth" => Ok(Aov::Depth),
            "id" => Ok(Aov::Id),
            "mask" => Ok(Aov::Mask),
            "normal" => Ok(Aov::Normal),
            "albedo" => Ok(Aov::Albedo),
            _ => Err(format!("unknown AOV '{s}' (depth, id, mask, normal, albedo)")),
        }
    }
}

impl Aov {
    pub fn name(self) -> &'static str {
        match self {
            Aov::Depth => "depth",
            Aov::Id => "id",
            Aov::Mask => "mask",
            Aov::Normal => "normal",
            Aov::Albedo => "albedo",
        }
    }
}

fn split_rgb(v: &[f32]) -> [Vec<f32>; 3] {
    [0, 1, 2].map(|c| v.iter().skip(c).step_by(3).copied().collect())
}

fn rgb_channels(prefix: &str, v: &[f32]) -> Vec<(String, Vec<f32>)> {
    let [r, g, b] = split_rgb(v);
    vec![(format!("{prefix}R"), r), (format!("{prefix}G"), g), (format!("{prefix}B"), b)]
}

/// Path of an AOV file next to `out`: out.exr -> out.depth.exr.
pub fn aov_path(out: &Path, aov: &str) -> PathBuf {
    let stem = out.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
    out.with_file_name(format!("{stem}.{aov}.exr"))
}

/// Refuses an output path `write_frame` cannot write (checked before a render, not after it).
pub fn check_frame_path(out: &Path) -> Result<()> {
    let ext = out.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    match ext.as_str() {
        "exr" | "png" => Ok(()),
        _ => Err(Error::io(out, "output must end in .exr or .png")),
    }
}

/// Writes the frame. `out` ending in .exr gets the EXR set plus a PNG preview; .png gets the PNG only.
/// Returns every path written.
pub fn write_frame(out: &Path, frame: &Frame, aovs: &[Aov], object_names: &[String]) -> Result<Vec<PathBuf>> {
    check_frame_path(out)?;
    let (w, h) = (frame.width, frame.height);
    let ext = out.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let mut written = Vec::new();
    if ext == "exr" {
        write_exr_channels(out, w, h, &rgb_channels("", &frame.radiance))?;
        written.push(out.to_path_buf());
        let png = out.with_extension("png");
        write_png_srgb(&png, w, h, &frame.radiance)?;
        written.push(png);
    } else {
        write_png_srgb(out, w, h, &frame.radiance)?;
        written.push(out.to_path_buf());
    }
    for &aov in aovs {
        let channels = match aov {
            Aov::Depth => vec![("Z".to_string(), frame.depth.clone())],
            Aov::Normal => rgb_channels("", &frame.normal),
            Aov::Albedo => rgb_channels("", &frame.albedo),
            // Ids as floats (exact below 2^24); -1 marks background.
            Aov::Id => vec![(
                "id".to_string(),
                frame.object_id.iter().map(|&i| if i == u32::MAX { -1.0 } else { i as f32 }).collect(),
            )],
            Aov::Mask => (0..frame.object_count as usize)
                .map(|k| (object_names.get(k).cloned().unwrap_or_else(|| format!("object{k}")), frame.mask(k)))
                .collect(),
        };
        if channels.is_empty() {
            continue;
        }
        let p = aov_path(out, aov.name());
        write_exr_channels(&p, w, h, &channels)?;
        written.push(p);
    }
    Ok(written)
}
