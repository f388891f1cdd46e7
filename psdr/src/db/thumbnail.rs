//! A model's thumbnail, rendered by psdr: the model in grey on a white ground, seen from the front-right and
//! above, lit from above the camera, framed to its bounds. `psdr db build` writes one per model so a user can
//! see the alternatives a run kept, and an image-embedding model can compare them with a photo's crops.

use super::ModelEntry;
use crate::error::Result;
use crate::render::{render_cpu, SceneData};
use crate::scene::{rectangle_mesh, Camera, Emitter, Material, Object, Pose, RenderSettings, Scene};
use glam::{Quat, Vec3};
use std::path::Path;

/// Renders `entry` at `size` x `size` pixels into a PNG at `path`.
pub fn render_thumbnail(entry: &ModelEntry, path: &Path, size: u32) -> Result<()> {
    let mut parts = entry.load_parts()?;
    parts.iter_mut().for_each(|p| p.material = 0);
    let s = entry.size();
    let radius = 0.5 * s.length().max(0.05);
    let centre = Vec3::new(0.0, s.y / 2.0, 0.0);
    let dir = Vec3::new(0.55, 0.45, 1.0).normalize();
    let fov = 40.0f32;
    let dist = radius / (fov.to_radians() / 2.0).sin() * 1.05;
    let camera = Camera::look_at(centre + dir * dist, centre, Vec3::Y, fov, size, size);
    let mut ground = rectangle_mesh(40.0 * radius, 40.0 * radius);
    ground.material = 1;
    let mut lamp = rectangle_mesh(2.0 * radius, 2.0 * radius);
    lamp.material = 1;
    let light_at = centre + Vec3::new(0.3, 1.0, 0.6).normalize() * 3.0 * radius;
    let scene = Scene {
        camera,
        settings: RenderSettings { spp: 16, max_depth: 3, rr_depth: 3, seed: 0 },
        materials: vec![Material::diffuse("model", Vec3::splat(0.6)), Material::diffuse("ground", Vec3::splat(0.9))],
        textures: vec![],
        objects: vec![
            Object { name: "model".into(), parts, pose: Pose::default(), emitter: None },
            Object {
                name: "ground".into(),
                parts: vec![ground],
                pose: Pose { rotation: Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2), ..Default::default() },
                emitter: None,
            },
            Object {
                name: "lamp".into(),
                parts: vec![lamp],
                pose: Pose {
                    translation: light_at,
                    rotation: Quat::from_rotation_arc(Vec3::Z, (centre - light_at).normalize()),
                    scale: Vec3::ONE,
                },
                emitter: Some(Emitter::uniform(Vec3::splat(3.0), false)),
            },
        ],
        source: None,
        requires_grad: vec![],
    };
    let f = render_cpu(&SceneData::build(&scene)?, &scene.settings, &|_, _| {});
    crate::output::write_png_srgb(path, size, size, &f.radiance)
}
