//! Crops of library materials as the material search sees them (bench_texture_search and the material-search
//! tests): a surface facing the camera, uv 0..1 across the crop, seen through a texture transform under a light
//! gain the albedo division did not remove, with photo noise.

use crate::SplitMix64;
use psdr::loss::Image;
use psdr::stages::{view_at, LibraryTexture, UvGrid};

/// Library materials that show wood (boards, parquet, veneer, grain); the graphs' categories say where a
/// material is used (floor, wall, furniture), not what it is, so wood is named here.
pub const WOOD: [&str; 10] = [
    "herringbone_dark",
    "herringbone_parquet",
    "laminate",
    "oak_planks",
    "painted_wood",
    "pine_planks",
    "walnut_planks",
    "walnut_veneer",
    "wood_grain",
    "wood_paneling",
];

/// One way of seeing a material: uv repeats across the crop, rotation, light gain per channel (not divided
/// out), relative gaussian noise.
pub struct Variant {
    pub name: &'static str,
    pub scale: f32,
    pub rotation_deg: f32,
    pub gain: [f32; 3],
    pub noise: f32,
}

pub const VARIANTS: [Variant; 7] = [
    Variant { name: "base", scale: 2.0, rotation_deg: 0.0, gain: [1.0; 3], noise: 0.02 },
    Variant { name: "rot30", scale: 2.0, rotation_deg: 30.0, gain: [1.0; 3], noise: 0.02 },
    Variant { name: "dim_warm", scale: 2.0, rotation_deg: 0.0, gain: [0.55, 0.5, 0.45], noise: 0.02 },
    Variant { name: "bright_cool", scale: 2.0, rotation_deg: 0.0, gain: [1.5, 1.6, 1.75], noise: 0.02 },
    Variant { name: "fine_rot90", scale: 4.5, rotation_deg: 90.0, gain: [1.0; 3], noise: 0.02 },
    Variant { name: "coarse", scale: 1.2, rotation_deg: 0.0, gain: [1.0; 3], noise: 0.02 },
    Variant { name: "mixed", scale: 3.0, rotation_deg: 30.0, gain: [0.75, 0.7, 0.62], noise: 0.04 },
];

/// The variant named `name`.
pub fn variant(name: &str) -> Option<&'static Variant> {
    VARIANTS.iter().find(|v| v.name == name)
}

/// A `size` x `size` crop of a surface facing the camera, uv 0..1 across it, `samples`^2 rays per pixel (as
/// `surface_textures::uv_grid` gives for such a surface).
pub fn facing_grid(size: usize, samples: usize) -> UvGrid {
    let s = samples.max(1);
    let uvs = (0..size * size)
        .map(|p| {
            let (x, y) = ((p % size) as f64, (p / size) as f64);
            let mut px = Vec::with_capacity(s * s);
            for j in 0..s {
                for i in 0..s {
                    let (sx, sy) = ((i as f64 + 0.5) / s as f64, (j as f64 + 0.5) / s as f64);
                    px.push([(x + sx) / size as f64, 1.0 - (y + sy) / size as f64]);
                }
            }
            px
        })
        .collect();
    UvGrid { width: size, height: size, uvs }
}

fn gaussian(rng: &mut SplitMix64) -> f32 {
    let u1 = rng.next_f32().max(1e-7);
    let u2 = rng.next_f32();
    (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
}

/// The query: the material through the variant's transform, under its light gain, with noise, clamped to 0..1
/// as the pipeline's albedo crop is.
pub fn query(tex: &LibraryTexture, v: &Variant, camera: &UvGrid, rng: &mut SplitMix64) -> Image {
    let mut img = view_at(tex, v.scale, v.rotation_deg, camera);
    for p in img.data.chunks_mut(3) {
        for (x, g) in p.iter_mut().zip(v.gain) {
            *x = (*x * g * (1.0 + v.noise * gaussian(rng))).clamp(0.0, 1.0);
        }
    }
    img
}
