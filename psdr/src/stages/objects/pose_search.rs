//! Scoring and searching one model's pose against a photo's instance, for the object stage's retrieval: the
//! instance as a target at the sweep's size, the score (mask IoU less depth misfit), a renderer that moves the
//! camera instead of the model, the median alignment on the floor, and the compass search of the finalists.

use crate::base::Intrinsics;
use crate::render::primary_hits::{model_scene_data, primary_hits};
use crate::render::scene_data::camera_gpu;
use crate::render::SceneData;
use crate::scene::{Camera, MeshPart, Pose};
use crate::vision::{ClassKind, Instances};
use glam::{Quat, Vec3};

pub(super) fn percentile(v: &mut [f32], q: f32) -> f32 {
    v.sort_by(f32::total_cmp);
    v[((v.len() - 1) as f32 * q).round() as usize]
}

/// The target at the sweep's size: 1 inside the instance, 0 outside, None where another instance (a possible
/// occluder) covers the pixel; and the observed depth.
pub(super) struct SweepTarget {
    w: usize,
    h: usize,
    mask: Vec<Option<bool>>,
    depth: Vec<f32>,
}

pub(super) fn sweep_target(inst: &Instances, depth: &[f32], id: u16, w: usize, h: usize) -> SweepTarget {
    let (pw, ph) = (inst.width, inst.height);
    let mut mask = vec![None; w * h];
    let mut d = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let (sx, sy) = ((x * pw + pw / 2) / w, (y * ph + ph / 2) / h);
            let p = sy.min(ph - 1) * pw + sx.min(pw - 1);
            let other = inst.ids[p] != 0 && inst.ids[p] != id && {
                let kind = inst.instances.iter().find(|i| i.id == inst.ids[p]).map(|i| i.kind);
                kind != Some(ClassKind::Structure)
            };
            mask[y * w + x] = if other { None } else { Some(inst.ids[p] == id) };
            d[y * w + x] = depth[p];
        }
    }
    SweepTarget { w, h, mask, depth: d }
}

/// IoU over the pixels the target does not leave out, less `depth_weight` x the mean depth misfit where both
/// cover, in units of the object's size (a bookcase turned to show its back panel is a shelf depth off, which
/// is small against the camera distance but not against the bookcase).
pub(super) fn score(target: &SweepTarget, ids: &[u32], depth: &[f32], size: f32, depth_weight: f32) -> (f32, f32) {
    let (mut inter, mut union) = (0usize, 0usize);
    let mut misfit = vec![];
    for p in 0..target.w * target.h {
        let Some(t) = target.mask[p] else { continue };
        let r = ids[p] == 0;
        inter += (t && r) as usize;
        union += (t || r) as usize;
        if t && r && target.depth[p] > 0.0 {
            misfit.push(((depth[p] - target.depth[p]).abs() / size.max(0.05)).min(1.0));
        }
    }
    let iou = if union == 0 { 0.0 } else { inter as f32 / union as f32 };
    let m = if misfit.is_empty() { 1.0 } else { misfit.iter().sum::<f32>() / misfit.len() as f32 };
    (iou, iou - depth_weight * m)
}

/// The larger horizontal extent of a model's parts.
pub(super) fn footprint_size(parts: &[MeshPart]) -> f32 {
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for v in parts.iter().flat_map(|p| &p.positions) {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    (hi.x - lo.x).max(hi.z - lo.z).max(0.05)
}

/// Renders one model alone with the photo's camera at the sweep's size: the object id and camera-space depth
/// of one ray through each pixel's centre (a mask and a depth need no shading). The model's BVH is built once
/// at the identity pose; a pose (translation, yaw, uniform scale) is rendered by moving the camera into the
/// model's frame instead, so a sweep costs ray casts, not rebuilds.
pub(super) struct PoseRenderer {
    camera: Camera,
    data: SceneData,
}

impl PoseRenderer {
    pub(super) fn new(camera: &Camera, parts: &[MeshPart], w: u32, h: u32) -> Option<PoseRenderer> {
        let mut cam = camera.clone();
        (cam.width, cam.height) = (w, h);
        let data = model_scene_data(parts, cam.clone()).ok()?;
        Some(PoseRenderer { camera: cam, data })
    }

    /// Object ids (0 on the model, `render::layout::NONE` elsewhere) and depth (world units, 0 on a miss)
    /// with the model at `pose` (uniform scale).
    pub(super) fn render(&mut self, pose: Pose) -> Option<(Vec<u32>, Vec<f32>)> {
        let (inv, s) = (pose.rotation.inverse(), pose.scale.x.max(1e-6));
        let c = &self.camera;
        let mut local = c.clone();
        local.origin = inv * (c.origin - pose.translation) / s;
        local.forward = inv * c.forward;
        local.up = inv * c.up;
        if !local.origin.is_finite() {
            return None;
        }
        let (ids, depth) = primary_hits(&self.data, &camera_gpu(&local), s);
        Some((ids, depth))
    }
}

/// The median-depth point of the pixels where `inside` holds, in world coordinates, if there are any.
pub(super) fn median_point(
    cam: &Camera,
    k: &Intrinsics,
    depth: &[f32],
    inside: impl Fn(usize) -> bool,
) -> Option<Vec3> {
    let mut xs = vec![];
    let mut ys = vec![];
    let mut zs = vec![];
    for (p, &z) in depth.iter().enumerate().take(k.width * k.height) {
        if inside(p) && z > 0.0 {
            xs.push((p % k.width) as f32);
            ys.push((p / k.width) as f32);
            zs.push(z);
        }
    }
    if xs.is_empty() {
        return None;
    }
    let (x, y, z) = (percentile(&mut xs, 0.5), percentile(&mut ys, 0.5), percentile(&mut zs, 0.5));
    let c = k.point(x as usize, y as usize, z);
    Some(cam.origin + cam.right() * c.x + cam.up * c.y + cam.forward * c.z)
}

/// Slides the object on the floor until the median visible point of its render meets the instance's (two
/// steps): the visible points are the object's near side, so its centre starts too close to the camera, and
/// by how much depends on the model and its yaw.
pub(super) fn align(
    cam: &Camera,
    renderer: &mut PoseRenderer,
    mut pose: Pose,
    target: &SweepTarget,
    w: u32,
    h: u32,
) -> Pose {
    let k = Intrinsics::new(w as usize, h as usize, cam.fov_y_deg);
    let Some(want) = median_point(cam, &k, &target.depth, |p| target.mask[p] == Some(true)) else { return pose };
    for _ in 0..2 {
        let Some((ids, depth)) = renderer.render(pose) else { break };
        let Some(got) = median_point(cam, &k, &depth, |p| ids[p] == 0 && target.mask[p].is_some()) else { break };
        let step = want - got;
        pose.translation += Vec3::new(step.x, 0.0, step.z);
    }
    pose
}

pub(super) fn pose_at(translation: Vec3, yaw_deg: f32, scale: f32) -> Pose {
    Pose { translation, rotation: Quat::from_rotation_y(yaw_deg.to_radians()), scale: Vec3::splat(scale) }
}

/// Up to `n` of the sweep's (yaw, place, score) starts, best first, no two closer than `apart` degrees; a
/// symmetric twin of a kept start (the same score at the same place: a cabinet turned round whose handle the
/// sweep cannot resolve) is kept too without counting, so the wall prior can choose between them.
pub(super) fn distinct_yaws(starts: &[(f32, Vec3, f32)], n: usize, apart: f32) -> Vec<(f32, Vec3, f32)> {
    let mut sorted = starts.to_vec();
    sorted.sort_by(|a, b| b.2.total_cmp(&a.2));
    let (mut kept, mut counted): (Vec<(f32, Vec3, f32)>, usize) = (vec![], 0);
    for s in sorted {
        let twin = |k: &(f32, Vec3, f32)| (s.2 - k.2).abs() < 1e-4 && s.1.distance(k.1) < 1e-3;
        let far = |k: &(f32, Vec3, f32)| ((s.0 - k.0).rem_euclid(360.0) - 180.0).abs() < 180.0 - apart;
        if kept.iter().any(twin) {
            kept.push(s);
        } else if counted < n && kept.iter().all(far) {
            kept.push(s);
            counted += 1;
        }
    }
    kept
}

/// A local search of one model's pose on the floor (translation x/z and yaw) for the best sweep score.
pub(super) struct PoseSearch<'a> {
    pub target: &'a SweepTarget,
    pub size: f32,
    pub prior: f32,
    pub depth_weight: f32,
}

impl PoseSearch<'_> {
    /// (score, iou) of `pose`.
    pub(super) fn eval(&self, renderer: &mut PoseRenderer, pose: Pose) -> Option<(f32, f32)> {
        let (ids, d) = renderer.render(pose)?;
        let (iou, s) = score(self.target, &ids, &d, self.size, self.depth_weight);
        Some((s - self.prior, iou))
    }

    /// Compass search from `pose` (whose yaw is `yaw` degrees): steps of `step` metres and `yaw_step` degrees
    /// along x, z and yaw, repeated while one improves, then halved, four times. Returns (yaw, score, iou,
    /// translation).
    pub(super) fn compass(
        &self,
        renderer: &mut PoseRenderer,
        pose: Pose,
        mut yaw: f32,
        mut step: f32,
        mut yaw_step: f32,
    ) -> Option<(f32, f32, f32, Vec3)> {
        let (mut best, mut iou) = self.eval(renderer, pose)?;
        let (mut t, scale) = (pose.translation, pose.scale.x);
        for _ in 0..4 {
            for _ in 0..4 {
                let moves = [
                    (Vec3::X * step, 0.0),
                    (-Vec3::X * step, 0.0),
                    (Vec3::Z * step, 0.0),
                    (-Vec3::Z * step, 0.0),
                    (Vec3::ZERO, yaw_step),
                    (Vec3::ZERO, -yaw_step),
                ];
                let mut moved = false;
                for (dt, dyaw) in moves {
                    if let Some((s, i)) = self.eval(renderer, pose_at(t + dt, yaw + dyaw, scale)) {
                        if s > best {
                            (best, iou, t, yaw, moved) = (s, i, t + dt, yaw + dyaw, true);
                        }
                    }
                }
                if !moved {
                    break;
                }
            }
            step /= 2.0;
            yaw_step /= 2.0;
        }
        Some((yaw, best, iou, t))
    }
}
