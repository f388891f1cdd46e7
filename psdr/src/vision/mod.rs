//! Photo observations: the photo (`photo`, and where it clips: `clipping`), depth (`depth`, and whether it runs
//! the way its units say: `depth_direction`), instance segmentation with classes (`masks`,
//! `classes`), the field of view, and their resolution from flags and files beside the photo
//! (`observations`), and estimators for what is not given: ONNX models for depth, segmentation and fov
//! (`onnx_model` and one file per contract), the field of view from vanishing points (`line_segments`,
//! `vanishing_points`), and the room's box and camera: from depth and masks (`room_init`, the room stage's
//! start), or where relative depth is not affine in distance from the lines' frame and the masks' contacts
//! (`room_layout`, `frame_search`, chosen and the depth mapped onto it by `layout_calibration` and
//! `monotone_depth`).

mod classes;
mod clipping;
mod depth;
mod depth_calibration;
mod depth_direction;
mod frame_search;
mod layout_calibration;
mod line_segments;
mod masks;
mod monotone_depth;
mod observations;
mod onnx_depth;
mod onnx_embedding;
mod onnx_fov;
mod onnx_model;
mod onnx_segmentation;
mod photo;
mod room_init;
mod room_layout;
mod vanishing_points;
mod working_size;

pub use classes::{canonical_class, class_names, ClassKind, UNKNOWN_CLASS};
pub use clipping::{clip_like_photo, is_low_dynamic_range, unclipped, CLIPPED_LINEAR};
pub use depth::{load_depth, Depth, DepthUnits};
pub use depth_calibration::{calibrate_relative_depth, DepthCalibration, LayoutCheck};
pub use depth_direction::floor_depth_trend;
pub use frame_search::{search_frame, FrameChoice, FrameStart};
pub use layout_calibration::{check_against_layout, LayoutCalibration};
pub use line_segments::{detect_segments, Segment, SegmentOptions};
pub use masks::{load_instances, Instance, Instances};
pub use monotone_depth::{fit_monotone_depth, MonotoneDepth};
pub use observations::{ObservationInputs, Observations, DEFAULT_CAMERA_HEIGHT, DEFAULT_FOV_Y_DEG};
pub use onnx_depth::estimate_depth;
pub use onnx_embedding::{cosine, embed, load_embedding_model, CLIP_IMAGE_FILE};
pub use onnx_fov::estimate_fov_onnx;
pub use onnx_model::{resize_bilinear, InputContract, ModelOutput, OnnxModel};
pub use onnx_segmentation::{estimate_instances, ADE20K_CLASSES};
pub use photo::load_photo;
pub use room_init::{init_room, RoomEstimate, RoomInitOptions};
pub use room_layout::{box_mask_iou, box_view, estimate_axes, layout_room, BoxSurface, LayoutEvidence, LayoutOptions};
pub use vanishing_points::{
    estimate_fov, estimate_frame, FovEstimate, FovFailure, ManhattanFrame, VanishingOptions, VanishingPoint,
};
pub use working_size::{photo_at, working_size, WORKING_MULTIPLE};
