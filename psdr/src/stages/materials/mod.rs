//! The material stage: which photo pixels show which material (`material_segments`) and where the fitted scene is
//! not the photo's (`geometry_agreement`), albedos divided out of
//! the shading and the lights' common scale (`albedo_division`, or
//! scored from renders kept by bounce count: `light_scale_bounces`), the procedural library searched on a crop
//! (`material_search`, through `texture_view`) and fitted to it (`graph_fit`), and applied to the surfaces that
//! show a texture (`surface_textures`), registered on the surface's pixels (`texture_registration`) and fitted
//! there block by block (`aligned_graph_fit`); a retrieved model's own pictures go back on
//! its parts where they are closer to the photo than the fitted constant (`object_pictures`); a plane whose
//! texture the library does not reproduce takes the photo's own pattern (`photo_textures`); each wall gets a
//! material of its own, joined back where the photo shows them alike (`own_materials`); a segment whose
//! pixels a specular lobe reproduces clearly better than a matte surface gets one (`gloss_fit`).

mod albedo_division;
mod aligned_graph_fit;
mod geometry_agreement;
mod gloss_fit;
mod graph_fit;
mod light_scale_bounces;
mod material_search;
mod material_segments;
mod object_pictures;
mod offset_correlation;
mod own_materials;
mod photo_textures;
mod surface_textures;
mod texture_registration;
mod texture_view;

pub(crate) use albedo_division::ALBEDO_RANGE;
pub use albedo_division::{divide_albedos, search_light_scale, Division, LightScale, LightScaleOptions, Segment};
pub use geometry_agreement::{agreeing_blocks, geometry_agreement};
pub use gloss_fit::{fit_gloss, GlossCandidate, GlossChoice, GlossOptions};
pub use graph_fit::{fit_graph_to_crop, GraphFit, GraphFitOptions};
pub use material_search::{
    contrast, library_textures, search_materials, search_materials_on, search_materials_with, transformed_view,
    view_at, LibraryTexture, MaterialEncoder, MaterialMatch,
};
pub use material_segments::material_segments;
pub use object_pictures::{apply_object_pictures, ObjectPicture, ObjectPictureOptions};
pub use own_materials::{join_alike_materials, own_materials, JoinedMaterials, OwnMaterial};
pub use photo_textures::{apply_photo_textures, plane_map, PhotoTexture, PhotoTextureOptions, PlaneMap};
pub use surface_textures::{texture_surfaces, SurfaceTexture, SurfaceTextureOptions};
pub use texture_registration::{Registration, RegistrationOptions};
pub use texture_view::{texture_view, texture_view_backward, Mips, UvGrid};
