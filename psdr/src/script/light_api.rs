//! The light stage's initialisation in scripts: `lights_init(s)` replaces a room scene's emitters with the
//! candidate lights, `fit_lights(s, photo)` fits their radiances to the photo and removes the ones it does not
//! need (in place); the fit goes into result.json as `light_fit`. `windows_init(s, obs)` adds the windows the
//! photo shows as area lights, `ceiling_lights_init(s, obs)` the ceiling lights it shows. `place_lights(s, photo, #{step, min_step, size_factor, spp, downsample})` moves
//! and sizes the lights by pattern search (`stages::light_placement`), recorded as `light_placement`.
//! `light_pose_params(s, name, opts)` gives the `optimize` entries that move a light by gradient.
//! `search_ceiling_height(s, obs, opts)` places a ceiling the photo does not show where its candidate lights
//! fit the photo best (`stages::ceiling_search`), recorded as `ceiling_search`. `outline_lights(s, obs)`
//! refits the outlines of the lights the photo shows at their fitted radiances, recorded as `light_outlines`.
//! `fit_window_skies(s, photo, opts)` fits the visible windows' daylight shaped by direction
//! (`stages::window_sky`), recorded as `window_sky`. `add_unseen_window(s, photo, opts)` adds a window on a wall
//! the photo does not show where the photo needs one (`stages::unseen_window`), recorded as `unseen_window`.

use super::api_support::{check_photo, on_backend, option_number, rhai_err, Rr, RunRef};
use super::scene_api::SceneHandle;
use super::vision_api::ObsHandle;
use crate::error::Error;
use crate::loss::Tensor;
use crate::stages::{
    add_unseen_window, fit_lights, fit_window_skies, init_lights, refine_light_placement, search_ceiling_height,
    Agreement, CeilingSearchOptions, LightFitOptions, LightInitOptions, LightPlacementOptions, UnseenWindowOptions,
    WindowSkyOptions,
};
use glam::Vec3;
use rhai::{Array, Dynamic, Engine, Map};

fn number(k: &str, v: &Dynamic, what: &str) -> crate::Result<f64> {
    option_number(what, k, v)
}

/// A true/false option (false when absent).
fn flag(what: &str, opts: &Map, key: &str) -> crate::Result<bool> {
    opts.get(key).map_or(Ok(false), |v| {
        v.as_bool().map_err(|_| Error::Invalid(format!("{what}: '{key}' must be true or false")))
    })
}

/// Options every light fit reads apart from its numbers: the surfaces' masks, white lights, and where the
/// fitted geometry agrees with the segmentation.
const SHARED_KEYS: [&str; 4] = ["segments", "white", "agreement", "min_agreement"];

/// Default share of a compared block's pixels that must agree with the fitted geometry (`Agreement`, and
/// `geometry_agreement`'s blocks): the outlines' misfit of a well-placed pose stays in (real rooms with their
/// own models: 0-3 % of the light fit's blocks under it), a retrieved model that misses a quarter of a block
/// leaves it out (held out: 8-19 %). scripts/room.rhai names it `fit_min_agreement`.
pub(super) const MIN_AGREEMENT: f32 = 0.75;

/// An options map's `agreement` (a mask of the camera's size, `geometry_agreement`) and `min_agreement`;
/// without a mask, every pixel agrees.
pub(super) fn agreement(what: &str, scene: &SceneHandle, opts: &Map) -> crate::Result<Agreement> {
    let min_share = match opts.get("min_agreement") {
        Some(v) => (number("min_agreement", v, what)? as f32).clamp(0.0, 1.0),
        None => MIN_AGREEMENT,
    };
    let mask = mask_option(what, scene, opts, "agreement", "geometry_agreement(s, obs)")?;
    Ok(Agreement { mask: mask.unwrap_or_default(), min_share })
}

/// An options map's mask `key` (one channel, the camera's size; `from` says where one comes from), if given.
fn mask_option(what: &str, scene: &SceneHandle, opts: &Map, key: &str, from: &str) -> crate::Result<Option<Vec<f32>>> {
    let Some(v) = opts.get(key) else { return Ok(None) };
    let t =
        v.clone().try_cast::<Tensor>().ok_or_else(|| Error::Invalid(format!("{what}: '{key}' is a mask ({from})")))?;
    let img = t.value();
    let (w, h) = (scene.0.camera.width as usize, scene.0.camera.height as usize);
    if (img.width, img.height, img.channels) != (w, h, 1) {
        return Err(Error::Invalid(format!(
            "{what}: '{key}' is {}x{}x{}, the scene's camera renders {w}x{h} (one channel)",
            img.width, img.height, img.channels
        )));
    }
    Ok(Some(img.data.clone()))
}

/// The masks of an options map's `segments` (material name -> mask, as `material_segments` gives), none without.
fn surface_masks(what: &str, scene: &SceneHandle, photo: &Tensor, opts: &Map) -> crate::Result<Vec<Vec<f32>>> {
    let Some(v) = opts.get("segments") else { return Ok(vec![]) };
    let map = v.clone().try_cast::<Map>().ok_or_else(|| {
        Error::Invalid(format!("{what}: 'segments' maps material names to masks (material_segments)"))
    })?;
    Ok(super::material_api::segments(what, scene, photo, &map)?.1.into_iter().map(|s| s.mask).collect())
}

fn lights_init(scene: &mut SceneHandle, opts: &Map) -> crate::Result<Array> {
    let mut o = LightInitOptions::default();
    for (k, v) in opts {
        let n = number(k, v, "lights_init")? as f32;
        match k.as_str() {
            "cell" => o.cell = n.max(0.1),
            "scale" => o.scale = n.clamp(0.01, 1.0),
            "unseen_wall_fraction" => o.unseen_wall_fraction = n,
            "window_cell" => o.window_cell = n,
            other => {
                return Err(Error::Invalid(format!(
                    "lights_init: unknown option '{other}' (cell, scale, unseen_wall_fraction, window_cell)"
                )))
            }
        }
    }
    let names = init_lights(&mut scene.0, &o);
    if names.is_empty() {
        return Err(Error::Invalid(
            "lights_init: the scene has no room (floor, ceiling, wall_x0 ... wall_z1) to light".into(),
        ));
    }
    Ok(names.into_iter().map(Dynamic::from).collect())
}

fn fit(run: &RunRef, scene: &mut SceneHandle, photo: &Tensor, opts: &Map) -> crate::Result<Map> {
    let mut o = LightFitOptions::default();
    let segments = surface_masks("fit_lights", scene, photo, opts)?;
    o.white = flag("fit_lights", opts, "white")?;
    o.agreement = agreement("fit_lights", scene, opts)?;
    for (k, v) in opts.iter().filter(|(k, _)| !SHARED_KEYS.contains(&k.as_str())) {
        let n = number(k, v, "fit_lights")?;
        match k.as_str() {
            "downsample" => o.downsample = n.max(1.0) as usize,
            "spp" => o.spp = n.max(1.0) as u32,
            "max_depth" => o.max_depth = Some(n.max(1.0) as u32),
            "removal_threshold" => o.removal_threshold = n as f32,
            "seed" => o.seed = n.max(0.0) as u32,
            "tint_prior" => o.tint_prior = n.max(0.0) as f32,
            other => {
                return Err(Error::Invalid(format!(
                    "fit_lights: unknown option '{other}' (downsample, spp, max_depth, removal_threshold, seed, \
                     tint_prior, segments, white, agreement, min_agreement)"
                )))
            }
        }
    }
    let img = photo.value();
    check_photo("fit_lights", &scene.0, img)?;
    let names: Vec<String> = scene.0.objects.iter().filter(|o| o.emitter.is_some()).map(|o| o.name.clone()).collect();
    let f = on_backend(run, "fit_lights", |b| fit_lights(b, &scene.0, &names, &img.data, &segments, &o))?;
    // Kept lights get their radiance; the others leave the scene.
    scene
        .0
        .objects
        .retain(|obj| obj.emitter.is_none() || f.names.iter().zip(&f.kept).any(|(n, k)| *k && n == &obj.name));
    for (i, n) in f.names.iter().enumerate() {
        if let Some(e) = scene.0.objects.iter_mut().find(|x| &x.name == n).and_then(|x| x.emitter.as_mut()) {
            e.radiance = Vec3::from(f.radiance[i]).max(Vec3::splat(1e-6));
        }
    }
    let mut out = Map::new();
    let kept: Array = f.names.iter().zip(&f.kept).filter(|(_, k)| **k).map(|(n, _)| Dynamic::from(n.clone())).collect();
    out.insert("kept".into(), Dynamic::from(kept));
    out.insert("relative_rms".into(), Dynamic::from(f.relative_rms as f64));
    out.insert("luminance_ratio".into(), Dynamic::from(f.luminance_ratio as f64));
    let v = serde_json::to_value(&f).map_err(|e| Error::Invalid(e.to_string()))?;
    let mut run = run.borrow_mut();
    run.recorded.insert("light_fit".into(), v);
    // Every fit that removed lights is kept (later fits overwrite `light_fit`), for the report's light list.
    let removed: Vec<&String> = f.names.iter().zip(&f.kept).filter(|(_, k)| !**k).map(|(n, _)| n).collect();
    if !removed.is_empty() {
        let entry = serde_json::json!({ "removed": removed, "candidates": f.names.len(),
                                        "relative_rms_all": f.relative_rms_all, "relative_rms_kept": f.relative_rms });
        push_removed(&mut run.recorded, entry);
    }
    Ok(out)
}

/// Sets the light fit's own number option `k` of `o` (`downsample`, `spp`, `max_depth`, `seed`, `tint_prior`);
/// false for any other key, which the caller then reads.
fn fit_number(o: &mut LightFitOptions, k: &str, n: f64) -> bool {
    match k {
        "downsample" => o.downsample = n.max(1.0) as usize,
        "spp" => o.spp = n.max(1.0) as u32,
        "max_depth" => o.max_depth = Some(n.max(1.0) as u32),
        "seed" => o.seed = n.max(0.0) as u32,
        "tint_prior" => o.tint_prior = n.max(0.0) as f32,
        _ => return false,
    }
    true
}

/// `fit_window_skies(s, photo, #{spp, downsample, white, tint_prior, segments, min_gain, windows})`: the
/// windows' sky gradients (by default every window the photo shows, `is_visible_window`) fitted with every
/// light's radiance; kept where they lower the fit's relative error by `min_gain`. Returns the record.
fn window_skies(run: &RunRef, scene: &mut SceneHandle, photo: &Tensor, opts: &Map) -> crate::Result<Dynamic> {
    const WHAT: &str = "fit_window_skies";
    let mut o = WindowSkyOptions::default();
    let segments = surface_masks(WHAT, scene, photo, opts)?;
    o.fit.white = flag(WHAT, opts, "white")?;
    o.fit.agreement = agreement(WHAT, scene, opts)?;
    let mut windows: Vec<String> = scene
        .0
        .objects
        .iter()
        .filter(|x| x.emitter.is_some() && crate::stages::is_visible_window(&x.name))
        .map(|x| x.name.clone())
        .collect();
    for (k, v) in opts.iter().filter(|(k, _)| !SHARED_KEYS.contains(&k.as_str())) {
        if k.as_str() == "windows" {
            let list = v.clone().into_typed_array::<rhai::ImmutableString>();
            let list = list.map_err(|_| Error::Invalid(format!("{WHAT}: windows must be an array of names")))?;
            windows = list.iter().map(|n| n.to_string()).collect();
            continue;
        }
        let n = number(k, v, WHAT)?;
        if fit_number(&mut o.fit, k, n) {
            continue;
        }
        match k.as_str() {
            "min_gain" => o.min_gain = n as f32,
            other => {
                return Err(Error::Invalid(format!(
                    "{WHAT}: unknown option '{other}' (downsample, spp, max_depth, seed, tint_prior, min_gain, \
                     windows, segments, white, agreement, min_agreement)"
                )))
            }
        }
    }
    let img = photo.value();
    check_photo(WHAT, &scene.0, img)?;
    let found = on_backend(run, WHAT, |b| fit_window_skies(b, &mut scene.0, &windows, &img.data, &segments, &o))?;
    record_returned(run, "window_sky", &found)
}

/// `add_unseen_window(s, photo, #{spp, downsample, white, tint_prior, segments, window_cell, min_gain})`: a
/// row of windows along each wall the photo does not show tried beside the scene's lights, the best added
/// where it lowers the fit's relative error by `min_gain` (`stages::unseen_window`). Recorded as
/// `unseen_window`; returns the record.
fn unseen_window(run: &RunRef, scene: &mut SceneHandle, photo: &Tensor, opts: &Map) -> crate::Result<Dynamic> {
    const WHAT: &str = "add_unseen_window";
    let mut o = UnseenWindowOptions::default();
    let segments = surface_masks(WHAT, scene, photo, opts)?;
    o.fit.white = flag(WHAT, opts, "white")?;
    o.fit.agreement = agreement(WHAT, scene, opts)?;
    for (k, v) in opts.iter().filter(|(k, _)| !SHARED_KEYS.contains(&k.as_str())) {
        let n = number(k, v, WHAT)?;
        if fit_number(&mut o.fit, k, n) {
            continue;
        }
        match k.as_str() {
            "window_cell" => o.window_cell = n as f32,
            "min_gain" => o.min_gain = n as f32,
            other => {
                return Err(Error::Invalid(format!(
                    "{WHAT}: unknown option '{other}' (downsample, spp, max_depth, seed, tint_prior, window_cell, \
                     min_gain, segments, white, agreement, min_agreement)"
                )))
            }
        }
    }
    let img = photo.value();
    check_photo(WHAT, &scene.0, img)?;
    let found = on_backend(run, WHAT, |b| add_unseen_window(b, &mut scene.0, &img.data, &segments, &o))?;
    record_returned(run, "unseen_window", &found)
}

/// Records `value` in result.json under `key` and returns it to the script.
fn record_returned(run: &RunRef, key: &str, value: &impl serde::Serialize) -> crate::Result<Dynamic> {
    let v = serde_json::to_value(value).map_err(|e| Error::Invalid(e.to_string()))?;
    run.borrow_mut().recorded.insert(key.into(), v.clone());
    rhai::serde::to_dynamic(v).map_err(|e| Error::Invalid(e.to_string()))
}

/// Appends one entry to `lights_removed` (every fit or merge that removed lights, for the report's light list).
fn push_removed(recorded: &mut serde_json::Map<String, serde_json::Value>, entry: serde_json::Value) {
    match recorded.entry("lights_removed").or_insert_with(|| serde_json::json!([])) {
        serde_json::Value::Array(list) => list.push(entry),
        other => *other = serde_json::json!([entry]),
    }
}

/// `ceiling_lights_init(s, obs)`: the ceiling lights the photo shows, as area lights where their pixels are
/// (after `lights_init`, which replaces every emitter).
fn ceiling_lights_init(scene: &mut SceneHandle, obs: &ObsHandle, opts: &Map) -> crate::Result<Array> {
    let mut min_pixels = 6usize;
    for (k, v) in opts {
        match k.as_str() {
            "min_pixels" => min_pixels = number(k, v, "ceiling_lights_init")?.max(0.0) as usize,
            other => return Err(Error::Invalid(format!("ceiling_lights_init: unknown option '{other}' (min_pixels)"))),
        }
    }
    check_photo("ceiling_lights_init", &scene.0, &obs.0.photo)?;
    let depth = obs.0.require_depth()?;
    let names = crate::stages::add_visible_ceiling_lights(
        &mut scene.0,
        &obs.0.photo.data,
        &depth.image.data,
        obs.0.instances.as_ref(),
        min_pixels,
    );
    Ok(names.into_iter().map(Dynamic::from).collect())
}

/// `windows_init(s, obs)`: the windows the photo shows, as area lights (after `lights_init`, which replaces
/// every emitter).
fn windows_init(scene: &mut SceneHandle, obs: &ObsHandle, opts: &Map) -> crate::Result<Array> {
    let mut min_pixels = 20usize;
    for (k, v) in opts {
        match k.as_str() {
            "min_pixels" => min_pixels = number(k, v, "windows_init")?.max(0.0) as usize,
            other => return Err(Error::Invalid(format!("windows_init: unknown option '{other}' (min_pixels)"))),
        }
    }
    let depth = obs.0.require_depth()?;
    let inst = obs.0.require_instances()?;
    let names =
        crate::stages::add_visible_windows(&mut scene.0, Some(&obs.0.photo.data), &depth.image.data, inst, min_pixels);
    Ok(names.into_iter().map(Dynamic::from).collect())
}

/// `outline_lights(s, obs, #{margin})`: the outlines of the lights the photo shows refitted to its pixels at
/// their fitted radiances, each edge within `margin` pixels (2) (`stages::fit_light_outlines`), recorded as
/// `light_outlines`; returns the refitted lights' names.
fn outline_lights(run: &RunRef, scene: &mut SceneHandle, obs: &ObsHandle, opts: &Map) -> crate::Result<Array> {
    let mut margin = 2.0f32;
    for (k, v) in opts {
        match k.as_str() {
            "margin" => margin = number(k, v, "outline_lights")?.max(0.0) as f32,
            other => return Err(Error::Invalid(format!("outline_lights: unknown option '{other}' (margin)"))),
        }
    }
    check_photo("outline_lights", &scene.0, &obs.0.photo)?;
    let inst = obs.0.instances.as_ref().filter(|i| i.ids.len() == obs.0.photo.width * obs.0.photo.height);
    let outlines = crate::stages::fit_light_outlines(&mut scene.0, &obs.0.photo.data, inst, margin);
    let v = serde_json::to_value(&outlines).map_err(|e| Error::Invalid(e.to_string()))?;
    run.borrow_mut().recorded.insert("light_outlines".into(), v);
    Ok(outlines.into_iter().map(|o| Dynamic::from(o.name)).collect())
}

fn place(run: &RunRef, scene: &mut SceneHandle, photo: &Tensor, opts: &Map) -> crate::Result<Dynamic> {
    let mut o = LightPlacementOptions::default();
    let segments = surface_masks("place_lights", scene, photo, opts)?;
    o.render.white = flag("place_lights", opts, "white")?;
    o.render.agreement = agreement("place_lights", scene, opts)?;
    let windows = mask_option("place_lights", scene, opts, "windows", "obs.class_mask(\"window\")")?;
    o.window_pixels = windows.unwrap_or_default().iter().map(|v| *v > 0.5).collect();
    for (k, v) in opts.iter().filter(|(k, _)| !SHARED_KEYS.contains(&k.as_str()) && k.as_str() != "windows") {
        let n = number(k, v, "place_lights")?;
        match k.as_str() {
            "step" => o.step = n as f32,
            "min_step" => o.min_step = n as f32,
            "size_factor" => o.size_factor = n as f32,
            "merge" => o.merge_threshold = n.max(0.0) as f32,
            "edge_max_side" => o.edge_max_side = n.max(0.05) as f32,
            "window_max_side" => o.window_max_side = n.max(0.05) as f32,
            "min_size" => o.size_range.0 = n as f32,
            "max_size" => o.size_range.1 = n as f32,
            "spp" => o.render.spp = n.max(1.0) as u32,
            "downsample" => o.render.downsample = n.max(1.0) as usize,
            "tint_prior" => o.render.tint_prior = n.max(0.0) as f32,
            other => {
                return Err(Error::Invalid(format!(
                    "place_lights: unknown option '{other}' (step, min_step, size_factor, merge, edge_max_side, \
                     window_max_side, windows, min_size, max_size, spp, downsample, tint_prior, segments, white, \
                     agreement, min_agreement)"
                )))
            }
        }
    }
    let img = photo.value();
    check_photo("place_lights", &scene.0, img)?;
    let placed =
        on_backend(run, "place_lights", |b| refine_light_placement(b, &mut scene.0, &img.data, &segments, &o))?;
    let v = serde_json::to_value(&placed).map_err(|e| Error::Invalid(e.to_string()))?;
    let mut run = run.borrow_mut();
    run.recorded.insert("light_placement".into(), v.clone());
    // A merged light leaves the scene like a removed one: it goes in the report's list with what took it.
    for (i, m) in placed.merged.iter().enumerate() {
        let entry = serde_json::json!({ "removed": [format!("{} (merged into {})", m.removed, m.into)],
                                        "candidates": placed.names.len() + placed.merged.len() - i,
                                        "relative_rms_all": m.relative_rms_before,
                                        "relative_rms_kept": m.relative_rms_after });
        push_removed(&mut run.recorded, entry);
    }
    rhai::serde::to_dynamic(v).map_err(|e| Error::Invalid(e.to_string()))
}

/// `search_ceiling_height(s, obs, #{...})`: where the photo shows the ceiling on at least `min_pixels` pixels
/// with depth, nothing changes (`seen: true`); else the ceiling moves to the height the light fit prefers.
fn ceiling_height(run: &RunRef, scene: &mut SceneHandle, obs: &ObsHandle, opts: &Map) -> crate::Result<Dynamic> {
    const WHAT: &str = "search_ceiling_height";
    let photo = Tensor::constant(obs.0.photo.clone());
    check_photo(WHAT, &scene.0, photo.value())?;
    let mut o = CeilingSearchOptions::default();
    o.fit.white = flag(WHAT, opts, "white")?;
    o.fit.agreement = agreement(WHAT, scene, opts)?;
    let segments = surface_masks(WHAT, scene, &photo, opts)?;
    let mut min_pixels = 30usize;
    for (k, v) in opts.iter().filter(|(k, _)| !SHARED_KEYS.contains(&k.as_str())) {
        let n = number(k, v, WHAT)?;
        match k.as_str() {
            "margin" => o.margin = n as f32,
            "step" => o.step = n as f32,
            "span" => o.span = n as f32,
            "max_span" => o.max_span = n as f32,
            "tolerance" => o.tolerance = (n as f32).max(0.0),
            "cell" => o.lights.cell = (n as f32).max(0.1),
            "spp" => o.fit.spp = n.max(1.0) as u32,
            "downsample" => o.fit.downsample = n.max(1.0) as usize,
            "seed" => o.fit.seed = n.max(0.0) as u32,
            "max_depth" => o.fit.max_depth = Some(n.max(1.0) as u32),
            "min_pixels" => min_pixels = n.max(0.0) as usize,
            other => {
                return Err(Error::Invalid(format!(
                    "{WHAT}: unknown option '{other}' (margin, step, span, max_span, tolerance, cell, spp, downsample, \
                     seed, max_depth, min_pixels, segments, white, agreement, min_agreement)"
                )))
            }
        }
    }
    let depth = &obs.0.require_depth()?.image.data;
    let inst = obs.0.instances.as_ref();
    let ceiling_pixels = inst.map_or(0, |i| {
        let ceiling = i.class_mask("ceiling");
        ceiling.iter().zip(depth).filter(|(m, d)| **m > 0.0 && **d > 0.0).count()
    });
    let record = if ceiling_pixels >= min_pixels {
        serde_json::json!({ "seen": true, "pixels": ceiling_pixels })
    } else {
        let img = &photo.value().data;
        let found = on_backend(run, WHAT, |b| search_ceiling_height(b, &mut scene.0, img, depth, inst, &segments, &o))?;
        let mut v = serde_json::to_value(&found).map_err(|e| Error::Invalid(e.to_string()))?;
        v["seen"] = serde_json::json!(false);
        v["pixels"] = serde_json::json!(ceiling_pixels);
        v
    };
    run.borrow_mut().recorded.insert("ceiling_search".into(), record.clone());
    rhai::serde::to_dynamic(record).map_err(|e| Error::Invalid(e.to_string()))
}

/// `light_pose_params(s, name, #{size_range, lr, size_lr})`: `optimize` params entries that move light `name` by
/// gradient along its own plane inside the room and resize it (`stages::light_motion`); none when it may not
/// move.
fn pose_params(scene: &SceneHandle, name: &str, opts: &Map) -> crate::Result<Array> {
    let (mut range, mut lr, mut size_lr) = ((0.7f32, 1.4f32), 0.02, 0.02);
    for (k, v) in opts {
        match k.as_str() {
            "size_range" => {
                let a = v.clone().try_cast::<Array>().filter(|a| a.len() == 2).ok_or_else(|| {
                    Error::Invalid("light_pose_params: size_range is [smallest, largest] of the size now".into())
                })?;
                let f = |x: &Dynamic| number("size_range", x, "light_pose_params").map(|f| f as f32);
                range = (f(&a[0])?, f(&a[1])?);
            }
            "lr" => lr = number(k, v, "light_pose_params")?,
            "size_lr" => size_lr = number(k, v, "light_pose_params")?,
            other => {
                return Err(Error::Invalid(format!(
                    "light_pose_params: unknown option '{other}' (size_range, lr, size_lr)"
                )))
            }
        }
    }
    let m = crate::stages::light_motion(&scene.0, name, range)?;
    let floats = |v: Vec3| -> Array { v.to_array().iter().map(|&f| Dynamic::from_float(f as f64)).collect() };
    let mut out = Array::new();
    if let (Some(axes), Some((lo, hi))) = (&m.plane_axes, m.translation) {
        let mut t = Map::new();
        t.insert("select".into(), format!("object/{name}/translation").into());
        t.insert("free".into(), axes.clone().into());
        t.insert("min".into(), floats(lo).into());
        t.insert("max".into(), floats(hi).into());
        t.insert("lr".into(), Dynamic::from_float(lr));
        out.push(t.into());
    }
    let mut sc = Map::new();
    sc.insert("select".into(), format!("object/{name}/scale").into());
    sc.insert("free".into(), "xy".into());
    sc.insert("min".into(), floats(m.scale.0).into());
    sc.insert("max".into(), floats(m.scale.1).into());
    sc.insert("lr".into(), Dynamic::from_float(size_lr));
    out.push(sc.into());
    Ok(out)
}

pub fn register(engine: &mut Engine, run: &RunRef) {
    engine.register_fn("light_pose_params", |s: &mut SceneHandle, name: &str| -> Rr<Array> {
        pose_params(s, name, &Map::new()).map_err(rhai_err)
    });
    engine.register_fn("light_pose_params", |s: &mut SceneHandle, name: &str, opts: Map| -> Rr<Array> {
        pose_params(s, name, &opts).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn("place_lights", move |s: &mut SceneHandle, photo: Tensor, opts: Map| -> Rr<Dynamic> {
        place(&r, s, &photo, &opts).map_err(rhai_err)
    });
    engine.register_fn("windows_init", |s: &mut SceneHandle, obs: ObsHandle| -> Rr<Array> {
        windows_init(s, &obs, &Map::new()).map_err(rhai_err)
    });
    engine.register_fn("windows_init", |s: &mut SceneHandle, obs: ObsHandle, opts: Map| -> Rr<Array> {
        windows_init(s, &obs, &opts).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn("search_ceiling_height", move |s: &mut SceneHandle, obs: ObsHandle, opts: Map| -> Rr<Dynamic> {
        ceiling_height(&r, s, &obs, &opts).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn("outline_lights", move |s: &mut SceneHandle, obs: ObsHandle| -> Rr<Array> {
        outline_lights(&r, s, &obs, &Map::new()).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn("outline_lights", move |s: &mut SceneHandle, obs: ObsHandle, opts: Map| -> Rr<Array> {
        outline_lights(&r, s, &obs, &opts).map_err(rhai_err)
    });
    engine.register_fn("is_visible_window", crate::stages::is_visible_window);
    engine.register_fn("is_visible_light", crate::stages::is_visible_light);
    engine.register_fn("is_edge_ceiling_light", crate::stages::is_edge_ceiling_light);
    engine.register_fn("ceiling_lights_init", |s: &mut SceneHandle, obs: ObsHandle| -> Rr<Array> {
        ceiling_lights_init(s, &obs, &Map::new()).map_err(rhai_err)
    });
    engine.register_fn("ceiling_lights_init", |s: &mut SceneHandle, obs: ObsHandle, opts: Map| -> Rr<Array> {
        ceiling_lights_init(s, &obs, &opts).map_err(rhai_err)
    });
    engine.register_fn("lights_init", |s: &mut SceneHandle| -> Rr<Array> {
        lights_init(s, &Map::new()).map_err(rhai_err)
    });
    engine.register_fn("lights_init", |s: &mut SceneHandle, opts: Map| -> Rr<Array> {
        lights_init(s, &opts).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn("add_unseen_window", move |s: &mut SceneHandle, photo: Tensor, opts: Map| -> Rr<Dynamic> {
        unseen_window(&r, s, &photo, &opts).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn("fit_window_skies", move |s: &mut SceneHandle, photo: Tensor, opts: Map| -> Rr<Dynamic> {
        window_skies(&r, s, &photo, &opts).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn("fit_lights", move |s: &mut SceneHandle, photo: Tensor| -> Rr<Map> {
        fit(&r, s, &photo, &Map::new()).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn("fit_lights", move |s: &mut SceneHandle, photo: Tensor, opts: Map| -> Rr<Map> {
        fit(&r, s, &photo, &opts).map_err(rhai_err)
    });
}
