//! A window's daylight shaped by direction (issue "Appearance", item 2: windows with an exterior, sky-like
//! radiance). Through a window a room sees the sky above the horizon and the ground below it, so the rays
//! that reach the window travelling up see more light than those travelling down: the window emits
//! `radiance * (1 + g d_y)` per channel (`scene::Emitter::sky_gradient`; the CIE overcast sky, (1 + 2 sin
//! elevation) / 3, is this line above the horizon). Rendering is linear in the radiance of each of two lobes,
//! sky (g = +1) and ground (g = -1), so the light fit's basis gains one unit render per window and the
//! non-negative least squares gives both lobes: a (1 + d_y) + b (1 - d_y) = (a + b)(1 + (a - b)/(a + b) d_y),
//! always within |g| <= 1. "Model no more than a scene needs": the shape is kept only where it lowers the
//! fit's relative error by `min_gain`, else the scene is left as it was.

use super::light_fit::{nnls_fit, unit_renders, FitTarget, LightFitOptions};
use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::scene::Scene;
use glam::Vec3;

/// Knobs of the window fit.
#[derive(Clone, Debug)]
pub struct WindowSkyOptions {
    /// The unit renders and the comparison (the light fit's own; `removal_threshold` is not used).
    pub fit: LightFitOptions,
    /// The shapes are kept when they lower the fit's relative RMS error by at least this (absolute).
    pub min_gain: f32,
}

impl Default for WindowSkyOptions {
    fn default() -> Self {
        WindowSkyOptions { fit: LightFitOptions::default(), min_gain: 0.01 }
    }
}

/// What the fit found: per window its sky gradient, both fits' errors, and whether the scene took them.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct WindowSky {
    pub windows: Vec<String>,
    pub sky_gradient: Vec<[f32; 3]>,
    /// Every light's radiance refitted with the windows as they were, and with their two lobes.
    pub relative_rms_as_they_were: f32,
    pub relative_rms_shaped: f32,
    pub kept: bool,
}

/// Fits the sky gradient of the emitters named `windows` together with every emitter's radiance to `photo`
/// (linear RGB, the camera's size), with each surface's albedo free where `segments` are given (as
/// `fit_lights`). Where the gradients lower the relative error by `min_gain` the scene takes them and the
/// radiances of that fit; otherwise it is left untouched.
pub fn fit_window_skies(
    backend: &mut dyn Backend,
    scene: &mut Scene,
    windows: &[String],
    photo: &[f32],
    segments: &[Vec<f32>],
    opts: &WindowSkyOptions,
) -> Result<WindowSky> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    if photo.len() != w * h * 3 {
        return Err(Error::Invalid(format!(
            "window sky fit: the photo has {} values, the camera renders {w}x{h} RGB",
            photo.len()
        )));
    }
    let lights: Vec<usize> = (0..scene.objects.len()).filter(|&i| scene.objects[i].emitter.is_some()).collect();
    let window_objects: Vec<usize> = windows
        .iter()
        .map(|n| {
            lights
                .iter()
                .copied()
                .find(|&i| &scene.objects[i].name == n)
                .ok_or_else(|| Error::Invalid(format!("window sky fit: '{n}' is not an emitter of the scene")))
        })
        .collect::<Result<_>>()?;
    let mut found = WindowSky {
        windows: windows.to_vec(),
        sky_gradient: window_objects
            .iter()
            .map(|&i| scene.objects[i].emitter.unwrap().sky_gradient.to_array())
            .collect(),
        relative_rms_as_they_were: 0.0,
        relative_rms_shaped: 0.0,
        kept: false,
    };
    if window_objects.is_empty() {
        return Ok(found);
    }
    let f = &opts.fit;
    let target = FitTarget::new(photo, w, h, f.downsample)
        .with_segments(segments, w, h, f.downsample)
        .with_agreement(&f.agreement, w, h, f.downsample)
        .white_lights(f.white);
    let target = target.tint_prior(f.tint_prior);
    let rel = |err: f64| (err / target.norm()).sqrt() as f32;
    // Columns: every light as it is (a window's from its lobes: its unit render is linear in the shape, and the
    // lobes take the same samples), then each window's sky lobe in its column and its ground lobe appended.
    let others: Vec<usize> = lights.iter().copied().filter(|i| !window_objects.contains(i)).collect();
    let progress = crate::progress::activity(
        format!(
            "window sky: unit renders of {} lights and of {} windows' sky and ground",
            others.len(),
            window_objects.len()
        ),
        Some(others.len() + 2 * window_objects.len()),
    );
    let mut basis = vec![vec![]; lights.len()];
    for (o, render) in others.iter().zip(unit_renders(backend, scene, &others, f, || progress.advance())?) {
        basis[lights.iter().position(|i| i == o).expect("a light")] = render;
    }
    let lobe = |scene: &Scene, object: usize, g: f32, backend: &mut dyn Backend| -> Result<Vec<f32>> {
        let mut s = scene.clone();
        s.objects[object].emitter.as_mut().expect("an emitter").sky_gradient = Vec3::splat(g);
        progress.advance();
        Ok(unit_renders(backend, &s, &[object], f, || {})?.remove(0))
    };
    let mut lobes = vec![];
    for &o in &window_objects {
        let (sky, ground) = (lobe(scene, o, 1.0, backend)?, lobe(scene, o, -1.0, backend)?);
        let g = scene.objects[o].emitter.expect("a light").sky_gradient;
        let column = lights.iter().position(|&i| i == o).expect("windows are lights");
        basis[column] = sky
            .iter()
            .zip(&ground)
            .enumerate()
            .map(|(k, (s, d))| 0.5 * ((1.0 + g[k % 3]) * s + (1.0 - g[k % 3]) * d))
            .collect();
        lobes.push((column, sky, ground));
    }
    drop(progress);
    let all: Vec<usize> = (0..basis.len()).collect();
    let (_, err_before) = nnls_fit(&basis, &target, &all);
    let mut columns = vec![];
    for (column, sky, ground) in lobes {
        basis[column] = sky;
        basis.push(ground);
        columns.push((column, basis.len() - 1));
    }
    let all: Vec<usize> = (0..basis.len()).collect();
    let (rad, err_shaped) = nnls_fit(&basis, &target, &all);
    found.relative_rms_as_they_were = rel(err_before);
    found.relative_rms_shaped = rel(err_shaped);
    found.sky_gradient = columns
        .iter()
        .map(|&(sky, ground)| {
            let (a, b) = (Vec3::from(rad[sky]), Vec3::from(rad[ground]));
            let sum = a + b;
            Vec3::select(sum.cmpgt(Vec3::ZERO), (a - b) / sum.max(Vec3::splat(1e-30)), Vec3::ZERO)
                .clamp(Vec3::splat(-1.0), Vec3::ONE)
                .to_array()
        })
        .collect();
    found.kept = found.relative_rms_as_they_were - found.relative_rms_shaped >= opts.min_gain;
    if found.kept {
        for (k, &o) in lights.iter().enumerate() {
            let e = scene.objects[o].emitter.as_mut().expect("a light");
            e.radiance = match columns.iter().position(|&(sky, _)| sky == k) {
                Some(j) => Vec3::from(rad[columns[j].0]) + Vec3::from(rad[columns[j].1]),
                None => Vec3::from(rad[k]),
            }
            .max(Vec3::splat(1e-6));
            if let Some(j) = window_objects.iter().position(|&x| x == o) {
                e.sky_gradient = Vec3::from(found.sky_gradient[j]);
            }
        }
    }
    Ok(found)
}
