//! Object ids and depths without shading: one ray through each pixel's centre, as the id AOV casts it. The
//! object stage scores poses and the model database describes silhouettes with this; a mask needs no light.

use super::bvh::trace_closest;
use super::camera::camera_ray;
use super::layout::{CameraGpu, NONE};
use super::SceneData;
use glam::Vec3;
use rayon::prelude::*;

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
