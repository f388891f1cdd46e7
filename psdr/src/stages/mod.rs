//! Pipeline stages (PSDR-Room's Method), the parts scripts call: the room stage's initialisation from depth and
//! segmentation (`room_init`, `depth_calibration`, geometry in `point_cloud` and `plane_fit`) and the room as a
//! scene (`room_scene`); the object stage's merging of split instances (`instance_merge`), retrieval and
//! placement (`object_init`, with `pose_search` and `object_support`); the light stage's initial lights
//! (`light_init`, and `window_lights` for the windows the photo shows) radiance fit (`light_fit`) and their
//! positions and sizes (`light_placement`); albedos divided out of the shading and the lights'
//! scale that only interreflections fix (`albedo_division`); which photo pixels show which material (`material_segments`); the material search over the
//! procedural library (`material_search`) and its
//! application to the surfaces a photo shows (`surface_textures`); and a fitted scene's errors against a
//! ground truth (`evaluation`).

mod albedo_division;
mod depth_calibration;
mod evaluation;
mod graph_fit;
mod instance_merge;
mod light_fit;
mod light_init;
mod light_placement;
mod material_search;
mod material_segments;
mod object_init;
mod object_support;
mod plane_fit;
mod point_cloud;
mod pose_search;
mod room_init;
mod room_scene;
mod surface_textures;
mod texture_view;
mod window_lights;

pub use albedo_division::{divide_albedos, search_light_scale, LightScale, LightScaleOptions, Segment};
pub use depth_calibration::{calibrate_relative_depth, DepthCalibration};
pub use evaluation::{evaluate, mask_ious, relative_rmse_downsampled, room_in_camera_frame, ssim_luminance, Merged};
pub use graph_fit::{fit_graph_to_crop, GraphFit, GraphFitOptions};
pub use instance_merge::{merge_split_instances, MergedInstance};
pub use light_fit::{fit_lights, nnls, LightFit, LightFitOptions};
pub use light_init::{init_lights, LightInitOptions};
pub use light_placement::{refine_light_placement, LightPlacement, LightPlacementOptions};
pub use material_search::{
    contrast, library_textures, search_materials, search_materials_on, search_materials_with, transformed_view,
    view_at, LibraryTexture, MaterialEncoder, MaterialMatch,
};
pub use material_segments::material_segments;
pub use object_init::{
    init_objects, init_objects_with, missing_classes, AppearanceCue, Candidate, ObjectInitOptions, ObjectPlacement,
    SkippedInstance,
};
pub use plane_fit::{fit_plane, fit_plane_in_depth, ransac_plane, symmetric_eigen, Plane};
pub use point_cloud::{erode, surface_points, Intrinsics, SurfacePoint};
pub use room_init::{init_room, RoomEstimate, RoomInitOptions};
pub use room_scene::{room_scene, room_summary, ROOM_SURFACES};
pub use surface_textures::{texture_surfaces, SurfaceTexture, SurfaceTextureOptions};
pub use texture_view::{texture_view, texture_view_backward, Mips, UvGrid};
pub use window_lights::add_visible_windows;
