//! A window the photo does not show, added after the light choice where the photo needs one (a forward step
//! after `fit_lights`' backward elimination). The candidates (`light_init`) have one window per unseen wall, at
//! the wall's middle; where along the wall a window is decides where its light falls on the floor and the walls
//! in view, so one near a corner is not that middle one dimmed, and the elimination drops it while a ceiling
//! light near the corner takes its light (real room08 with its true geometry and materials: the window 1.1 m
//! from the middle, the ceiling light beside it 3x too bright). Here each unseen wall gets a row of windows, one
//! per `window_cell`; each is fitted beside the lights the choice kept, and the one that lowers the fit's
//! relative RMS error most is added where it lowers it by at least `min_gain` (the elimination's own threshold:
//! a light that gains less would be removed again). Adding rather than offering the row to the elimination
//! leaves the ceiling lights' choice as it was (offered, the known-geometry test's two lights came out 17 and
//! 34 cm off instead of 3 and 6).

use super::light_fit::{nnls_fit, unit_renders, FitTarget, LightFitOptions};
use super::light_init::{init_lights, LightInitOptions};
use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::scene::Scene;
use glam::Vec3;
use serde::Serialize;

/// Knobs of the step.
#[derive(Clone, Debug)]
pub struct UnseenWindowOptions {
    /// The unit renders and the comparison (the light fit's; `removal_threshold` is not used).
    pub fit: LightFitOptions,
    /// Spacing of the windows tried along each unseen wall, metres.
    pub window_cell: f32,
    /// Least drop of the fit's relative RMS error for the best window to be added.
    pub min_gain: f32,
}

impl Default for UnseenWindowOptions {
    fn default() -> Self {
        UnseenWindowOptions { fit: LightFitOptions::default(), window_cell: 1.5, min_gain: 0.01 }
    }
}

/// What the step tried and did (result.json's `unseen_window`).
#[derive(Clone, Debug, Serialize)]
pub struct UnseenWindow {
    /// Each window tried and the fit's relative RMS error with it.
    pub tried: Vec<(String, f32)>,
    /// The fit's relative RMS error with the lights as they were (their radiances refitted).
    pub relative_rms_before: f32,
    /// The window added, if one was.
    pub added: Option<String>,
    /// The error after: with the added window, else as before.
    pub relative_rms_after: f32,
}

/// Tries a row of windows along each wall of `scene` the photo does not show beside its emitters (see the
/// module) and adds the best where it gains `min_gain`, the emitters then at the radiances of the fit with it;
/// else the scene is left as it was. With `segments` (surface masks, may be empty) each surface's albedo is free in the fit, as in
/// `fit_lights`. A scene without the room's named surfaces, or whose walls are all in view, is left as it is.
pub fn add_unseen_window(
    backend: &mut dyn Backend,
    scene: &mut Scene,
    photo: &[f32],
    segments: &[Vec<f32>],
    opts: &UnseenWindowOptions,
) -> Result<UnseenWindow> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    if photo.len() != w * h * 3 {
        return Err(Error::Invalid(format!("unseen window: the photo is not the camera's {w}x{h} RGB")));
    }
    if opts.window_cell.is_nan() || opts.window_cell <= 0.0 {
        return Err(Error::Invalid(format!("unseen window: window_cell {} is not a length", opts.window_cell)));
    }
    let lights: Vec<usize> = (0..scene.objects.len()).filter(|&i| scene.objects[i].emitter.is_some()).collect();
    if lights.is_empty() {
        return Err(Error::Invalid("unseen window: the scene has no lights to fit beside".into()));
    }
    // The row, from the candidates' own rule for which walls are unseen; a name the scene has is not tried.
    let mut probe = scene.clone();
    init_lights(&mut probe, &LightInitOptions { window_cell: opts.window_cell, ..Default::default() });
    let row: Vec<_> = probe
        .objects
        .into_iter()
        .filter(|o| o.name.starts_with("light_window_wall_") && scene.objects.iter().all(|x| x.name != o.name))
        .collect();
    let mut with_row = scene.clone();
    let first = with_row.objects.len();
    with_row.objects.extend(row.iter().cloned());
    let index: Vec<usize> = lights.iter().copied().chain(first..with_row.objects.len()).collect();
    let target = FitTarget::new(photo, w, h, opts.fit.downsample)
        .with_segments(segments, w, h, opts.fit.downsample)
        .with_agreement(&opts.fit.agreement, w, h, opts.fit.downsample)
        .white_lights(opts.fit.white)
        .tint_prior(opts.fit.tint_prior);
    let progress = crate::progress::activity(
        format!("unseen windows: unit renders of {} lights and {} windows", lights.len(), row.len()),
        Some(index.len()),
    );
    let basis = unit_renders(backend, &with_row, &index, &opts.fit, || progress.advance())?;
    drop(progress);
    let norm = target.norm();
    let rel = |err: f64| (err / norm).sqrt() as f32;
    let kept: Vec<usize> = (0..lights.len()).collect();
    let (_, err) = nnls_fit(&basis, &target, &kept);
    let before = rel(err);
    let mut tried = vec![];
    let mut best: Option<(usize, Vec<[f32; 3]>, f32)> = None;
    for (j, window) in row.iter().enumerate() {
        let active: Vec<usize> = kept.iter().copied().chain([lights.len() + j]).collect();
        let (r, e) = nnls_fit(&basis, &target, &active);
        tried.push((window.name.clone(), rel(e)));
        if best.as_ref().is_none_or(|b| rel(e) < b.2) {
            best = Some((j, r, rel(e)));
        }
    }
    let mut added = None;
    let mut after = before;
    if let Some((j, r, e)) = best.filter(|b| before - b.2 >= opts.min_gain) {
        // Every emitter at its radiance in the fit with the window (the basis holds the lights first, in their
        // order, then the row); without one the scene is left exactly as it was.
        for (k, &o) in lights.iter().enumerate() {
            set_radiance(scene, o, r[k]);
        }
        scene.objects.push(row[j].clone());
        let at = scene.objects.len() - 1;
        set_radiance(scene, at, r[lights.len() + j]);
        added = Some(row[j].name.clone());
        after = e;
    }
    Ok(UnseenWindow { tried, relative_rms_before: before, added, relative_rms_after: after })
}

fn set_radiance(scene: &mut Scene, object: usize, radiance: [f32; 3]) {
    if let Some(e) = scene.objects[object].emitter.as_mut() {
        e.radiance = Vec3::from(radiance).max(Vec3::splat(1e-6));
    }
}
