//! The room stage: the room box and camera from depth and segmentation (`room_init`; relative depth is turned
//! into metres by `vision::calibrate_relative_depth` first) and the room as a scene (`room_scene`).

mod frame_search;
mod room_init;
mod room_layout;
mod room_scene;

pub use frame_search::{search_frame, FrameChoice, FrameStart};
pub use room_init::{init_room, RoomEstimate, RoomInitOptions};
pub use room_layout::{box_mask_iou, box_view, estimate_axes, layout_room, BoxSurface, LayoutEvidence, LayoutOptions};
pub use room_scene::{room_scene, room_summary, ROOM_SURFACES};
