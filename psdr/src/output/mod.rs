//! Writing images: linear EXR (named channels) and sRGB PNG, always to a temporary name then renamed,
//! so an interrupted run never leaves a half-written file.

mod frame_files;

pub use crate::base::{read_exr_channels, read_exr_rgb, write_atomically, write_exr_channels, write_png_srgb};
pub use frame_files::{check_frame_path, write_frame, Aov};
