//! Pipeline stages (PSDR-Room's Method), the parts scripts call, in the order `scripts/room.rhai` runs them:
//! `room` (the box and camera from depth and segmentation), `objects` (retrieval and placement), `lights`
//! (candidates, radiance fit, placement), `materials` (albedo division, the light scale, procedural textures),
//! and `evaluation` (a fitted scene's errors against a ground truth). Each folder's mod.rs maps its files; what
//! the stages share with other layers (points from depth, robust planes, rectangles) is in `base`.

mod evaluation;
mod lights;
mod materials;
mod objects;
mod room;

pub use evaluation::{
    evaluate, image_error_by_surface, mask_ious, noise_and_bias, relative_rmse_downsampled, room_in_camera_frame,
    ssim_luminance, Merged,
};
pub use lights::{add_unseen_window, UnseenWindow, UnseenWindowOptions};
pub use lights::{
    add_visible_ceiling_lights, add_visible_windows, is_edge_ceiling_light, is_visible_ceiling_light, is_visible_light,
    is_visible_window,
};
pub use lights::{fit_light_outlines, LightOutline};
pub use lights::{fit_lights, nnls, Agreement, LightFit, LightFitOptions};
pub use lights::{fit_window_skies, WindowSky, WindowSkyOptions};
pub use lights::{init_lights, LightInitOptions};
pub use lights::{light_motion, LightMotion};
pub use lights::{refine_light_placement, LightPlacement, LightPlacementOptions};
pub use lights::{search_ceiling_height, CeilingSearch, CeilingSearchOptions};
pub use materials::{agreeing_blocks, geometry_agreement, material_segments};
pub use materials::{apply_object_pictures, ObjectPicture, ObjectPictureOptions};
pub use materials::{apply_photo_textures, plane_map, PhotoTexture, PhotoTextureOptions, PlaneMap};
pub use materials::{
    contrast, library_textures, search_materials, search_materials_on, search_materials_with, transformed_view,
    view_at, LibraryTexture, MaterialEncoder, MaterialMatch,
};
pub use materials::{divide_albedos, search_light_scale, Division, LightScale, LightScaleOptions, Segment};
pub use materials::{fit_gloss, GlossCandidate, GlossChoice, GlossOptions};
pub use materials::{fit_graph_to_crop, GraphFit, GraphFitOptions};
pub use materials::{join_alike_materials, own_materials, JoinedMaterials, OwnMaterial};
pub use materials::{texture_surfaces, Registration, RegistrationOptions, SurfaceTexture, SurfaceTextureOptions};
pub use materials::{texture_view, texture_view_backward, Mips, UvGrid};
pub use objects::{
    init_objects, init_objects_with, missing_classes, AppearanceCue, Candidate, ObjectInitOptions, ObjectPlacement,
    SkippedInstance,
};
pub use objects::{merge_split_instances, model_looks, MergedInstance};
pub use room::{box_mask_iou, box_view, estimate_axes, layout_room, BoxSurface, LayoutEvidence, LayoutOptions};
pub use room::{init_room, search_frame, FrameChoice, FrameStart, RoomEstimate, RoomInitOptions};
pub use room::{room_scene, room_summary, ROOM_SURFACES};
