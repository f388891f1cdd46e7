//! The room's frame refined by how well its layout covers the segmentation (the paper's IoU criterion). A
//! wrong yaw, pitch or roll moves the wall feet the layout reads off the floor-wall contacts, and the box then
//! covers the masks worse; so the start frame's layout is scored by its mean mask IoU (`box_mask_iou`) and
//! improved by a compass search over small rotations about the room's up (yaw) and, unless the
//! start's up is to be kept, the camera's right (pitch) and view axis (roll): steps of 2 degrees halved down
//! to 1/8 degree. The masks say little about pitch (all walls are one class, so a wall-wall corner leaves no
//! boundary; the layout reproduces the floor-wall and wall-ceiling boundaries at almost any pitch): the
//! lines' vertical, where it has segments of its own, is kept (`bench_room_layout`: within 1.5 degrees of the
//! truth in 7 of 12 real-furniture rooms, the search moved it by up to 8 off). The search runs on masks
//! subsampled to about `SEARCH_LONG_SIDE` pixels; the chosen frame's layout is then made at full size.

use super::room_init::RoomEstimate;
use super::room_layout::{box_mask_iou, layout_room, LayoutEvidence, LayoutOptions};
use crate::base::Intrinsics;
use crate::error::{Error, Result};
use glam::{Quat, Vec3};

/// Long side (pixels) of the masks the search scores frames on.
const SEARCH_LONG_SIDE: usize = 320;

/// The frame kept and its layout.
pub struct FrameChoice {
    pub up: Vec3,
    pub x: Vec3,
    /// Angle (degrees) the search turned the start's up by.
    pub turned_deg: f32,
    pub layout: RoomEstimate,
    pub evidence: LayoutEvidence,
    /// Mean mask IoU of the layout at full size.
    pub iou: f32,
}

/// Every `step`-th pixel's mask value (pixel centres), and the intrinsics of that grid (same fov).
fn subsample(mask: &[bool], w: usize, h: usize, step: usize) -> Vec<bool> {
    let (sw, sh) = (w / step, h / step);
    (0..sw * sh).map(|i| mask[((i / sw) * step + step / 2) * w + (i % sw) * step + step / 2]).collect()
}

/// A start frame: up and x in camera coordinates, and whether its up is to be kept (the lines' vertical, which
/// the masks cannot correct: only the yaw is searched then).
#[derive(Clone, Copy, Debug)]
pub struct FrameStart {
    pub up: Vec3,
    pub x: Vec3,
    pub keep_up: bool,
}

/// The start frame turned by the compass search on its layout's IoU.
pub fn search_frame(start: FrameStart, masks: [&[bool]; 3], k: &Intrinsics, camera_height: f32) -> Result<FrameChoice> {
    let (w, h) = (k.width, k.height);
    let step = w.max(h).div_ceil(SEARCH_LONG_SIDE).max(1);
    let small: Vec<Vec<bool>> = masks.iter().map(|m| subsample(m, w, h, step)).collect();
    let sk = Intrinsics { width: w / step, height: h / step, ..*k };
    let sm = [small[0].as_slice(), small[1].as_slice(), small[2].as_slice()];
    let opts = LayoutOptions::default();
    let score = |up: Vec3, x: Vec3| -> Option<f32> {
        let (e, _) = layout_room(up, x, sm, &sk, camera_height, &opts).ok()?;
        Some(box_mask_iou(&e, &sk, sm[0], sm[1], sm[2]))
    };
    let mut best_score = score(start.up, start.x)
        .ok_or_else(|| Error::Invalid("room layout: the start frame gives no layout".into()))?;
    let (mut up, mut x) = (start.up, start.x);
    let mut delta = 2f32.to_radians();
    while delta >= 0.125f32.to_radians() * 0.99 {
        let mut improved = true;
        while improved {
            improved = false;
            // The camera's right turns the pitch, its view axis the roll, the room's up the yaw.
            let axes: &[Vec3] = if start.keep_up { &[up] } else { &[Vec3::X, Vec3::Z, up] };
            for &axis in axes {
                for sign in [1.0f32, -1.0] {
                    let q = Quat::from_axis_angle(axis, sign * delta);
                    let (u, v) = (q * up, q * x);
                    if let Some(s) = score(u, v) {
                        if s > best_score + 1e-5 {
                            (up, x, best_score, improved) = (u, v, s, true);
                        }
                    }
                }
            }
        }
        delta *= 0.5;
    }
    let (layout, evidence) = layout_room(up, x, masks, k, camera_height, &opts)?;
    let iou = box_mask_iou(&layout, k, masks[0], masks[1], masks[2]);
    let turned_deg = up.dot(start.up).clamp(-1.0, 1.0).acos().to_degrees();
    Ok(FrameChoice { up, x, turned_deg, layout, evidence, iou })
}
