//! Reverse mode of the radiance image with respect to object poses: the material-form interior term
//! (`geometry_interior`) plus boundary terms. The primary boundary samples silhouette edges seen by the camera
//! by projected length and takes the radiance difference across them from two paths that share their random
//! numbers (so the difference, not each side, carries the noise).

use super::geometry_interior::{path_touches, replay_radiance, Tangent};
use super::path_record::{record_from, record_path, PathRecord};
use super::pose_velocity::PoseLayout;
use super::primary_edges::{project_velocity, PrimaryEdges};
use super::secondary_edges::{secondary_boundary, SecondaryEdges, SecondaryPath};
use crate::error::{Error, Result};
use crate::render::camera::camera_ray;
use crate::render::cpu::frame_params;
use crate::render::sampler::Sampler;
use crate::render::SceneData;
use crate::scene::{RenderSettings, Scene};
use glam::Vec3;
use rayon::prelude::*;

/// Offset of the two side rays from a silhouette, in pixels.
const SIDE_EPS: f32 = 1e-3;
const EDGE_SEED: u32 = 0x6a09_e667;
const CHUNK: u32 = 256;

/// Sample counts of the boundary terms.
#[derive(Clone, Copy, Debug)]
pub struct BoundarySamples {
    /// Primary (camera silhouette) edge samples per evaluation (sppe).
    pub primary: u32,
    /// Secondary (shadow and indirect) edge samples per path vertex (sppse); 0 turns them off.
    pub secondary: u32,
}

/// Refuses what the geometric replay does not model yet.
pub fn check_supported(scene: &Scene, pose: &PoseLayout) -> Result<()> {
    for (o, obj) in scene.objects.iter().enumerate() {
        if !pose.moves(o as u32) {
            continue;
        }
        if let Some(m) = obj.parts.iter().map(|p| &scene.materials[p.material]).find(|m| m.normal_map.is_some()) {
            return Err(Error::Invalid(format!(
                "object '{}': radiance gradients w.r.t. the pose of a normal-mapped object (material '{}') are not \
                 implemented yet; use --fd",
                obj.name, m.name
            )));
        }
    }
    Ok(())
}

pub fn radiance_pose_vjp(
    scene: &Scene,
    d: &SceneData,
    settings: &RenderSettings,
    pose: &PoseLayout,
    adjoint: &[f32],
    samples: BoundarySamples,
) -> Result<Vec<f64>> {
    check_supported(scene, pose)?;
    let (w, h) = (d.camera.width as usize, d.camera.height as usize);
    if adjoint.len() != w * h * 3 {
        return Err(Error::Invalid(format!("adjoint image has {} values, expected {}", adjoint.len(), w * h * 3)));
    }
    if let Some(i) = adjoint.iter().position(|v| !v.is_finite()) {
        return Err(Error::Invalid(format!("adjoint image value {i} is not finite")));
    }
    let fp = frame_params(d, settings);
    let secondary = SecondaryEdges::build(scene, |o| pose.moves(o));
    let rows: Vec<Vec<f64>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut g = vec![0.0f64; pose.len];
            let mut rec = PathRecord::default();
            let mut velocities = vec![Vec::new(); pose.entries.len()];
            for x in 0..w {
                let i = (y * w + x) * 3;
                let delta = Vec3::from_slice(&adjoint[i..i + 3]) / fp.spp as f32;
                if delta == Vec3::ZERO {
                    continue;
                }
                for sample in 0..fp.spp {
                    record_path(d, &fp, x as u32, y as u32, sample, &mut rec);
                    for (e, &(object, component, at)) in pose.entries.iter().enumerate() {
                        if path_touches(d, &rec, object) {
                            let tg = Tangent { pose, object, component };
                            let (dl, _) = replay_radiance(d, &tg, &rec, &mut velocities[e]);
                            g[at] += delta.dot(dl) as f64;
                        } else {
                            velocities[e].clear();
                            velocities[e].resize(rec.vertices.len(), Vec3::ZERO);
                        }
                    }
                    if samples.secondary > 0 {
                        let s = Sampler { seed: fp.seed, pixel: (y * w + x) as u32, sample };
                        let paths = SecondaryPath { rec: &rec, velocities: &velocities, sampler: &s, delta };
                        secondary_boundary(d, &fp, pose, &secondary, &paths, samples.secondary, &mut g);
                    }
                }
            }
            g
        })
        .collect();
    let mut grad = vec![0.0f64; pose.len];
    for row in rows.into_iter().chain(primary_boundary(scene, d, settings, pose, adjoint, samples.primary)) {
        grad.iter_mut().zip(row).for_each(|(g, r)| *g += r);
    }
    Ok(grad)
}

/// Primary boundary: one gradient vector per chunk of edge samples, reduced in chunk order by the caller.
fn primary_boundary(
    scene: &Scene,
    d: &SceneData,
    settings: &RenderSettings,
    pose: &PoseLayout,
    adjoint: &[f32],
    edge_samples: u32,
) -> Vec<Vec<f64>> {
    let edges = PrimaryEdges::build(scene, &d.camera, true, |o| pose.moves(o));
    if edges.edges.is_empty() || edge_samples == 0 {
        return vec![];
    }
    let fp = frame_params(d, settings);
    let (w, h) = (d.camera.width as f32, d.camera.height as f32);
    let origin = Vec3::from(d.camera.origin);
    (0..edge_samples.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut g = vec![0.0f64; pose.len];
            let mut rec = PathRecord::default();
            for k in c * CHUNK..((c + 1) * CHUNK).min(edge_samples) {
                let s = Sampler { seed: settings.seed ^ EDGE_SEED, pixel: k, sample: 0 };
                let Some(es) = edges.sample(&d.camera, s.get(0), s.get(1)) else { continue };
                let [x, y] = es.y;
                if !(x >= 0.0 && y >= 0.0 && x < w && y < h) {
                    continue;
                }
                let i = (y as u32 * d.camera.width + x as u32) as usize * 3;
                let delta = Vec3::from_slice(&adjoint[i..i + 3]);
                if delta == Vec3::ZERO {
                    continue;
                }
                let [nx, ny] = es.n;
                let mut side = |sign: f32| {
                    let dir = camera_ray(&d.camera, x + sign * nx * SIDE_EPS, y + sign * ny * SIDE_EPS);
                    record_from(d, &fp, &s, origin, dir, &mut rec);
                    rec.radiance()
                };
                let jump = side(-1.0) - side(1.0);
                if jump == Vec3::ZERO {
                    continue;
                }
                let object = edges.edges[es.edge].object;
                let weight = delta.dot(jump) / (es.pdf * edge_samples as f32);
                for &(o, comp, at) in &pose.entries {
                    if o == object {
                        let v = project_velocity(&d.camera, es.x, pose.velocity(o, comp, es.x));
                        g[at] += (weight * (v[0] * nx + v[1] * ny)) as f64;
                    }
                }
            }
            g
        })
        .collect()
}
