//! Materials: Lambertian diffuse + GGX specular layer, each parameter a constant or a texture.

use super::Procedural;
use glam::{Vec2, Vec3};
use std::path::PathBuf;

/// An RGB parameter: a constant (linear) or a texture index into `Scene::textures`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Color {
    Constant(Vec3),
    Texture(usize),
}

/// A scalar parameter: a constant or a texture (first channel is used).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scalar {
    Constant(f32),
    Texture(usize),
}

/// uv' = R(rotation) * (scale * uv) + offset, applied before every texture lookup of the material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    pub scale: Vec2,
    pub rotation_deg: f32,
    pub offset: Vec2,
}

impl Default for UvTransform {
    fn default() -> Self {
        UvTransform { scale: Vec2::ONE, rotation_deg: 0.0, offset: Vec2::ZERO }
    }
}

impl UvTransform {
    /// Rows of the 2x3 affine matrix: (a, b, tx) and (c, d, ty).
    pub fn rows(&self) -> [[f32; 3]; 2] {
        let (s, c) = self.rotation_deg.to_radians().sin_cos();
        [[c * self.scale.x, -s * self.scale.y, self.offset.x], [s * self.scale.x, c * self.scale.y, self.offset.y]]
    }

    /// The same transform in the material library's (f64) form, for its lookups and their derivatives.
    pub fn texture_transform(&self) -> psdr_materials::TextureTransform {
        psdr_materials::TextureTransform {
            scale: [self.scale.x as f64, self.scale.y as f64],
            rotation_deg: self.rotation_deg as f64,
            offset: [self.offset.x as f64, self.offset.y as f64],
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Diffuse albedo, linear RGB in [0, 1].
    pub albedo: Color,
    /// Perceptual roughness in [0, 1]; GGX alpha = roughness^2.
    pub roughness: Scalar,
    /// Specular level in [0, 1]; normal-incidence Fresnel F0 = 0.08 * specular (0.5 -> 0.04, IOR 1.5).
    pub specular: Scalar,
    /// Tangent-space normal map (RGB in [0,1] -> n = 2c - 1), texture index.
    pub normal_map: Option<usize>,
    pub uv_transform: UvTransform,
    /// Where the albedo texture comes from when a procedural graph generates it (`albedo` is then that
    /// texture, kept baked at the graph's parameters by `Scene::set_procedural` and parameter writes).
    pub procedural: Option<Procedural>,
    /// How the furniture model this part came from colours it (its MTL), kept beside the constant `albedo` the
    /// fits work with until `stages::object_pictures` puts it back: on the parts the photo does not show, and
    /// the picture, tinted to the fitted albedo, where it is closer to the photo than that constant.
    pub model_look: Option<ModelLook>,
}

/// A furniture model's own colouring of one of its parts.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelLook {
    /// Linear albedo: the MTL's Kd times its picture's mean (within the albedo division's range).
    pub albedo: Vec3,
    /// The map_Kd picture, where the file is there and reads.
    pub picture: Option<PathBuf>,
}

impl Material {
    pub fn diffuse(name: &str, albedo: Vec3) -> Self {
        Material {
            name: name.to_string(),
            albedo: Color::Constant(albedo),
            roughness: Scalar::Constant(1.0),
            specular: Scalar::Constant(0.0),
            normal_map: None,
            uv_transform: UvTransform::default(),
            procedural: None,
            model_look: None,
        }
    }
}
