//! Object ids and depths without shading: one ray through each pixel's centre, as the id AOV casts it. The
//! object stage scores poses and the model database describes silhouettes with this; a mask needs no light.

use super::bvh::trace_closest;
use super::camera::camera_ray;
use super::layout::{CameraGpu, NONE};
use super::SceneData;
use crate::error::Result;
use crate::scene::{Camera, Material, MeshPart, Object, Pose, RenderSettings, Scene};
use glam::Vec3;
use rayon::prelude::*;

/// The scene data of one model alone at the identity pose (every part one grey material, one sample, one
/// bounce), seen by `camera`: what `primary_hits` casts against to outline or pose a model.
pub fn model_scene_data(parts: &[MeshPart], camera: Camera) -> Result<SceneData> {
    let parts = parts
        .iter()
        .cloned()
        .map(|mut p| {
            p.material = 0;
            p
        })
        .collect();
    SceneData::build(&Scene {
        camera,
        settings: RenderSettings { spp: 1, max_depth: 1, rr_depth: 1, seed: 0 },
        materials: vec![Material::diffuse("model", Vec3::splat(0.5))],
        textures: vec![],
        objects: vec![Object { name: "model".into(), parts, pose: Pose::default(), emitter: None }],
        source: None,
        requires_grad: vec![],
    })
}

/// Per pixel of `cam`'s image: the hit object's index (`NONE` on a miss) and the camera-space depth of the hit
/// (0 on a miss), times `depth_scale` (a camera moved into a scaled object's frame sees depths divided by it).
pub fn primary_hits(d: &SceneData, cam: &CameraGpu, depth_scale: f32) -> (Vec<u32>, Vec<f32>) {
    let (w, h) = (cam.width, cam.height);
    let (origin, forward) = (Vec3::from(cam.origin), Vec3::from(cam.forward));
    (0..w * h)
        .into_par_iter()
        .map(|p| {
            let dir = camera_ray(cam, (p % w) as f32 + 0.5, (p / w) as f32 + 0.5);
            match trace_closest(&d.nodes, &d.triangles, origin, dir, f32::INFINITY) {
                Some(hit) => (d.triangles[hit.triangle as usize].object, hit.t * dir.dot(forward) * depth_scale),
                None => (NONE, 0.0),
            }
        })
        .unzip()
}
