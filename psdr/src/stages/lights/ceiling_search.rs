//! The ceiling's height where the photo does not show the ceiling, from the light it throws. The room stage
//! can only bound it from below (it is above every point the photo shows; room_init guesses 1.2x the highest),
//! but where the ceiling lights hang sets how the light falls off down the walls and across the floor: room04
//! of the real-furniture rooms had its unseen ceiling 47 cm too high, and the light fit then kept one of its
//! three ceiling lights. Each height tried gets the light stage's own candidates (`init_lights`, the photo's
//! windows) fitted to the photo with every candidate kept; the highest height whose fit's error is within a
//! tolerance of the least wins.

use super::{add_visible_windows, fit_lights, init_lights, LightFitOptions, LightInitOptions};
use crate::backend::Backend;
use crate::base::Intrinsics;
use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::vision::Instances;
use serde::Serialize;

/// Knobs of the search.
#[derive(Clone, Debug)]
pub struct CeilingSearchOptions {
    /// The lowest height tried is this far above the highest point the photo shows (metres).
    pub margin: f32,
    /// Heights tried this far apart...
    pub step: f32,
    /// ...up to this far above the highest point the photo shows...
    pub span: f32,
    /// ...and on, up to this far, while the best is the highest tried.
    pub max_span: f32,
    /// The chosen height is the highest whose error is within this fraction of the least: the error rises
    /// steeply above the true height and only gently below it (the free albedos and the other candidates make
    /// up for a low ceiling), so the least alone was found 20-40 cm low where the curve is flat (real room02).
    pub tolerance: f32,
    /// The candidates at each height, as the light stage makes them.
    pub lights: LightInitOptions,
    /// Their fit (every candidate kept: `removal_threshold` is not used).
    pub fit: LightFitOptions,
    /// Window instances with fewer depth pixels than this are not lights (`add_visible_windows`).
    pub window_min_pixels: usize,
}

impl Default for CeilingSearchOptions {
    fn default() -> Self {
        CeilingSearchOptions {
            margin: 0.05,
            step: 0.1,
            span: 0.65,
            max_span: 1.5,
            tolerance: 0.01,
            lights: LightInitOptions::default(),
            fit: LightFitOptions::default(),
            window_min_pixels: 20,
        }
    }
}

/// What the search tried and chose (heights above the floor, metres).
#[derive(Clone, Debug, Serialize)]
pub struct CeilingSearch {
    /// The highest point the photo shows (its depth's 99.8th percentile: a few stray pixels do not count).
    pub lowest: f32,
    /// The height before the search.
    pub start: f32,
    pub heights: Vec<f32>,
    /// The light fit's relative RMS error at each height.
    pub relative_rms: Vec<f32>,
    pub chosen: f32,
}

/// The heights above the floor of the points `depth` (camera-space z per pixel of `scene`'s camera, 0 = none)
/// shows, at percentile `q`.
fn highest_shown(scene: &Scene, depth: &[f32], floor_y: f32, q: f32) -> Option<f32> {
    let cam = &scene.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let k = Intrinsics::new(w, h, cam.fov_y_deg);
    let (right, up, fwd) = (cam.right(), cam.up, cam.forward);
    let mut ys: Vec<f32> = (0..w * h)
        .filter(|&p| depth[p] > 0.0 && depth[p].is_finite())
        .map(|p| {
            let c = k.point(p % w, p / w, depth[p]);
            (cam.origin + right * c.x + up * c.y + fwd * c.z).y - floor_y
        })
        .collect();
    if ys.is_empty() {
        return None;
    }
    ys.sort_by(f32::total_cmp);
    Some(ys[((ys.len() - 1) as f32 * q).round() as usize])
}

/// Moves `scene`'s ceiling (a room scene: `floor`, `ceiling`, `wall_x0` ... `wall_z1`) to the height whose
/// candidate lights fit `photo` best. `depth` is the photo's (at the camera's size), `windows` its instances
/// (the windows among them become lights, as in the light stage), `segments` the surfaces' masks whose albedos
/// the fit frees (may be empty). The scene's emitters are left as they are.
pub fn search_ceiling_height(
    backend: &mut dyn Backend,
    scene: &mut Scene,
    photo: &[f32],
    depth: &[f32],
    windows: Option<&Instances>,
    segments: &[Vec<f32>],
    opts: &CeilingSearchOptions,
) -> Result<CeilingSearch> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    if depth.len() != w * h {
        return Err(Error::Invalid(format!(
            "ceiling search: the depth has {} values, the camera {w}x{h}",
            depth.len()
        )));
    }
    if !(opts.step > 0.0 && opts.span >= 0.0 && opts.margin >= 0.0) {
        return Err(Error::Invalid("ceiling search: step must be > 0, span and margin >= 0".into()));
    }
    let y_of = |s: &Scene, name: &str| s.objects.iter().find(|o| o.name == name).map(|o| o.pose.translation.y);
    let (Some(floor_y), Some(start)) = (y_of(scene, "floor"), y_of(scene, "ceiling")) else {
        return Err(Error::Invalid("ceiling search: the scene has no room (floor and ceiling)".into()));
    };
    let lowest = highest_shown(scene, depth, floor_y, 0.998)
        .ok_or_else(|| Error::Invalid("ceiling search: the depth shows no point".into()))?;
    let first = lowest + opts.margin;
    // One set of candidates for every height, made at the lowest (where the camera sees the most of the
    // ceiling, so none is in view at any height tried), moved up with the ceiling: the fit then changes
    // smoothly with the height. Made afresh at each height, the grid's view culling changed the set and the
    // error jumped by a third between neighbouring heights (real room02).
    let mut base = scene.clone();
    let set_height = |s: &mut Scene, height: f32| {
        for o in s.objects.iter_mut() {
            if o.name == "ceiling" {
                o.pose.translation.y = floor_y + height;
            } else if o.name.starts_with("light_ceiling_") {
                o.pose.translation.y = floor_y + height - 0.01;
            } else if o.name.starts_with("light_window_wall_") {
                o.pose.translation.y = floor_y + 0.55 * height;
            }
        }
    };
    set_height(&mut base, first);
    let mut names = init_lights(&mut base, &opts.lights);
    if let Some(inst) = windows {
        names.extend(add_visible_windows(&mut base, Some(photo), depth, inst, opts.window_min_pixels));
    }
    let fit_at = |backend: &mut dyn Backend, height: f32| -> Result<f32> {
        let mut s = base.clone();
        set_height(&mut s, height);
        // Every candidate kept: an elimination step would never pay.
        let fit = LightFitOptions { removal_threshold: f32::NEG_INFINITY, ..opts.fit.clone() };
        Ok(fit_lights(backend, &s, &names, photo, segments, &fit)?.relative_rms_all)
    };
    let progress = crate::progress::activity("ceiling height search".to_string(), None);
    let (mut heights, mut errors): (Vec<f32>, Vec<f32>) = (vec![], vec![]);
    let mut k = 0;
    loop {
        let height = first + k as f32 * opts.step;
        let best_is_last =
            errors.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1)).map(|(i, _)| i + 1) == Some(errors.len());
        let within = height <= lowest + opts.span + 1e-4;
        if !(within || (best_is_last && height <= lowest + opts.max_span + 1e-4)) {
            break;
        }
        progress.advance();
        errors.push(fit_at(backend, height)?);
        heights.push(height);
        k += 1;
    }
    // Half a step either side of the best.
    let best = |hs: &[f32], es: &[f32]| hs[es.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1)).unwrap().0];
    let centre = best(&heights, &errors);
    for height in [centre - opts.step / 2.0, centre + opts.step / 2.0] {
        if height >= first {
            errors.push(fit_at(backend, height)?);
            heights.push(height);
        }
    }
    let least = errors.iter().copied().fold(f32::INFINITY, f32::min);
    let chosen = heights
        .iter()
        .zip(&errors)
        .filter(|(_, e)| **e <= least * (1.0 + opts.tolerance))
        .map(|(h, _)| *h)
        .fold(f32::MIN, f32::max);
    if let Some(c) = scene.objects.iter_mut().find(|o| o.name == "ceiling") {
        c.pose.translation.y = floor_y + chosen;
    }
    Ok(CeilingSearch { lowest, start: start - floor_y, heights, relative_rms: errors, chosen })
}
