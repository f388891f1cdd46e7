//! Relative depth to metres. Monocular estimators give depth up to an unknown scale and shift: either affine in
//! depth (`relative`: v = a·z + b) or affine in inverse depth (`disparity`: v = a/z + b, as Depth-Anything and
//! DPT give). The shift is found from the room itself: with the right shift the floor is a plane and the walls
//! stand perpendicular to it (a wrong shift bends planes in the first model and tilts them by unequal amounts in
//! the second), so a one-dimensional search minimises how far the surface normals are from that Manhattan
//! structure. The scale cannot come from a single photo: it is set by a stated prior, the camera's height above
//! the floor, and recorded as such.

use crate::base::{erode, fit_plane_in_depth, ransac_plane, surface_points, Intrinsics};
use crate::error::{Error, Result};
use crate::vision::DepthUnits;
use glam::Vec3;

/// What was done to turn relative depth into metres.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DepthCalibration {
    pub units: DepthUnits,
    /// z ∝ v − shift (relative) or 1/(v − shift) (disparity).
    pub shift: f32,
    /// Metres per unit of the shifted depth.
    pub scale: f32,
    /// How far the normals are from a floor plane with perpendicular walls at the chosen shift (0 = exact).
    pub manhattan_residual: f32,
    /// The camera height the scale was set from (metres), a prior, not a measurement.
    pub camera_height_prior: f32,
    /// The room layout from lines and masks the depth was compared with (and, where it fits the segmentation
    /// better than the box of this affine calibration, mapped onto by its order alone).
    pub layout: Option<LayoutCheck>,
}

/// The depth-free room layout against the affine calibration's box.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LayoutCheck {
    /// The start frame the layout came from, "lines" (the photo's Manhattan frame) or "depth" (the affine
    /// box's floor and walls), and how far the search by mask IoU turned it (`search_frame`).
    pub frame: String,
    /// Angle (degrees) between the lines' up and the affine depth's; None without a frame from lines.
    pub frame_angle_deg: Option<f32>,
    /// Mean IoU of each box's floor, walls and ceiling with the segmentation's.
    pub box_iou_affine: f32,
    pub box_iou_layout: f32,
    pub evidence: super::room_layout::LayoutEvidence,
    /// Whether the depth was mapped onto the layout (true) or kept affine.
    pub used: bool,
    /// The depth's order against the layout's (Spearman) and the monotone map's median relative error.
    pub rank_correlation: Option<f32>,
    pub median_relative_error: Option<f32>,
}

/// Shifted depth (arbitrary scale) for one shift; 0 where there is none.
fn shifted(values: &[f32], units: DepthUnits, shift: f32) -> Vec<f32> {
    values
        .iter()
        .map(|&v| {
            let s = v - shift;
            if !(v > 0.0 && s > 0.0) {
                0.0
            } else if units == DepthUnits::Disparity {
                1.0 / s
            } else {
                s
            }
        })
        .collect()
}

/// The mean of the smallest 80 % (edge pixels and clutter make the largest residuals).
fn trimmed_mean(mut v: Vec<f32>) -> f32 {
    if v.is_empty() {
        return 1.0;
    }
    v.sort_by(f32::total_cmp);
    let keep = (v.len() * 4 / 5).max(1);
    v[..keep].iter().sum::<f32>() / keep as f32
}

/// How far the surface normals are from a Manhattan room at this depth: floor and ceiling normals against the
/// floor plane's, wall normals' components along it.
fn manhattan_residual(z: &[f32], masks: [&[bool]; 3], k: &Intrinsics, seed: u64) -> Option<f32> {
    let sub = |m: &[bool]| {
        let pts = surface_points(z, m, k);
        let stride = (pts.len() / 4000).max(1);
        pts.into_iter().step_by(stride).collect::<Vec<_>>()
    };
    let (floor, walls, ceiling) = (sub(masks[0]), sub(masks[1]), sub(masks[2]));
    if floor.len() < 20 {
        return None;
    }
    let positions: Vec<Vec3> = floor.iter().map(|s| s.p).collect();
    let zmed = {
        let mut zs: Vec<f32> = positions.iter().map(|p| p.z).collect();
        zs.sort_by(f32::total_cmp);
        zs[zs.len() / 2]
    };
    let (plane, _) = ransac_plane(&positions, 0.02 * zmed, 100, seed)?;
    let up = plane.n;
    let horizontal = floor.iter().chain(&ceiling).map(|s| 1.0 - s.n.dot(up).powi(2)).collect();
    let vertical = walls.iter().map(|s| s.n.dot(up).powi(2)).collect();
    Some(trimmed_mean(horizontal) + if walls.is_empty() { 0.0 } else { trimmed_mean(vertical) })
}

/// Turns relative depth (`values`, 0 = none) into metres: the shift that makes the room most Manhattan, the
/// scale that puts the camera `camera_height` above the floor.
pub fn calibrate_relative_depth(
    values: &[f32],
    units: DepthUnits,
    masks: [&[bool]; 3],
    k: &Intrinsics,
    camera_height: f32,
    erode_px: usize,
) -> Result<(Vec<f32>, DepthCalibration)> {
    if units == DepthUnits::Metres {
        return Err(Error::Invalid("calibrate_relative_depth: the depth is already in metres".into()));
    }
    if !(camera_height.is_finite() && camera_height > 0.0) {
        return Err(Error::Invalid(format!("camera height prior {camera_height} m must be positive")));
    }
    let eroded: Vec<Vec<bool>> = masks.iter().map(|m| erode(m, k.width, k.height, erode_px)).collect();
    let masks = [eroded[0].as_slice(), eroded[1].as_slice(), eroded[2].as_slice()];
    let mut seen: Vec<f32> =
        values.iter().enumerate().filter(|&(p, &v)| v > 0.0 && masks.iter().any(|m| m[p])).map(|(_, &v)| v).collect();
    if seen.len() < 50 {
        return Err(Error::Invalid(format!(
            "relative depth: only {} floor, wall or ceiling pixels with depth; too few to find its shift",
            seen.len()
        )));
    }
    seen.sort_by(f32::total_cmp);
    let (lo, med) = (seen[seen.len() / 100], seen[seen.len() / 2]);
    if med <= lo {
        return Err(Error::Invalid("relative depth: the room's depth is constant; its shift cannot be found".into()));
    }
    // Shift as rho, the ratio of the near to the median shifted value, in (0, 1): every shift below the
    // smallest value maps to one rho.
    let shift_of = |rho: f32| (lo - rho * med) / (1.0 - rho);
    let cost =
        |rho: f32| manhattan_residual(&shifted(values, units, shift_of(rho)), masks, k, 1).unwrap_or(f32::INFINITY);
    let grid: Vec<f32> = (1..50).map(|i| i as f32 / 50.0).collect();
    let costs: Vec<f32> = grid.iter().map(|&r| cost(r)).collect();
    let best = (0..grid.len()).min_by(|&a, &b| costs[a].total_cmp(&costs[b])).unwrap_or(0);
    if !costs[best].is_finite() {
        return Err(Error::Invalid("relative depth: no floor plane at any shift; is the floor segmented?".into()));
    }
    // Golden-section refinement between the best grid point's neighbours.
    let (mut a, mut b) = (grid[best.saturating_sub(1)], grid[(best + 1).min(grid.len() - 1)]);
    let g = 0.618_034f32;
    for _ in 0..20 {
        let (c, d) = (b - g * (b - a), a + g * (b - a));
        if cost(c) < cost(d) {
            b = d;
        } else {
            a = c;
        }
    }
    let rho = 0.5 * (a + b);
    let residual = cost(rho).min(costs[best]);
    let rho = if cost(rho) <= costs[best] { rho } else { grid[best] };
    let shift = shift_of(rho);
    let z = shifted(values, units, shift);
    // Scale: the camera's height above the floor plane fitted in this depth.
    let floor: Vec<Vec3> = surface_points(&z, masks[0], k).into_iter().map(|s| s.p).collect();
    let mut zs: Vec<f32> = floor.iter().map(|p| p.z).collect();
    zs.sort_by(f32::total_cmp);
    let tol = 0.01 * zs.get(zs.len() / 2).copied().unwrap_or(1.0);
    let plane = ransac_plane(&floor, tol, 300, 1)
        .and_then(|(p, _)| {
            let near: Vec<Vec3> = floor.iter().copied().filter(|q| p.distance(*q).abs() <= 3.0 * tol).collect();
            fit_plane_in_depth(&near)
        })
        .ok_or_else(|| Error::Invalid("relative depth: no floor plane found".into()))?;
    let height = plane.d.abs();
    if !(height.is_finite() && height > 0.0) {
        return Err(Error::Invalid("relative depth: the camera is on the floor plane".into()));
    }
    let scale = camera_height / height;
    let metres = z.iter().map(|v| v * scale).collect();
    Ok((
        metres,
        DepthCalibration {
            units,
            shift,
            scale,
            manhattan_residual: residual,
            camera_height_prior: camera_height,
            layout: None,
        },
    ))
}
