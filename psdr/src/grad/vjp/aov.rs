//! Reverse mode for the depth and coverage-mask AOVs with respect to object poses:
//!     d/dθ ∫_pixel f(y) dy = ∫_pixel ∂f/∂θ dy  +  ∫_{silhouettes ∩ pixel} (f⁻ − f⁺) (V·n) dℓ
//! The interior term exists for depth only (a mask is piecewise constant): along a fixed camera ray the hit
//! distance to a plane moving with velocity u changes by (n·u)/(n·d). The boundary term samples silhouette
//! edges by projected length (`PrimaryEdges`), evaluates f on both sides of the edge with two camera rays
//! ε pixels apart, and V = ∂y/∂θ is the image velocity of the edge point. f⁻ is the side the normal n points
//! away from: when the edge moves along +n, the f⁻ region grows.

use crate::error::{Error, Result};
use crate::grad::boundary::primary::{primary_boundary_weighted, PrimaryEdges, SIDE_EPS};
use crate::grad::path::velocity::PoseLayout;
use crate::grad::Output;
use crate::grad::{accumulate_blocks, check_adjoint};
use crate::render::bvh::trace_closest;
use crate::render::camera::camera_ray;
use crate::render::layout::NONE;
use crate::render::sampler::{Sampler, DIM_PIXEL_X};
use crate::render::SceneData;
use crate::scene::{RenderSettings, Scene};
use glam::Vec3;

/// What the camera ray through image point (x, y) sees: its depth and the object it hits (None: nothing).
fn seen_along(d: &SceneData, x: f32, y: f32) -> (f32, Option<u32>) {
    let dir = camera_ray(&d.camera, x, y);
    match trace_closest(&d.nodes, &d.triangles, Vec3::from(d.camera.origin), dir, f32::INFINITY) {
        None => (0.0, None),
        Some(h) => (h.t * dir.dot(Vec3::from(d.camera.forward)), Some(d.triangles[h.triangle as usize].object)),
    }
}

/// dLoss/d(AOV) images of one loss: the depth's (w·h values) and any number of objects' coverage masks'.
#[derive(Clone, Copy, Debug, Default)]
pub struct AovAdjoints<'a> {
    pub depth: Option<&'a [f32]>,
    /// (object index, adjoint of its mask).
    pub masks: &'a [(usize, &'a [f32])],
}

/// dLoss/dθ for the pose entries of `pose`, given dLoss/d(AOV) per pixel (`adjoint`, w·h values).
pub fn aov_vjp(
    scene: &Scene,
    d: &SceneData,
    settings: &RenderSettings,
    pose: &PoseLayout,
    output: &Output,
    adjoint: &[f32],
    edge_samples: u32,
) -> Result<Vec<f64>> {
    let masks;
    let adjoints = match output {
        Output::Radiance => {
            return Err(Error::Invalid("aov_vjp differentiates depth and masks; radiance has its own adjoint".into()))
        }
        Output::Depth => AovAdjoints { depth: Some(adjoint), masks: &[] },
        Output::Mask(o) => {
            masks = [(*o, adjoint)];
            AovAdjoints { depth: None, masks: &masks }
        }
    };
    aovs_vjp(scene, d, settings, pose, &adjoints, edge_samples)
}

/// dLoss/dθ for a loss that reads depth and several masks at once: one depth interior pass and one set of
/// silhouette samples whose two side rays serve every output (the jump of each output is weighted by its own
/// adjoint at the sample's pixel).
pub fn aovs_vjp(
    scene: &Scene,
    d: &SceneData,
    settings: &RenderSettings,
    pose: &PoseLayout,
    adjoints: &AovAdjoints,
    edge_samples: u32,
) -> Result<Vec<f64>> {
    let of_object = masks_by_object(scene, d, adjoints)?;
    if adjoints.depth.is_none() && adjoints.masks.is_empty() {
        return Ok(vec![0.0; pose.len]);
    }
    let mut grad = boundary(scene, d, settings, pose, adjoints.depth, &of_object, edge_samples);
    if let Some(a) = adjoints.depth {
        let interior = depth_interior(d, settings, pose, a);
        grad.iter_mut().zip(interior).for_each(|(g, r)| *g += r);
    }
    Ok(grad)
}

/// Each object's mask adjoint (`None` for the masks the loss does not read), once the depth's and every mask's
/// adjoint are checked to cover the image and no object is given twice.
pub fn masks_by_object<'a>(scene: &Scene, d: &SceneData, adjoints: &AovAdjoints<'a>) -> Result<Vec<Option<&'a [f32]>>> {
    let (w, h) = (d.camera.width as usize, d.camera.height as usize);
    if let Some(a) = adjoints.depth {
        check_adjoint(a, w * h)?;
    }
    let mut of_object: Vec<Option<&[f32]>> = vec![None; scene.objects.len()];
    for &(o, a) in adjoints.masks {
        if o >= scene.objects.len() {
            return Err(Error::Invalid(format!("mask of object {o}: the scene has {}", scene.objects.len())));
        }
        if of_object[o].is_some() {
            return Err(Error::Invalid(format!("two adjoints given for the mask of object {o}")));
        }
        check_adjoint(a, w * h)?;
        of_object[o] = Some(a);
    }
    Ok(of_object)
}

/// Interior term of depth.
fn depth_interior(d: &SceneData, settings: &RenderSettings, pose: &PoseLayout, adjoint: &[f32]) -> Vec<f64> {
    let (w, h) = (d.camera.width, d.camera.height);
    let fwd = Vec3::from(d.camera.forward);
    let origin = Vec3::from(d.camera.origin);
    accumulate_blocks(h as usize, pose.len, |rows, g| {
        let mut moving = vec![];
        for py in rows.map(|y| y as u32) {
            for px in 0..w {
                let delta = adjoint[(py * w + px) as usize] / settings.spp as f32;
                if delta == 0.0 {
                    continue;
                }
                for sample in 0..settings.spp {
                    let s = Sampler { seed: settings.seed, pixel: py * w + px, sample };
                    let (jx, jy) = s.get2(DIM_PIXEL_X);
                    let dir = camera_ray(&d.camera, px as f32 + jx, py as f32 + jy);
                    let Some(hit) = trace_closest(&d.nodes, &d.triangles, origin, dir, f32::INFINITY) else {
                        continue;
                    };
                    let tri = &d.triangles[hit.triangle as usize];
                    if tri.object == NONE || !pose.moves(tri.object) {
                        continue;
                    }
                    let n = Vec3::from(tri.e1).cross(Vec3::from(tri.e2));
                    let p = origin + dir * hit.t;
                    let nd = n.dot(dir);
                    if nd == 0.0 {
                        continue;
                    }
                    let ids = pose.corners(d, hit.triangle);
                    let site = [(ids[0], 1.0 - hit.u - hit.v), (ids[1], hit.u), (ids[2], hit.v)];
                    moving.clear();
                    pose.entries_moving(tri.object, &ids, &mut moving);
                    for &e in &moving {
                        let (o, c, at) = pose.entries[e];
                        let dt = n.dot(pose.velocity(o, c, p, &site)) / nd;
                        g[at] += (delta * dt * dir.dot(fwd)) as f64;
                    }
                }
            }
        }
    })
}

/// Boundary term: silhouettes only (depth and masks are continuous across creases).
fn boundary(
    scene: &Scene,
    d: &SceneData,
    settings: &RenderSettings,
    pose: &PoseLayout,
    depth: Option<&[f32]>,
    masks: &[Option<&[f32]>],
    edge_samples: u32,
) -> Vec<f64> {
    let edges = PrimaryEdges::build(scene, &d.camera, false, |o| pose.moves(o));
    primary_boundary_weighted(d, settings.seed, pose, &edges, edge_samples, |pixel, [x, y], [nx, ny], _| {
        let (inner, outer) =
            (seen_along(d, x - nx * SIDE_EPS, y - ny * SIDE_EPS), seen_along(d, x + nx * SIDE_EPS, y + ny * SIDE_EPS));
        let mut jump = 0.0;
        if let Some(a) = depth {
            jump += a[pixel] * (inner.0 - outer.0);
        }
        // Only the masks of the objects seen on either side jump.
        let mut mask_jump = |object: Option<u32>, sign: f32| {
            if let Some(&Some(a)) = object.and_then(|o| masks.get(o as usize)) {
                jump += a[pixel] * sign;
            }
        };
        if inner.1 != outer.1 {
            mask_jump(inner.1, 1.0);
            mask_jump(outer.1, -1.0);
        }
        jump
    })
}
