//! The room stage: the room box and camera from depth and segmentation (`room_init`), relative depth turned into metres
//! (`depth_calibration`), and the room as a scene (`room_scene`).

mod depth_calibration;
mod room_init;
mod room_scene;

pub use depth_calibration::{calibrate_relative_depth, DepthCalibration};
pub use room_init::{init_room, RoomEstimate, RoomInitOptions};
pub use room_scene::{room_scene, room_summary, ROOM_SURFACES};
