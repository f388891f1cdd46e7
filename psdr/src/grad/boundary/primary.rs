//! Primary boundary: the silhouette edges of moving objects as seen from the camera, projected to the image and
//! sampled by projected length (the edge distribution, built once per scene and camera).
//!
//! A mesh edge can carry a visibility discontinuity for the camera when it bounds the mesh (one adjacent
//! triangle), when its two triangles face opposite ways from the camera, or when more than two triangles meet
//! there (`mesh_edges`). Edges hidden behind other geometry are kept: the two-sided evaluation sees no jump.

use crate::grad::accumulate_blocks;
use crate::grad::boundary::mesh_edges::mesh_edges;
use crate::grad::path::velocity::PoseLayout;
use crate::render::layout::CameraGpu;
use crate::render::sampler::Sampler;
use crate::render::SceneData;
use crate::scene::Scene;
use glam::Vec3;

/// A silhouette edge clipped to the front of the camera.
#[derive(Clone, Copy, Debug)]
pub struct ImageEdge {
    /// World-space endpoints.
    pub a: Vec3,
    pub b: Vec3,
    /// Image-space endpoints in pixels (x right, y down).
    pub pa: [f32; 2],
    pub pb: [f32; 2],
    pub object: u32,
    /// The whole (unclipped) mesh edge and the welded ids of its ends, for vertex velocities.
    pub mesh: [Vec3; 2],
    pub ends: [u32; 2],
}

impl ImageEdge {
    /// The point x of the mesh edge as a `Site`: its end vertices weighted by where x lies between them.
    pub fn site(&self, x: Vec3) -> [(u32, f32); 2] {
        let ab = self.mesh[1] - self.mesh[0];
        let t = ((x - self.mesh[0]).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
        [(self.ends[0], 1.0 - t), (self.ends[1], t)]
    }
}

/// The edge distribution: silhouette edges of the given objects and the CDF of their projected lengths.
pub struct PrimaryEdges {
    pub edges: Vec<ImageEdge>,
    /// Running sums of the edges' projected lengths (pixels).
    pub cdf: Vec<f32>,
    /// Total projected length in pixels.
    pub total_length: f32,
}

/// A point sampled on the silhouette set.
pub struct EdgeSample {
    pub edge: usize,
    /// Image position (pixels) and the unit image-space normal of the edge there.
    pub y: [f32; 2],
    pub n: [f32; 2],
    /// World-space point on the edge that projects to `y`.
    pub x: Vec3,
    /// Density of `y` per unit projected length (1 / total length).
    pub pdf: f32,
}

/// Camera-space distance in front of the camera below which edges are clipped.
const NEAR: f32 = 1e-4;

/// Projects a world point to image pixels; None behind the near plane.
pub fn project(c: &CameraGpu, x: Vec3) -> Option<[f32; 2]> {
    let r = x - Vec3::from(c.origin);
    let z = r.dot(Vec3::from(c.forward));
    if z <= NEAR * 0.5 {
        return None;
    }
    let ndc_x = r.dot(Vec3::from(c.right)) / (z * c.tan_half_fov * c.aspect);
    let ndc_y = r.dot(Vec3::from(c.up)) / (z * c.tan_half_fov);
    Some([(ndc_x + 1.0) * 0.5 * c.width as f32, (1.0 - ndc_y) * 0.5 * c.height as f32])
}

/// ∂(pixel x, pixel y)/∂x of `project` at world point x, applied to a velocity u.
pub fn project_velocity(c: &CameraGpu, x: Vec3, u: Vec3) -> [f32; 2] {
    let (fwd, right, up) = (Vec3::from(c.forward), Vec3::from(c.right), Vec3::from(c.up));
    let r = x - Vec3::from(c.origin);
    let z = r.dot(fwd);
    let dz = u.dot(fwd);
    let sx = 0.5 * c.width as f32 / (c.tan_half_fov * c.aspect);
    let sy = -0.5 * c.height as f32 / c.tan_half_fov;
    [sx * (u.dot(right) * z - r.dot(right) * dz) / (z * z), sy * (u.dot(up) * z - r.dot(up) * dz) / (z * z)]
}

impl PrimaryEdges {
    /// Silhouette edges (and, with `creases`, shading creases facing the camera) of the objects for which
    /// `wanted(object)` is true. Depth and masks jump only at silhouettes; radiance seen along fixed camera
    /// rays also jumps at creases, which move in the image with the object.
    pub fn build(scene: &Scene, cam: &CameraGpu, creases: bool, wanted: impl Fn(u32) -> bool) -> PrimaryEdges {
        let eye = Vec3::from(cam.origin);
        let mut edges = vec![];
        for e in mesh_edges(scene, wanted) {
            let keep = e.is_silhouette_from(eye)
                || (creases && e.is_crease() && e.faces.iter().all(|f| f.normal.dot(eye - e.a) > 0.0));
            if keep {
                if let Some((a, b, pa, pb)) = clip_and_project(cam, e.a, e.b) {
                    edges.push(ImageEdge { a, b, pa, pb, object: e.object, mesh: [e.a, e.b], ends: e.ends });
                }
            }
        }
        let mut cdf = Vec::with_capacity(edges.len());
        let mut total = 0.0f32;
        for e in &edges {
            total += length(e);
            cdf.push(total);
        }
        PrimaryEdges { edges, cdf, total_length: total }
    }

    /// A point uniformly distributed over the total projected length, from two uniform numbers.
    pub fn sample(&self, cam: &CameraGpu, u_edge: f32, u_along: f32) -> Option<EdgeSample> {
        if self.total_length <= 0.0 {
            return None;
        }
        let target = u_edge * self.total_length;
        let k = self.cdf.partition_point(|&c| c <= target).min(self.edges.len() - 1);
        let e = &self.edges[k];
        let (dx, dy) = (e.pb[0] - e.pa[0], e.pb[1] - e.pa[1]);
        let len = (dx * dx + dy * dy).sqrt();
        if len <= 0.0 {
            return None;
        }
        let y = [e.pa[0] + dx * u_along, e.pa[1] + dy * u_along];
        let x = point_on_edge(cam, e, y)?;
        Some(EdgeSample { edge: k, y, n: [-dy / len, dx / len], x, pdf: 1.0 / self.total_length })
    }
}

fn length(e: &ImageEdge) -> f32 {
    ((e.pb[0] - e.pa[0]).powi(2) + (e.pb[1] - e.pa[1]).powi(2)).sqrt()
}

/// Clips the segment to the front of the camera and projects it: the clipped ends and their image positions.
fn clip_and_project(cam: &CameraGpu, mut a: Vec3, mut b: Vec3) -> Option<(Vec3, Vec3, [f32; 2], [f32; 2])> {
    let (eye, fwd) = (Vec3::from(cam.origin), Vec3::from(cam.forward));
    let (za, zb) = ((a - eye).dot(fwd), (b - eye).dot(fwd));
    if za < NEAR && zb < NEAR {
        return None;
    }
    if za < NEAR {
        a = a + (b - a) * ((NEAR - za) / (zb - za));
    } else if zb < NEAR {
        b = b + (a - b) * ((NEAR - zb) / (za - zb));
    }
    Some((a, b, project(cam, a)?, project(cam, b)?))
}

/// The point of the edge's 3D segment whose projection is `y` (closest point between the camera ray through y
/// and the edge's line).
fn point_on_edge(cam: &CameraGpu, e: &ImageEdge, y: [f32; 2]) -> Option<Vec3> {
    let o = Vec3::from(cam.origin);
    let d = crate::render::camera::camera_ray(cam, y[0], y[1]);
    let ab = e.b - e.a;
    let w = e.a - o;
    let (a11, a12, a22) = (ab.dot(ab), ab.dot(d), d.dot(d));
    let (b1, b2) = (-w.dot(ab), w.dot(d));
    let det = a11 * a22 - a12 * a12;
    if det.abs() <= 1e-12 * a11 * a22 {
        return None; // the edge points at the camera: zero projected length
    }
    let t = ((b1 * a22 + a12 * b2) / det).clamp(0.0, 1.0);
    Some(e.a + ab * t)
}

/// Offset of the two side rays from a silhouette, in pixels: far below a pixel, far above f32 rounding of pixel
/// coordinates (~1e-5 at 512 px).
pub const SIDE_EPS: f32 = 1e-3;
/// Seed tweak separating edge samples from pixel samples.
pub const EDGE_SEED: u32 = 0x6a09_e667;

/// dLoss/d(output) per pixel, `channels` (1 or 3) values per pixel.
#[derive(Clone, Copy)]
pub struct PixelAdjoint<'a> {
    pub values: &'a [f32],
    pub channels: usize,
}

/// The primary boundary term of any per-pixel output:
///     Σ_samples adjoint(pixel) · [f(y − εn) − f(y + εn)] (V·n) / pdf / N
/// over `edge_samples` points y sampled on `edges`. `side(x, y, sampler)` evaluates the output along the camera
/// ray through image point (x, y); both sides of one sample get the same sampler, so noise cancels in the
/// difference.
pub fn primary_boundary<F>(
    d: &SceneData,
    seed: u32,
    pose: &PoseLayout,
    edges: &PrimaryEdges,
    adjoint: PixelAdjoint,
    edge_samples: u32,
    side: F,
) -> Vec<f64>
where
    F: Fn(f32, f32, &Sampler) -> Vec3 + Sync,
{
    primary_boundary_weighted(d, seed, pose, edges, edge_samples, |pixel, [x, y], [nx, ny], s| {
        let i = pixel * adjoint.channels;
        let mut delta = Vec3::ZERO;
        for (ch, a) in adjoint.values[i..i + adjoint.channels].iter().enumerate() {
            delta[ch] = *a;
        }
        if delta == Vec3::ZERO {
            return 0.0;
        }
        delta.dot(side(x - nx * SIDE_EPS, y - ny * SIDE_EPS, s) - side(x + nx * SIDE_EPS, y + ny * SIDE_EPS, s))
    })
}

/// The primary boundary term with the adjoint-weighted jump supplied by the caller:
/// `weighted_jump(pixel, y, n, sampler)` = Σ_outputs adjoint(pixel) · [f(y − εn) − f(y + εn)], so several
/// outputs read by one loss (depth and the masks of many objects) share one set of edge samples and rays.
pub fn primary_boundary_weighted<F>(
    d: &SceneData,
    seed: u32,
    pose: &PoseLayout,
    edges: &PrimaryEdges,
    edge_samples: u32,
    weighted_jump: F,
) -> Vec<f64>
where
    F: Fn(usize, [f32; 2], [f32; 2], &Sampler) -> f32 + Sync,
{
    if edges.edges.is_empty() || edge_samples == 0 {
        return vec![0.0; pose.len];
    }
    accumulate_blocks(edge_samples as usize, pose.len, |samples, g| {
        let mut moving = vec![];
        for k in samples.map(|k| k as u32) {
            primary_boundary_sample(d, seed, pose, edges, edge_samples, k, &weighted_jump, &mut moving, g);
        }
    })
}

/// Edge sample `k` of `primary_boundary_weighted`, added to `g` (`moving` is scratch space).
#[allow(clippy::too_many_arguments)]
pub fn primary_boundary_sample<F>(
    d: &SceneData,
    seed: u32,
    pose: &PoseLayout,
    edges: &PrimaryEdges,
    edge_samples: u32,
    k: u32,
    weighted_jump: &F,
    moving: &mut Vec<usize>,
    g: &mut [f64],
) where
    F: Fn(usize, [f32; 2], [f32; 2], &Sampler) -> f32,
{
    let (w, h) = (d.camera.width as f32, d.camera.height as f32);
    let s = Sampler { seed: seed ^ EDGE_SEED, pixel: k, sample: 0 };
    let Some(es) = edges.sample(&d.camera, s.get(0), s.get(1)) else { return };
    let [x, y] = es.y;
    if !(x >= 0.0 && y >= 0.0 && x < w && y < h) {
        return;
    }
    let pixel = (y as u32 * d.camera.width + x as u32) as usize;
    let jump = weighted_jump(pixel, es.y, es.n, &s);
    if jump == 0.0 {
        return;
    }
    let [nx, ny] = es.n;
    let edge = &edges.edges[es.edge];
    let weight = jump / (es.pdf * edge_samples as f32);
    let site = edge.site(es.x);
    moving.clear();
    pose.entries_moving(edge.object, &edge.ends, moving);
    for &e in moving.iter() {
        let (o, comp, at) = pose.entries[e];
        let v = project_velocity(&d.camera, es.x, pose.velocity(o, comp, es.x, &site));
        g[at] += (weight * (v[0] * nx + v[1] * ny)) as f64;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::camera::camera_ray;
    use crate::scene::Camera;

    fn camera() -> CameraGpu {
        let c = Camera::look_at(Vec3::new(0.3, 1.45, 2.3), Vec3::new(-0.1, 0.8, -1.5), Vec3::Y, 60.0, 256, 192);
        crate::render::scene_data::camera_gpu(&c)
    }

    /// `project` inverts `camera_ray` (to f32 rounding of pixel coordinates).
    #[test]
    fn project_inverts_camera_ray() {
        let c = camera();
        for (x, y) in [(0.5, 0.5), (100.25, 37.5), (255.0, 191.0), (128.0, 96.0)] {
            let p = project(&c, Vec3::from(c.origin) + camera_ray(&c, x, y) * 3.7).unwrap();
            assert!((p[0] - x).abs() < 1e-3 && (p[1] - y).abs() < 1e-3, "({x},{y}) -> {p:?}");
        }
    }

    /// `project_velocity` is the derivative of `project` (central differences, step 1e-3 m).
    #[test]
    fn project_velocity_matches_finite_differences() {
        let c = camera();
        let x = Vec3::new(-0.4, 0.6, -1.1);
        for u in [Vec3::X, Vec3::Y, Vec3::Z, Vec3::new(0.3, -0.2, 0.9)] {
            let h = 1e-3;
            let (a, b) = (project(&c, x + u * h).unwrap(), project(&c, x - u * h).unwrap());
            let fd = [(a[0] - b[0]) / (2.0 * h), (a[1] - b[1]) / (2.0 * h)];
            let v = project_velocity(&c, x, u);
            for k in 0..2 {
                assert!((fd[k] - v[k]).abs() < 1e-2 * (1.0 + fd[k].abs()), "u {u}: FD {fd:?} vs {v:?}");
            }
        }
    }
}
