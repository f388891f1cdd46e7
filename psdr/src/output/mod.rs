//! Writing images: linear EXR (named channels) and sRGB PNG, always to a temporary name then renamed,
//! so an interrupted run never leaves a half-written file.

mod atomic;
mod exr_io;
mod frame_files;
mod png_io;

pub use atomic::write_atomically;
pub use exr_io::{read_exr_channels, read_exr_rgb, write_exr_channels};
pub use frame_files::{write_frame, Aov};
pub use png_io::write_png_srgb;
