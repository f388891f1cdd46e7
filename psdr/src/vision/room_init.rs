//! The room box from depth and segmentation (PSDR-Room, "Room stage", initialisation): the floor plane by
//! RANSAC on the floor's points, the Manhattan wall directions from the walls' normals, each wall at the
//! median offset of its points, the height from the ceiling's points (else 1.2x the highest point seen). A
//! wall that is not seen is put just behind the camera (photos are taken from a room's edge), or just beyond
//! every point seen in its direction. The camera's height, pitch and roll come out of the floor plane.

use crate::base::{erode, surface_points, Intrinsics, SurfacePoint};
use crate::base::{fit_plane_in_depth, ransac_plane};
use crate::error::{Error, Result};
use glam::{Mat4, Vec3, Vec4};

/// Knobs of the initialisation (a script passes its own).
#[derive(Clone, Debug)]
pub struct RoomInitOptions {
    /// Pixels removed from each mask's border before points are taken.
    pub erode: usize,
    /// RANSAC inlier distance as a fraction of the median depth.
    pub plane_tolerance: f32,
    pub ransac_iters: usize,
    pub seed: u64,
    /// A wall point's normal must be within this angle (degrees) of a Manhattan axis to place that wall.
    pub wall_angle_deg: f32,
    /// An unseen wall goes this far beyond the farthest point seen in its direction (or behind the camera),
    /// in depth units: a camera in a wall's plane would see it edge-on.
    pub unseen_wall_margin: f32,
}

impl Default for RoomInitOptions {
    fn default() -> Self {
        RoomInitOptions {
            erode: 1,
            plane_tolerance: 0.01,
            ransac_iters: 300,
            seed: 1,
            wall_angle_deg: 20.0,
            unseen_wall_margin: 0.05,
        }
    }
}

/// The initial room: an axis-aligned box in a world frame whose y is up, floor at y = 0, and the camera.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RoomEstimate {
    /// Extents along world x (width) and z (depth), and height.
    pub width: f32,
    pub depth: f32,
    pub height: f32,
    /// The box spans x in [x_min, x_min + width], z in [z_min, z_min + depth].
    pub x_min: f32,
    pub z_min: f32,
    /// Camera-to-world (OpenGL convention: the camera looks down its -z), camera at (0, height, 0).
    pub camera_to_world: [[f32; 4]; 4],
    pub camera_height: f32,
    pub pitch_deg: f32,
    pub roll_deg: f32,
    /// Walls at -x, +x, -z, +z: placed from their own points (true) or by the fallback (false).
    pub walls_seen: [bool; 4],
    pub ceiling_seen: bool,
    pub floor_inliers: usize,
}

pub(super) fn median(mut v: Vec<f32>) -> Option<f32> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f32::total_cmp);
    Some(v[v.len() / 2])
}

/// Estimates the room box. `depth`: camera-space z per pixel (0 = none, metric or of any common scale);
/// `floor`, `walls`, `ceiling`: per-pixel class masks.
pub fn init_room(
    depth: &[f32],
    floor: &[bool],
    walls: &[bool],
    ceiling: &[bool],
    k: &Intrinsics,
    opts: &RoomInitOptions,
) -> Result<RoomEstimate> {
    let (w, h) = (k.width, k.height);
    let pts = |m: &[bool]| surface_points(depth, &erode(m, w, h, opts.erode), k);
    let (floor_pts, wall_pts, ceil_pts) = (pts(floor), pts(walls), pts(ceiling));
    if floor_pts.len() < 20 {
        return Err(Error::Invalid(format!(
            "room: only {} floor pixels with depth; the floor must be visible to place the room",
            floor_pts.len()
        )));
    }
    let zs = median(floor_pts.iter().chain(&wall_pts).map(|s| s.p.z).collect()).unwrap_or(1.0);
    let positions: Vec<Vec3> = floor_pts.iter().map(|s| s.p).collect();
    // RANSAC finds the floor among stray points (furniture bleeding into the mask); the final plane is
    // fitted in inverse depth on its inliers, with a band as wide as the depth's own noise.
    let tol = opts.plane_tolerance * zs;
    let (seed_plane, _) = ransac_plane(&positions, tol, opts.ransac_iters, opts.seed)
        .ok_or_else(|| Error::Invalid("room: no floor plane found".into()))?;
    let residual_sigma =
        1.4826 * median(positions.iter().map(|p| seed_plane.distance(*p).abs()).collect()).unwrap_or(0.0);
    let band = (3.0 * residual_sigma).max(tol);
    let near: Vec<Vec3> = positions.iter().copied().filter(|p| seed_plane.distance(*p).abs() <= band).collect();
    let plane = fit_plane_in_depth(&near).unwrap_or(seed_plane);
    let inliers = near.len();
    // Up points from the floor to the camera (the camera is above the floor).
    let (mut up, mut d) = (plane.n, plane.d);
    if -d < 0.0 {
        (up, d) = (-up, -d);
    }
    let cam_height = -d; // the camera (origin) is at n·0 − d = −d above the plane
    if cam_height.is_nan() || cam_height <= 0.0 {
        return Err(Error::Invalid("room: the camera is on the floor plane".into()));
    }
    // Manhattan directions: wall normals projected on the floor, angle folded to 90°.
    let forward = Vec3::Z;
    let e1 = (forward - up * forward.dot(up)).normalize_or_zero();
    let e1 = if e1 == Vec3::ZERO { Vec3::X } else { e1 };
    let e2 = up.cross(e1);
    let horizontal: Vec<&SurfacePoint> = wall_pts.iter().filter(|s| s.n.dot(up).abs() < 0.3).collect();
    let (mut sx, mut sy) = (0.0f64, 0.0f64);
    for s in &horizontal {
        let phi = s.n.dot(e2).atan2(s.n.dot(e1)) as f64;
        sx += (4.0 * phi).cos();
        sy += (4.0 * phi).sin();
    }
    let mut theta = if horizontal.is_empty() { 0.0 } else { (sy.atan2(sx) / 4.0) as f32 };
    let cos_tol = opts.wall_angle_deg.to_radians().cos();
    let axes = |theta: f32| {
        let ax = e1 * theta.cos() + e2 * theta.sin(); // world +x
                                                      // World +z. Camera space (x right, y up, z forward) is left-handed and the world is right-handed (the
                                                      // renderer's right is forward x up): the world's axes, written in camera coordinates, must form a
                                                      // left-handed triple, else the room comes out mirrored about the view.
        (ax, up.cross(ax))
    };
    let (mut ax, mut az) = axes(theta);
    // A wall counts as seen with enough points of its own (edge pixels with noisy normals do not make one).
    let enough = (wall_pts.len() / 30).max(30);
    let mut sides: [Vec<f32>; 4] = Default::default();
    // Normals are trusted when most wall points have one along a Manhattan axis; with noisy depth they point
    // anywhere, and the walls are found as lines in the wall points' footprint on the floor instead.
    let aligned = wall_pts.iter().filter(|s| s.n.dot(ax).abs().max(s.n.dot(az).abs()) > cos_tol).count();
    if aligned * 2 >= wall_pts.len() {
        // Walls: offsets of points whose normal is along ±x or ±z, split by the side of the camera they are on.
        for s in &wall_pts {
            for (i, (axis, sign)) in [(ax, -1.0f32), (ax, 1.0), (az, -1.0), (az, 1.0)].into_iter().enumerate() {
                let off = s.p.dot(axis);
                // A wall on the +axis side faces back along −axis (toward the camera).
                if off * sign > 0.0 && s.n.dot(axis) * -sign > cos_tol {
                    sides[i].push(off);
                }
            }
        }
    } else if wall_pts.len() >= enough {
        let flat: Vec<[f32; 2]> = wall_pts.iter().map(|s| [s.p.dot(e1), s.p.dot(e2)]).collect();
        // The inlier band follows the depth's relative noise, read off the floor's residuals.
        let noise = residual_sigma / cam_height;
        let band = (2.5 * noise * zs).max(tol);
        let lines = footprint_lines(&flat, band, enough, opts.seed);
        if let Some(first) = lines.first() {
            theta = first.0;
            (ax, az) = axes(theta);
        }
        for (dir, members) in &lines {
            // A line running along x is a wall across z, and the other way round.
            let along_x = (dir - theta).cos().abs() > (dir - theta).sin().abs();
            let axis = if along_x { az } else { ax };
            let offs: Vec<f32> = members.iter().map(|&k| wall_pts[k].p.dot(axis)).collect();
            let off = median(offs.clone()).unwrap_or(0.0);
            let i = if along_x { 2 } else { 0 } + usize::from(off > 0.0);
            if offs.len() > sides[i].len() {
                sides[i] = offs;
            }
        }
    }
    let all: Vec<Vec3> = floor_pts.iter().chain(&wall_pts).chain(&ceil_pts).map(|s| s.p).collect();
    let mut bounds = [0.0f32; 4];
    let mut seen = [false; 4];
    for (i, (axis, sign)) in [(ax, -1.0f32), (ax, 1.0), (az, -1.0), (az, 1.0)].into_iter().enumerate() {
        if sides[i].len() >= enough {
            bounds[i] = median(sides[i].clone()).unwrap_or(0.0);
            seen[i] = true;
        } else {
            // Unseen: beyond every point in that direction, or at the camera.
            let far = all.iter().map(|p| p.dot(axis) * sign).fold(0.0f32, f32::max);
            bounds[i] = (far + opts.unseen_wall_margin) * sign;
        }
    }
    let height_of = |p: Vec3| p.dot(up) + cam_height;
    let ceiling = median(ceil_pts.iter().map(|s| height_of(s.p)).collect());
    let ceiling_seen = ceiling.is_some() && ceil_pts.len() >= 30;
    let height = match ceiling.filter(|_| ceiling_seen) {
        Some(c) => c,
        None => 1.2 * all.iter().map(|p| height_of(*p)).fold(cam_height, f32::max),
    };
    Ok(box_estimate(BoxAxes { up, ax, az }, cam_height, bounds, seen, height, ceiling_seen, inliers))
}

/// The room's axes in camera coordinates: up (floor to ceiling), world +x and world +z.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoxAxes {
    pub up: Vec3,
    pub ax: Vec3,
    pub az: Vec3,
}

/// The estimate of a box with walls at `bounds` (offsets along -x, +x, -z, +z from the camera) seen from a
/// camera `cam_height` above the floor.
pub(crate) fn box_estimate(
    axes: BoxAxes,
    cam_height: f32,
    bounds: [f32; 4],
    seen: [bool; 4],
    height: f32,
    ceiling_seen: bool,
    floor_inliers: usize,
) -> RoomEstimate {
    let BoxAxes { up, ax, az } = axes;
    // Camera-to-world: world coordinates of the camera's axes (renderer convention: x right, y up, z forward).
    let world = |v: Vec3| Vec3::new(v.dot(ax), v.dot(up), v.dot(az));
    let (right, cam_up, fwd) = (world(Vec3::X), world(Vec3::Y), world(Vec3::Z));
    let m = Mat4::from_cols(
        right.extend(0.0),
        cam_up.extend(0.0),
        (-fwd).extend(0.0),
        Vec4::new(0.0, cam_height, 0.0, 1.0),
    );
    let rows = m.transpose().to_cols_array_2d();
    let pitch_deg = fwd.y.asin().to_degrees();
    // Positive when the image is turned counterclockwise (the camera's right side rises).
    let roll_deg = right.y.atan2(cam_up.y).to_degrees();
    RoomEstimate {
        width: bounds[1] - bounds[0],
        depth: bounds[3] - bounds[2],
        height,
        x_min: bounds[0],
        z_min: bounds[2],
        camera_to_world: rows,
        camera_height: cam_height,
        pitch_deg,
        roll_deg,
        walls_seen: seen,
        ceiling_seen,
        floor_inliers,
    }
}

/// Lines through 2-D points by sequential RANSAC (each line's inliers removed before the next): up to four
/// (direction angle, member indices) with at least `min_points` members each, largest first.
fn footprint_lines(pts: &[[f32; 2]], band: f32, min_points: usize, seed: u64) -> Vec<(f32, Vec<usize>)> {
    let mut state = seed ^ 0x2545_F491_4F6C_DD1D;
    let mut next = |n: usize| {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 33) % n as u64) as usize
    };
    let mut left: Vec<usize> = (0..pts.len()).collect();
    let mut lines = vec![];
    while lines.len() < 4 && left.len() >= min_points {
        let mut best: Option<(f32, Vec<usize>)> = None;
        for _ in 0..300 {
            let (a, b) = (pts[left[next(left.len())]], pts[left[next(left.len())]]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len = (dx * dx + dy * dy).sqrt();
            if len < band {
                continue;
            }
            let (nx, ny) = (-dy / len, dx / len);
            let members: Vec<usize> = left
                .iter()
                .copied()
                .filter(|&k| ((pts[k][0] - a[0]) * nx + (pts[k][1] - a[1]) * ny).abs() < band)
                .collect();
            if best.as_ref().is_none_or(|b| members.len() > b.1.len()) {
                best = Some((dy.atan2(dx), members));
            }
        }
        match best {
            Some((dir, members)) if members.len() >= min_points => {
                left.retain(|k| !members.contains(k));
                lines.push((dir, members));
            }
            _ => break,
        }
    }
    lines
}
