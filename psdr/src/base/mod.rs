//! What several layers share, below all of them: the image type, image files (EXR, PNG, written atomically),
//! the sRGB transfer function, rectangles in masks, connected regions, camera-space points from depth and
//! robust plane fits.
//! Depends on nothing but `error`.

mod atomic;
mod colour;
mod exr_io;
mod image;
mod plane_fit;
mod png_io;
mod point_cloud;
mod rect;
mod regions;

pub use atomic::write_atomically;
pub use colour::{linear_to_srgb, srgb_to_linear};
pub use exr_io::{read_exr_channels, read_exr_rgb, write_exr_channels};
pub use image::Image;
pub use plane_fit::{fit_plane, fit_plane_in_depth, ransac_plane, symmetric_eigen, Plane};
pub use png_io::write_png_srgb;
pub use point_cloud::{erode, surface_points, Intrinsics, SurfacePoint};
pub use rect::{largest_rect, mask_inside, squarest_rect, Rect};
pub use regions::connected_regions;
