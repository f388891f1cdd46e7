//! The scene file schema (JSON, format "psdr-scene", version 1). See README "Scene files".
//! Fields are deliberately loose here (optional, untyped numbers); `load` validates them with messages that
//! name the field, which serde alone cannot do well.

use serde::{Deserialize, Deserializer, Serialize};
use std::collections::BTreeMap;

pub const FORMAT: &str = "psdr-scene";
pub const VERSION: u32 = 1;

#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub format: String,
    pub version: u32,
    pub camera: CameraFile,
    #[serde(default)]
    pub render: RenderFile,
    #[serde(default)]
    pub materials: Vec<MaterialFile>,
    pub shapes: Vec<ShapeFile>,
    /// Parameter paths that require gradients (e.g. "object/sofa/translation"); `psdr grad` and the
    /// optimisation stages differentiate these when no parameter is named explicitly.
    #[serde(default)]
    pub requires_grad: Vec<String>,
}

#[derive(Deserialize, Serialize, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
pub struct CameraFile {
    pub origin: Option<[f32; 3]>,
    pub target: Option<[f32; 3]>,
    pub up: Option<[f32; 3]>,
    /// Camera-to-world, row-major, OpenGL convention (looks down -z); alternative to origin/target/up.
    pub to_world: Option<[[f32; 4]; 4]>,
    pub fov_y: f32,
    pub width: u32,
    pub height: u32,
}

#[derive(Deserialize, Serialize, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
pub struct RenderFile {
    pub spp: Option<u32>,
    pub max_depth: Option<u32>,
    pub rr_depth: Option<u32>,
    pub seed: Option<u32>,
}

/// `[r, g, b]`, a single grey value, or `{"texture": "file.png", "srgb": true}`.
#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(untagged)]
pub enum ValueFile {
    Number(f32),
    Rgb([f32; 3]),
    Texture(TextureRef),
}

#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct TextureRef {
    pub texture: String,
    /// Decode 8-bit images from sRGB. Default: true for albedo, false for data maps.
    pub srgb: Option<bool>,
}

#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct MaterialFile {
    pub name: String,
    pub albedo: Option<ValueFile>,
    pub roughness: Option<ValueFile>,
    pub specular: Option<ValueFile>,
    pub normal_map: Option<String>,
    pub uv_transform: Option<UvTransformFile>,
}

#[derive(Deserialize, Serialize, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
pub struct UvTransformFile {
    /// One number or `[su, sv]`.
    #[serde(default, deserialize_with = "one_or_many")]
    pub scale: Option<Vec<f32>>,
    pub rotation_deg: Option<f32>,
    pub offset: Option<[f32; 2]>,
}

#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ShapeFile {
    pub name: String,
    /// "obj", "rectangle", "box" or "sphere".
    #[serde(rename = "type")]
    pub kind: String,
    /// obj: the OBJ file.
    pub file: Option<String>,
    /// rectangle: [w, h]; box: [x, y, z].
    pub size: Option<Vec<f32>>,
    /// sphere
    pub radius: Option<f32>,
    pub rings: Option<u32>,
    pub segments: Option<u32>,
    /// box, sphere: normals point inside (rooms, enclosures).
    pub inward: Option<bool>,
    /// Material for every part without an entry in `part_materials`.
    pub material: Option<String>,
    /// OBJ material-group name -> scene material name.
    #[serde(default)]
    pub part_materials: BTreeMap<String, String>,
    pub transform: Option<TransformFile>,
    pub emitter: Option<EmitterFile>,
}

#[derive(Deserialize, Serialize, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
pub struct TransformFile {
    pub translation: Option<[f32; 3]>,
    /// Euler angles in degrees, applied about x, then y, then z (fixed axes).
    pub rotation_deg: Option<[f32; 3]>,
    /// Unit quaternion [x, y, z, w]; alternative to rotation_deg.
    pub quaternion: Option<[f32; 4]>,
    /// One number or `[sx, sy, sz]`.
    #[serde(default, deserialize_with = "one_or_many")]
    pub scale: Option<Vec<f32>>,
}

#[derive(Deserialize, Serialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct EmitterFile {
    pub radiance: ValueFile,
    #[serde(default)]
    pub two_sided: bool,
}

/// Reads `2` as `[2]` and `[2, 3]` as itself, so "one number or a list" fields accept both spellings.
fn one_or_many<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec<f32>>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum OneOrMany {
        One(f32),
        Many(Vec<f32>),
    }
    Ok(Option::<OneOrMany>::deserialize(d)?.map(|n| match n {
        OneOrMany::One(x) => vec![x],
        OneOrMany::Many(v) => v,
    }))
}
