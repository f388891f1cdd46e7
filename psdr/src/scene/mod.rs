//! The in-memory scene: camera, objects (mesh parts + pose), materials, textures, emitters, render settings.
//! Every stage reads and writes one `Scene`; `file` is its JSON form, `load` turns one into the other.

mod auto_smooth;
mod camera;
mod compare;
pub mod file;
mod load;
mod material;
mod mesh;
mod obj;
mod obj_write;
mod param_path;
mod pose;
mod primitives;
mod procedural;
mod room_box;
mod save;
mod texture;
mod unseen_triangles;
pub mod validate;
mod weld;

pub use auto_smooth::auto_smooth;
pub use camera::Camera;
pub use compare::{same_parts, same_scene, same_triangles};
pub use load::load_scene;
pub use material::{Color, Material, ModelLook, Scalar, UvTransform};
pub use mesh::{Emitter, MeshPart, Object};
pub use obj::{load_obj, MtlMaterial, ObjMesh};
pub use obj_write::{obj_text, written_names, ObjText};
pub use param_path::{ParamPath, TextureSlot};
pub use pose::Pose;
pub use primitives::{box_mesh, rectangle_mesh, sphere_mesh};
pub use procedural::Procedural;
pub use room_box::{keep_inside_walls, object_bounds, room_box};
pub use save::save_scene;
pub use unseen_triangles::{drop_unseen_triangles, UnseenTriangles};
pub use weld::{weld, Welding};

pub use crate::base::{linear_to_srgb as texture_linear_to_srgb, srgb_to_linear};
pub use texture::{Texture, TextureEncoding};

use std::path::PathBuf;

/// Sampling settings of a render.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub spp: u32,
    /// Longest path in vertices after the camera (Mitsuba's convention: 1 = emitters seen directly,
    /// 2 = direct lighting, ...).
    pub max_depth: u32,
    /// Depth at which Russian roulette starts.
    pub rr_depth: u32,
    pub seed: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings { spp: 16, max_depth: 5, rr_depth: 3, seed: 0 }
    }
}

#[derive(Clone, Debug)]
pub struct Scene {
    pub camera: Camera,
    pub settings: RenderSettings,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub objects: Vec<Object>,
    /// The file this scene came from, if any (relative asset paths of exports resolve against it).
    pub source: Option<PathBuf>,
    /// Parameters marked as requiring gradients.
    pub requires_grad: Vec<ParamPath>,
}

impl Scene {
    /// A scene with only a camera: default render settings, nothing in it.
    pub fn empty(camera: Camera) -> Scene {
        Scene {
            camera,
            settings: RenderSettings::default(),
            materials: vec![],
            textures: vec![],
            objects: vec![],
            source: None,
            requires_grad: vec![],
        }
    }

    pub fn object_index(&self, name: &str) -> Option<usize> {
        self.objects.iter().position(|o| o.name == name)
    }
    pub fn material_index(&self, name: &str) -> Option<usize> {
        self.materials.iter().position(|m| m.name == name)
    }
    pub fn triangle_count(&self) -> usize {
        self.objects.iter().flat_map(|o| &o.parts).map(|p| p.indices.len()).sum()
    }

    /// Makes material `m`'s albedo the procedural graph `p` baked (into its texture if it already has one of
    /// its own from a graph, else a new one).
    pub fn set_procedural(&mut self, m: usize, p: Procedural) -> crate::Result<()> {
        let texture = p.bake()?;
        let mat = &mut self.materials[m];
        match (&mat.procedural, mat.albedo) {
            (Some(_), Color::Texture(t)) => self.textures[t] = texture,
            _ => {
                self.textures.push(texture);
                mat.albedo = Color::Texture(self.textures.len() - 1);
            }
        }
        mat.procedural = Some(p);
        Ok(())
    }
}
