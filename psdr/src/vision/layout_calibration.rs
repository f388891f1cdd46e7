//! Relative depth checked against the room layout. The affine calibration (`calibrate_relative_depth`) is
//! exact when the depth is affine in true depth (or in inverse depth), as a depth sensor's or a renderer's is;
//! a network's is not, and then its room comes out tilted and bent (on a real living-room photo: pitch -15.6
//! degrees where the photo's is about -26). The depth-free layout (`layout_room`: the photo's lines'
//! Manhattan frame, the floor-wall and wall-ceiling contacts of the segmentation, the camera-height prior) does
//! not rest on the depth's values at all; its frame is the lines' where they give a vertical of their own,
//! else the affine depth's turned by the layout's mask IoU (`search_frame`). Of the two boxes the one whose floor, walls and ceiling cover the
//! segmentation's better is kept (the paper's IoU criterion; a tie keeps the affine one); when it is the
//! layout, the depth is mapped onto it by its order alone (`fit_monotone_depth`), so furniture gets depths
//! consistent with the room it stands in. Both boxes' scores, the frame's source and the depth's rank
//! agreement with the layout are reported.

use super::depth_calibration::LayoutCheck;
use super::frame_search::{search_frame, FrameStart};
use super::room_init::{init_room, RoomEstimate, RoomInitOptions};
use super::room_layout::{box_mask_iou, box_view, estimate_axes, BoxSurface};
use super::vanishing_points::{estimate_frame, VanishingOptions};
use super::working_size::{photo_at, working_size};
use super::{fit_monotone_depth, DepthUnits};
use crate::base::{erode, Image, Intrinsics};
use crate::error::{Error, Result};
use glam::Vec3;

/// The outcome: the check for the report, and where the layout is kept, its box and the depth mapped onto it.
pub struct LayoutCalibration {
    pub check: LayoutCheck,
    pub room: Option<RoomEstimate>,
    pub metres: Option<Vec<f32>>,
}

/// Long side (pixels) of the copy of the photo the lines are found on: directions need no more.
const FRAME_LONG_SIDE: usize = 640;
/// The lines' up must be within this of the affine depth's (degrees) to replace it: beyond, a line cluster
/// was taken for the vertical that is not (or the depth is upside down).
const FRAME_AGREEMENT_DEG: f32 = 25.0;
/// The lines' vertical is trusted with this many segments of its own: with fewer it follows from the two
/// horizontal directions, whose rotation about the better-supported one is loose (`bench_room_layout`: every
/// vertical with 8 or more within 1.5 degrees of the truth, those with 2-6 off by 3.7-15.5).
const MIN_VERTICAL_SEGMENTS: usize = 8;
/// The layout replaces the affine box only when its mean IoU is higher by more than this.
const IOU_MARGIN: f32 = 0.01;

/// The photo's Manhattan frame from its lines, matched to `up0` and `x0` (the affine box's axes, camera
/// coordinates): (up, x, angle between the two ups in degrees), or why not.
fn frame_from_lines(
    photo: &Image,
    fov_y_deg: f32,
    up0: Vec3,
    x0: Vec3,
) -> std::result::Result<(Vec3, Vec3, f32), String> {
    let (ww, wh, crop) = working_size(photo.width, photo.height, FRAME_LONG_SIDE);
    let small = photo_at(photo, ww, wh).ok_or("the photo could not be resampled")?;
    let fov = (2.0 * ((fov_y_deg.to_radians() / 2.0).tan() as f64 * crop[3] / photo.height as f64).atan()).to_degrees();
    let frame = estimate_frame(&small, fov as f32, &VanishingOptions::default()).map_err(|f| f.to_string())?;
    let axes: Vec<Vec3> = frame.axes.iter().map(|a| Vec3::from_array(*a)).collect();
    let i = (0..3).max_by(|&a, &b| axes[a].dot(up0).abs().total_cmp(&axes[b].dot(up0).abs())).unwrap_or(1);
    let up = axes[i] * axes[i].dot(up0).signum();
    let angle = up.dot(up0).clamp(-1.0, 1.0).acos().to_degrees();
    if frame.segments[i] < MIN_VERTICAL_SEGMENTS {
        return Err(format!(
            "the vertical has {} segments of its own (at least {MIN_VERTICAL_SEGMENTS} fix it)",
            frame.segments[i]
        ));
    }
    if angle > FRAME_AGREEMENT_DEG {
        return Err(format!("the lines' nearest vertical is {angle:.1} degrees from the depth's"));
    }
    let j = (0..3).filter(|&j| j != i).max_by(|&a, &b| axes[a].dot(x0).abs().total_cmp(&axes[b].dot(x0).abs()));
    let x = j.map(|j| axes[j] * axes[j].dot(x0).signum()).unwrap_or(x0);
    Ok((up, x, angle))
}

/// Compares the affine calibration's room (from `affine_metres`) with the layout, and maps `values` onto the
/// layout where it wins. `masks`: floor, walls, ceiling.
#[allow(clippy::too_many_arguments)]
pub fn check_against_layout(
    photo: &Image,
    fov_y_deg: f32,
    values: &[f32],
    units: DepthUnits,
    affine_metres: &[f32],
    masks: [&[bool]; 3],
    k: &Intrinsics,
    camera_height: f32,
) -> Result<LayoutCalibration> {
    let [floor, walls, ceiling] = masks;
    let affine = init_room(affine_metres, floor, walls, ceiling, k, &RoomInitOptions::default()).ok();
    let iou = |e: &RoomEstimate| box_mask_iou(e, k, floor, walls, ceiling);
    let box_iou_affine = affine.as_ref().map_or(0.0, iou);
    // Without an affine box: the camera held roughly level, its x along the image's.
    let (up0, x0) = affine.as_ref().map_or((Vec3::Y, Vec3::X), |e| {
        let (up, ax, _) = estimate_axes(e);
        (up, ax)
    });
    // The start frame: the photo's lines' where they give a vertical near the depth's up, else the affine
    // depth's (turned by the masks' IoU, which cannot tell pitches apart, so the lines' up is kept).
    let lines = frame_from_lines(photo, fov_y_deg, up0, x0);
    let (start, source, frame_angle_deg) = match lines {
        Ok((up, x, angle)) => (FrameStart { up, x, keep_up: true }, "lines".to_string(), Some(angle)),
        Err(why) if affine.is_some() => {
            (FrameStart { up: up0, x: x0, keep_up: false }, format!("depth (lines: {why})"), None)
        }
        Err(why) => return Err(Error::Invalid(format!("room layout: no frame: the depth gives no room and {why}"))),
    };
    let choice = search_frame(start, masks, k, camera_height)?;
    let frame = format!("{source}, turned {:.2} degrees by the masks' IoU", choice.turned_deg);
    let (layout, evidence, box_iou_layout) = (choice.layout, choice.evidence, choice.iou);
    let mut check = LayoutCheck {
        frame,
        frame_angle_deg,
        box_iou_affine,
        box_iou_layout,
        evidence,
        used: false,
        rank_correlation: None,
        median_relative_error: None,
    };
    if box_iou_layout <= box_iou_affine + IOU_MARGIN {
        return Ok(LayoutCalibration { check, room: None, metres: None });
    }
    // The layout's depth where the segmentation shows the surface the box has there (and the box measured it).
    let (w, h) = (k.width, k.height);
    let inner: Vec<Vec<bool>> = masks.iter().map(|m| erode(m, w, h, 1)).collect();
    let target: Vec<f32> = box_view(&layout, k)
        .iter()
        .enumerate()
        .map(|(i, v)| match v {
            Some((z, BoxSurface::Floor)) if inner[0][i] => *z,
            Some((z, BoxSurface::Wall(s))) if inner[1][i] && layout.walls_seen[*s] => *z,
            Some((z, BoxSurface::Ceiling)) if inner[2][i] && layout.ceiling_seen => *z,
            _ => 0.0,
        })
        .collect();
    let Some(map) = fit_monotone_depth(values, &target, units) else {
        return Ok(LayoutCalibration { check, room: None, metres: None });
    };
    check.used = true;
    check.rank_correlation = Some(map.rank_correlation);
    check.median_relative_error = Some(map.median_relative_error);
    let metres = values.iter().map(|&v| map.apply(v)).collect();
    Ok(LayoutCalibration { check, room: Some(layout), metres: Some(metres) })
}
