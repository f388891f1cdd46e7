//! Geometry the room and object stages share: camera-space points from depth (`point_cloud`) and robust plane
//! fits (`plane_fit`).

mod plane_fit;
mod point_cloud;

pub use plane_fit::{fit_plane, fit_plane_in_depth, ransac_plane, symmetric_eigen, Plane};
pub use point_cloud::{erode, surface_points, Intrinsics, SurfacePoint};
