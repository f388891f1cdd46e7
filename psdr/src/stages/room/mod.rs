//! The room stage: the room as a scene (`room_scene`) from the box and camera the observations estimate
//! (`vision::init_room` from depth and segmentation; where relative depth is not affine in distance, the
//! layout from lines and masks, `vision::layout_room`), re-exported here as the stage's starting points.

mod room_scene;

pub use crate::vision::{box_mask_iou, box_view, estimate_axes, init_room, layout_room, search_frame};
pub use crate::vision::{BoxSurface, FrameChoice, FrameStart, LayoutEvidence, LayoutOptions};
pub use crate::vision::{RoomEstimate, RoomInitOptions};
pub use room_scene::{room_scene, room_summary, ROOM_SURFACES};
