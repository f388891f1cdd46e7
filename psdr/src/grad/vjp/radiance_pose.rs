//! Reverse mode of the radiance image with respect to object poses and vertices: the ray-form interior term
//! (interior/geometry.rs) plus the primary, secondary and horizon boundary terms. The primary boundary samples silhouette edges seen by the camera
//! by projected length and takes the radiance difference across them from two paths that share their random
//! numbers (so the difference, not each side, carries the noise).

use crate::backend::Backend;
use crate::error::Result;
use crate::grad::boundary::primary::{primary_boundary, PixelAdjoint, PrimaryEdges};
use crate::grad::boundary::secondary::{secondary_boundary, SecondaryEdges, SecondaryPath};
use crate::grad::boundary::shadow::{shadow_boundary, shadow_sample_count, ShadowEdges};
use crate::grad::interior::geometry::{entries_touching, replay_radiance, Tangent};
use crate::grad::path::record::{record_path, PathRecord};
use crate::grad::path::velocity::PoseLayout;
use crate::grad::{accumulate_blocks, check_adjoint, radiance_primary_boundary_on};
use crate::render::camera::camera_ray;
use crate::render::cpu::frame_params;
use crate::render::path_trace::trace_from;
use crate::render::sampler::Sampler;
use crate::render::SceneData;
use crate::scene::{RenderSettings, Scene};
use glam::Vec3;

/// Sample counts of the boundary terms.
#[derive(Clone, Copy, Debug)]
pub struct BoundarySamples {
    /// Primary (camera silhouette) edge samples per evaluation (sppe).
    pub primary: u32,
    /// Secondary (shadow and indirect) edge samples per path vertex (sppse), and as many light-side shadow
    /// samples per camera path; 0 turns them off.
    pub secondary: u32,
}

pub fn radiance_pose_vjp(
    scene: &Scene,
    d: &SceneData,
    settings: &RenderSettings,
    pose: &PoseLayout,
    adjoint: &[f32],
    samples: BoundarySamples,
    backend: &mut dyn Backend,
) -> Result<Vec<f64>> {
    let (w, h) = (d.camera.width as usize, d.camera.height as usize);
    check_adjoint(adjoint, w * h * 3)?;
    // The secondary boundary reads each path's replayed vertex velocities: both run together, on a device
    // where its kernels cover the entries, else here, path by path.
    let on_device = backend.radiance_pose_interior(scene, d, settings, pose, adjoint, samples.secondary)?;
    let mut grad = match on_device {
        Some(g) => g,
        None => interior_and_secondary(scene, d, settings, pose, adjoint, samples.secondary),
    };
    let primary = radiance_primary_boundary_on(backend, scene, d, settings, pose, adjoint, samples.primary)?;
    grad.iter_mut().zip(primary).for_each(|(g, p)| *g += p);
    if samples.secondary > 0 {
        // The direct-shadow part the path-vertex estimator leaves out, sampled from the lights (on the host
        // for either backend: a few rays a sample).
        let fp = frame_params(d, settings);
        let count = shadow_sample_count(samples.secondary, w as u32 * h as u32 * fp.spp);
        let shadow = shadow_boundary(d, &fp, pose, &ShadowEdges::build(scene, pose), adjoint, count);
        grad.iter_mut().zip(shadow).for_each(|(g, s)| *g += s);
    }
    Ok(grad)
}

/// The ray-form interior term and the secondary boundary (`secondary_samples` per path vertex; 0: off) on the
/// CPU: each path is recorded once, replayed along every entry that touches it, and its replayed vertex
/// velocities drive the secondary edge samples.
fn interior_and_secondary(
    scene: &Scene,
    d: &SceneData,
    settings: &RenderSettings,
    pose: &PoseLayout,
    adjoint: &[f32],
    secondary_samples: u32,
) -> Vec<f64> {
    let (w, h) = (d.camera.width as usize, d.camera.height as usize);
    let fp = frame_params(d, settings);
    let secondary = SecondaryEdges::build(scene, pose);
    accumulate_blocks(h, pose.len, |rows, g| {
        let mut rec = PathRecord::default();
        // Vertex velocities of the path under each active entry (indexed like `active`).
        let mut velocities: Vec<Vec<Vec3>> = vec![];
        let mut active = vec![];
        for y in rows {
            for x in 0..w {
                let i = (y * w + x) * 3;
                let delta = Vec3::from_slice(&adjoint[i..i + 3]) / fp.spp as f32;
                if delta == Vec3::ZERO {
                    continue;
                }
                for sample in 0..fp.spp {
                    record_path(d, &fp, x as u32, y as u32, sample, &mut rec);
                    entries_touching(d, pose, &rec, &mut active);
                    velocities.resize_with(velocities.len().max(active.len()), Vec::new);
                    for (j, &e) in active.iter().enumerate() {
                        let (dl, _) = replay_radiance(d, &Tangent::of(pose, e), &rec, &mut velocities[j]);
                        g[pose.entries[e].2] += delta.dot(dl) as f64;
                    }
                    if secondary_samples > 0 {
                        let s = Sampler { seed: fp.seed, pixel: (y * w + x) as u32, sample };
                        let paths =
                            SecondaryPath { rec: &rec, active: &active, velocities: &velocities, sampler: &s, delta };
                        secondary_boundary(d, &fp, pose, &secondary, &paths, secondary_samples, g);
                    }
                }
            }
        }
    })
}

/// Primary boundary of radiance: silhouettes and creases, two paths per edge sample (the integrator's radiance
/// along the camera ray through each side, sharing the sample's random numbers).
pub fn radiance_primary_boundary(
    scene: &Scene,
    d: &SceneData,
    settings: &RenderSettings,
    pose: &PoseLayout,
    adjoint: &[f32],
    edge_samples: u32,
) -> Vec<f64> {
    let edges = PrimaryEdges::build(scene, &d.camera, true, |o| pose.moves(o));
    let fp = frame_params(d, settings);
    let origin = Vec3::from(d.camera.origin);
    primary_boundary(
        d,
        settings.seed,
        pose,
        &edges,
        PixelAdjoint { values: adjoint, channels: 3 },
        edge_samples,
        |x, y, s| trace_from(d, &fp, s, origin, camera_ray(&d.camera, x, y), &mut ()).radiance,
    )
}
