//! Ground-truth evaluation in scripts: `evaluate(scene, obs, TRUTH)` or `evaluate(scene, obs, TRUTH, #{spp})`
//! renders the fitted scene, compares it with the ground-truth scene file of the photo (`stages::evaluate`)
//! and records the errors in result.json as `evaluation`; it returns them too. With the photo's instance masks,
//! `evaluation.mask_iou` gives each placed object's IoU against its instance. The image error (`image.rmse_rel_1_8`)
//! is split into the render's Monte Carlo noise and the rest (`noise_rel_1_8`, `bias_rel_1_8`) by a second
//! render with other samples. For synthetic photos, where a truth exists: the examples, the tests and the
//! evaluation benchmark.

use super::api_support::{on_backend, rhai_err, Rr, RunRef};
use super::scene_api::SceneHandle;
use super::vision_api::ObsHandle;
use crate::error::Error;
use crate::render::SceneData;
use crate::scene::load_scene;
use rhai::{Dynamic, Engine, Map};
use std::path::Path;

fn evaluate(run: &RunRef, scene: &SceneHandle, obs: &ObsHandle, truth: &str, opts: &Map) -> crate::Result<Dynamic> {
    let mut spp = 16u32;
    for (k, v) in opts {
        match k.as_str() {
            "spp" => {
                spp =
                    v.as_int().map_err(|_| Error::Invalid("evaluate: 'spp' must be an integer".into()))?.clamp(1, 4096)
                        as u32
            }
            other => return Err(Error::Invalid(format!("evaluate: unknown option '{other}' (spp)"))),
        }
    }
    let truth = load_scene(Path::new(truth))?;
    let photo = &obs.0.photo;
    let mut fitted = scene.0.clone();
    (fitted.camera.width, fitted.camera.height) = (photo.width as u32, photo.height as u32);
    if photo.channels != 3 {
        return Err(Error::Invalid("evaluate: the photo must be RGB".into()));
    }
    fitted.settings.spp = spp;
    let data = SceneData::build(&fitted)?;
    let frame = on_backend(run, "evaluate", |b| b.render(&data, &fitted.settings, &|_, _| {}))?;
    // The same render with other samples: how much of the image error is the render's own noise
    // (`stages::noise_and_bias`; the true scene rendered at 16 spp is mostly noise against its photo).
    let mut repeat_settings = fitted.settings.clone();
    repeat_settings.seed = repeat_settings.seed.wrapping_add(1);
    let repeat = on_backend(run, "evaluate", |b| b.render(&data, &repeat_settings, &|_, _| {}))?;
    // Which model each placed object is (none when the geometry was given), and the split pieces merged into it.
    let placed: Vec<serde_json::Value> =
        run.borrow().recorded.get("objects_init").and_then(|o| o["placed"].as_array().cloned()).unwrap_or_default();
    let models: Vec<(String, String)> = placed
        .iter()
        .filter_map(|p| Some((p["name"].as_str()?.to_string(), p["chosen"]["model"].as_str()?.to_string())))
        .collect();
    let merged: Vec<(String, Vec<u16>)> = placed
        .iter()
        .filter_map(|p| {
            let ids = p["merged"].as_array()?.iter().filter_map(|v| u16::try_from(v.as_u64()?).ok()).collect();
            Some((p["name"].as_str()?.to_string(), ids))
        })
        .collect();
    // The truth's albedo and object images, at the photo's size (its own camera).
    let mut truth_view = truth.clone();
    (truth_view.camera.width, truth_view.camera.height) = (fitted.camera.width, fitted.camera.height);
    truth_view.settings.spp = spp;
    truth_view.settings.max_depth = 1;
    let truth_frame =
        on_backend(run, "evaluate", |b| b.render(&SceneData::build(&truth_view)?, &truth_view.settings, &|_, _| {}))?;
    let masks = obs.0.instances.as_ref().map(|m| (m, merged.as_slice()));
    let mut errors = crate::stages::evaluate(&fitted, &truth, &models, &frame, &truth_frame, &photo.data, masks);
    let clipped = |f: &crate::render::Frame| crate::vision::clip_like_photo(&f.radiance, &photo.data);
    let (noise, bias) =
        crate::stages::noise_and_bias(&clipped(&frame), &clipped(&repeat), &photo.data, photo.width, photo.height, 8);
    errors["image"]["noise_rel_1_8"] = serde_json::json!(noise);
    errors["image"]["bias_rel_1_8"] = serde_json::json!(bias);
    run.borrow_mut().recorded.insert("evaluation".into(), errors.clone());
    rhai::serde::to_dynamic(errors).map_err(|e| Error::Invalid(format!("evaluate: {e}")))
}

pub fn register(engine: &mut Engine, run: &RunRef) {
    let r = run.clone();
    engine.register_fn("evaluate", move |s: &mut SceneHandle, obs: ObsHandle, truth: &str| -> Rr<Dynamic> {
        evaluate(&r, s, &obs, truth, &Map::new()).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn("evaluate", move |s: &mut SceneHandle, obs: ObsHandle, truth: &str, opts: Map| -> Rr<Dynamic> {
        evaluate(&r, s, &obs, truth, &opts).map_err(rhai_err)
    });
}
