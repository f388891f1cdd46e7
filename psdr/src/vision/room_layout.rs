//! The room box from what survives a monocular depth network's distortions. Such depth is neither metric nor
//! affine in true depth (planes come out bent, walls tilted), but three things in a photo do not depend on it:
//! the room's directions (the Manhattan frame of its lines, `vision::estimate_frame`), where the floor meets
//! the walls and the walls meet the ceiling (the segmentation's class boundaries), and a camera-height prior.
//! With the frame and the height the floor plane is known; each floor-wall contact pixel's ray meets it at a
//! point of a wall's foot; the feet fall on lines along the room's axes, one per seen wall; each wall-ceiling
//! contact pixel's ray meets its wall at the ceiling's height. No depth value is used: the network's depth
//! then only has to be right in its order (`vision::fit_monotone_depth` maps it onto this box).

use super::room_init::{box_estimate, median, BoxAxes, RoomEstimate};
use crate::base::Intrinsics;
use crate::error::{Error, Result};
use glam::{Mat3, Vec3};

/// Knobs of the layout.
#[derive(Clone, Debug)]
pub struct LayoutOptions {
    /// A wall's foot point belongs to it within this fraction of the point's distance from the camera (a
    /// pixel of the boundary is ~1 % at 5 m for a 320-pixel-wide photo; masks are ragged by a few).
    pub band: f32,
    /// An unseen wall goes this far (metres) beyond the farthest floor point in its direction.
    pub unseen_wall_margin: f32,
}

impl Default for LayoutOptions {
    fn default() -> Self {
        LayoutOptions { band: 0.03, unseen_wall_margin: 0.05 }
    }
}

/// What the layout rests on, for the report.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LayoutEvidence {
    /// Floor-wall contact pixels found, and the share of them on a placed wall's foot.
    pub contact_points: usize,
    pub contacts_on_walls: f32,
    /// Wall-ceiling contact pixels that measured the ceiling's height.
    pub ceiling_points: usize,
}

/// The axes of an estimate's camera, in camera coordinates (x right, y up, z forward).
pub fn estimate_axes(e: &RoomEstimate) -> (Vec3, Vec3, Vec3) {
    let r = &e.camera_to_world;
    // Row i of the camera-to-world rotation is world axis i in the (z backward) camera's coordinates.
    let axis = |i: usize| Vec3::new(r[i][0], r[i][1], -r[i][2]);
    (axis(1), axis(0), axis(2))
}

/// A foot point of the floor-wall boundary: its floor coordinates along (x, z) and which walls it may belong to
/// by the boundary's local direction (a wall across x runs along z).
struct Foot {
    xz: [f32; 2],
    dist: f32,
    /// May be on a wall across x (normal along x), across z.
    across: [bool; 2],
}

/// The room box from the frame `up`, `x` (camera coordinates; z follows), the class masks (floor, walls,
/// ceiling) and the camera's height above the floor (a prior that sets the scale).
pub fn layout_room(
    up: Vec3,
    x: Vec3,
    masks: [&[bool]; 3],
    k: &Intrinsics,
    camera_height: f32,
    opts: &LayoutOptions,
) -> Result<(RoomEstimate, LayoutEvidence)> {
    let (w, h) = (k.width, k.height);
    let [floor, walls, ceiling] = masks;
    if !(camera_height.is_finite() && camera_height > 0.0) {
        return Err(Error::Invalid(format!("room layout: camera height {camera_height} m must be positive")));
    }
    let up = up.normalize();
    let ax = (x - up * x.dot(up)).normalize();
    // World +z from up x world +x (the camera's coordinates are left-handed: see `init_room`).
    let az = up.cross(ax);
    let on_floor = |d: Vec3| -> Option<Vec3> {
        let s = d.dot(up);
        (s < -1e-4).then(|| d * (-camera_height / s))
    };
    let xz = |p: Vec3| [p.dot(ax), p.dot(az)];
    // Floor-wall contacts: a floor pixel right below a wall pixel; the ray through the edge between them.
    let mut contacts: Vec<(usize, f32, [f32; 2], f32)> = vec![]; // column, row, foot, distance
    for px in 0..w {
        for py in 1..h {
            if floor[py * w + px] && walls[(py - 1) * w + px] {
                if let Some(p) = on_floor(k.ray(px as f32 + 0.5, py as f32)) {
                    let f = xz(p);
                    contacts.push((px, py as f32, f, (f[0] * f[0] + f[1] * f[1]).sqrt()));
                }
            }
        }
    }
    let min_points = (w / 50).max(8);
    if contacts.len() < min_points {
        return Err(Error::Invalid(format!(
            "room layout: {} pixels where the floor meets a wall (at least {min_points} needed); the walls' feet \
             are hidden",
            contacts.len()
        )));
    }
    // The boundary's local direction on the floor, from the contact nearest in row a few columns either side.
    let step = (w / 100).max(2);
    let near_in = |col: usize, row: f32| {
        contacts
            .iter()
            .filter(|c| c.0 == col)
            .min_by(|a, b| (a.1 - row).abs().total_cmp(&(b.1 - row).abs()))
            .filter(|c| (c.1 - row).abs() <= 2.0 * step as f32)
    };
    let cos30 = 30f32.to_radians().cos();
    let feet: Vec<Foot> = contacts
        .iter()
        .map(|c| {
            let (l, r) = (c.0.checked_sub(step).and_then(|col| near_in(col, c.1)), near_in(c.0 + step, c.1));
            let across = match (l.or(Some(c)), r.or(Some(c))) {
                (Some(a), Some(b)) if a.0 != b.0 => {
                    let d = [b.2[0] - a.2[0], b.2[1] - a.2[1]];
                    let n = (d[0] * d[0] + d[1] * d[1]).sqrt().max(1e-9);
                    // Running along z: a wall across x; along x: across z; between: a corner, either.
                    let (along_x, along_z) = ((d[0] / n).abs(), (d[1] / n).abs());
                    if along_z >= cos30 {
                        [true, false]
                    } else if along_x >= cos30 {
                        [false, true]
                    } else {
                        [true, true]
                    }
                }
                _ => [true, true],
            };
            Foot { xz: c.2, dist: c.3, across }
        })
        .collect();
    // Walls by sequential consensus: the axis-aligned line (x = c or z = c) with the most feet within the band,
    // its offset the median of theirs; one wall per side.
    let mut free = vec![true; feet.len()];
    let mut bounds = [0.0f32; 4];
    let mut seen = [false; 4];
    let stride = (feet.len() / 400).max(1);
    loop {
        let mut best: Option<(usize, usize, f32)> = None; // (count, side, offset)
        for a in 0..2 {
            for cand in feet.iter().step_by(stride).filter(|f| f.across[a]) {
                let c = cand.xz[a];
                let side = 2 * a + usize::from(c > 0.0);
                if seen[side] || c.abs() < 1e-3 {
                    continue;
                }
                let n = feet
                    .iter()
                    .zip(&free)
                    .filter(|(f, &fr)| fr && f.across[a] && (f.xz[a] - c).abs() < opts.band * f.dist)
                    .count();
                if best.is_none_or(|b| n > b.0) {
                    best = Some((n, side, c));
                }
            }
        }
        let Some((n, side, c)) = best.filter(|b| b.0 >= min_points) else { break };
        let a = side / 2;
        let members = |c: f32| -> Vec<usize> {
            (0..feet.len())
                .filter(|&i| free[i] && feet[i].across[a] && (feet[i].xz[a] - c).abs() < opts.band * feet[i].dist)
                .collect()
        };
        let c = median(members(c).iter().map(|&i| feet[i].xz[a]).collect()).unwrap_or(c);
        let m = members(c);
        if m.len() < min_points.max(n / 2) || (c > 0.0) != (side % 2 == 1) {
            break;
        }
        for i in m {
            free[i] = false;
        }
        bounds[side] = c;
        seen[side] = true;
    }
    if !seen.iter().any(|&s| s) {
        return Err(Error::Invalid("room layout: the floor-wall contacts do not line up along the room's axes".into()));
    }
    // Unseen walls: beyond every floor point in their direction, or just behind the camera.
    let floor_pts: Vec<[f32; 2]> = (0..w * h)
        .filter(|&i| floor[i])
        .step_by(((w * h) / 20000).max(1))
        .filter_map(|i| on_floor(k.ray((i % w) as f32 + 0.5, (i / w) as f32 + 0.5)).map(xz))
        .collect();
    for side in 0..4 {
        if !seen[side] {
            let (a, sign) = (side / 2, if side % 2 == 1 { 1.0 } else { -1.0 });
            let far = floor_pts.iter().map(|p| p[a] * sign).fold(0.0f32, f32::max);
            bounds[side] = (far + opts.unseen_wall_margin) * sign;
        }
    }
    // Where a ray leaves the box through a wall: the distance along it and the wall's side.
    let exit = |d: Vec3| -> Option<(f32, usize)> {
        let (dx, dz) = (d.dot(ax), d.dot(az));
        let tx = if dx < 0.0 { (bounds[0] / dx, 0) } else { (bounds[1] / dx.max(1e-12), 1) };
        let tz = if dz < 0.0 { (bounds[2] / dz, 2) } else { (bounds[3] / dz.max(1e-12), 3) };
        let t = if tx.0 < tz.0 { tx } else { tz };
        (t.0.is_finite() && t.0 > 0.0).then_some(t)
    };
    // The ceiling: a ceiling pixel right above a wall pixel; its ray's height where it meets a seen wall.
    let mut heights = vec![];
    for px in 0..w {
        for py in 1..h {
            if walls[py * w + px] && ceiling[(py - 1) * w + px] {
                let d = k.ray(px as f32 + 0.5, py as f32);
                if let Some((t, side)) = exit(d).filter(|e| seen[e.1]) {
                    let _ = side;
                    heights.push(camera_height + t * d.dot(up));
                }
            }
        }
    }
    heights.retain(|v| *v > camera_height);
    let ceiling_points = heights.len();
    let ceiling_height = median(heights).filter(|_| ceiling_points >= min_points);
    let height = match ceiling_height {
        Some(c) => c,
        None => {
            // Unmeasured: 1.2x the highest wall point seen on a seen wall (as `init_room`), above the camera.
            let top = (0..w * h)
                .filter(|&i| walls[i])
                .step_by(((w * h) / 20000).max(1))
                .filter_map(|i| {
                    let d = k.ray((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
                    exit(d).filter(|e| seen[e.1]).map(|(t, _)| camera_height + t * d.dot(up))
                })
                .fold(camera_height, f32::max);
            1.2 * top
        }
    };
    let on_walls = free.iter().filter(|f| !**f).count();
    let est = box_estimate(
        BoxAxes { up, ax, az },
        camera_height,
        bounds,
        seen,
        height,
        ceiling_height.is_some(),
        floor.iter().filter(|&&f| f).count(),
    );
    let evidence = LayoutEvidence {
        contact_points: feet.len(),
        contacts_on_walls: on_walls as f32 / feet.len() as f32,
        ceiling_points,
    };
    Ok((est, evidence))
}

/// What a box shows at a pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoxSurface {
    Floor,
    Ceiling,
    /// Walls at -x, +x, -z, +z.
    Wall(usize),
}

/// The box of `e` seen through `k`: per pixel the camera-space depth (z) of the surface its ray leaves the box
/// through, and which surface that is (none where the camera is outside the box).
pub fn box_view(e: &RoomEstimate, k: &Intrinsics) -> Vec<Option<(f32, BoxSurface)>> {
    let (up, ax, az) = estimate_axes(e);
    let m = Mat3::from_cols(ax, up, az).transpose(); // camera to room directions
    let lo = Vec3::new(e.x_min, 0.0, e.z_min);
    let hi = Vec3::new(e.x_min + e.width, e.height, e.z_min + e.depth);
    let o = Vec3::new(0.0, e.camera_height, 0.0);
    (0..k.width * k.height)
        .map(|i| {
            let d = k.ray((i % k.width) as f32 + 0.5, (i / k.width) as f32 + 0.5);
            let r = m * d;
            let mut best: Option<(f32, BoxSurface)> = None;
            for (axis, lo, hi) in [(0usize, lo.x, hi.x), (1, lo.y, hi.y), (2, lo.z, hi.z)] {
                let (c, oc) = (r[axis], o[axis]);
                if c.abs() < 1e-12 {
                    continue;
                }
                let (t, high) = if c > 0.0 { ((hi - oc) / c, true) } else { ((lo - oc) / c, false) };
                if t > 0.0 && best.is_none_or(|b| t < b.0) {
                    let s = match axis {
                        1 if high => BoxSurface::Ceiling,
                        1 => BoxSurface::Floor,
                        0 => BoxSurface::Wall(usize::from(high)),
                        _ => BoxSurface::Wall(2 + usize::from(high)),
                    };
                    best = Some((t, s));
                }
            }
            best
        })
        .collect()
}

/// How well a box's floor, walls and ceiling cover the segmentation's: the mean IoU of the three classes over
/// the pixels segmented as any of them (furniture hides the room in the photo but not in the empty box), over
/// the classes the segmentation shows.
pub fn box_mask_iou(e: &RoomEstimate, k: &Intrinsics, floor: &[bool], walls: &[bool], ceiling: &[bool]) -> f32 {
    let view = box_view(e, k);
    let class_of = |s: BoxSurface| match s {
        BoxSurface::Floor => 0,
        BoxSurface::Wall(_) => 1,
        BoxSurface::Ceiling => 2,
    };
    let masks = [floor, walls, ceiling];
    let (mut inter, mut union) = ([0usize; 3], [0usize; 3]);
    for (i, v) in view.iter().enumerate() {
        let Some(seg) = (0..3).find(|&c| masks[c][i]) else { continue };
        let mine = v.map(|(_, s)| class_of(s));
        for c in 0..3 {
            let (a, b) = (seg == c, mine == Some(c));
            inter[c] += usize::from(a && b);
            union[c] += usize::from(a || b);
        }
    }
    let shown: Vec<usize> = (0..3).filter(|&c| masks[c].iter().any(|&m| m)).collect();
    shown.iter().map(|&c| inter[c] as f32 / union[c].max(1) as f32).sum::<f32>() / shown.len().max(1) as f32
}
