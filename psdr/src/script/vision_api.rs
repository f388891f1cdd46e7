//! Observations and the room stage in scripts: `observe(PHOTO)`, `obs.photo`, `obs.unclipped` (1 where the
//! photo is not clipped), `obs.depth`, `obs.fov`, `obs.width`, `obs.height`, `obs.class_mask(class)`,
//! `obs.classes()`, `obs.resized(long_side)` (the working size), `obs.photo_detail(working, long_side)` (the
//! photo over the working observations' view at up to `long_side` pixels: the texture search's crops),
//! `scene.match_photo(obs)` (the camera renders that photo's size and field of view), and `room_init(obs)` (the
//! room box and camera as a scene).

use super::api_support::{rhai_err, Rr, RunRef};
use super::scene_api::SceneHandle;
use crate::base::Intrinsics;
use crate::error::Error;
use crate::loss::{Image, Tensor};
use crate::stages::{init_room, room_scene, RoomInitOptions};
use crate::vision::{ObservationInputs, Observations};
use rhai::{Array, Dynamic, Engine, Map};
use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// A photo's resolved observations.
#[derive(Clone)]
pub struct ObsHandle(pub Rc<Observations>);

fn observe(run: &RunRef, path: &str, opts: &Map) -> Rr<ObsHandle> {
    // The run's photo takes the command line's observation flags; options given here override them.
    let flags = run.borrow().options.observations.clone().filter(|o| o.photo == Path::new(path));
    let mut inputs = flags.unwrap_or_else(|| ObservationInputs::new(Path::new(path)));
    for (k, v) in opts {
        let text = || {
            v.clone().into_string().map_err(|_| rhai_err(Error::Invalid(format!("observe: '{k}' must be a string"))))
        };
        match k.as_str() {
            "depth" => inputs.depth = Some(PathBuf::from(text()?)),
            "masks" => inputs.masks = Some(PathBuf::from(text()?)),
            "labels" => inputs.labels = Some(PathBuf::from(text()?)),
            "models" => inputs.models = Some(PathBuf::from(text()?)),
            "depth_units" => inputs.depth_units = text()?.parse().map_err(|e: String| rhai_err(Error::Invalid(e)))?,
            "fov" | "camera_height" | "fov_max_sigma" => {
                let f = v.as_float().or_else(|_| v.as_int().map(|i| i as f64));
                let f = f.map_err(|_| rhai_err(Error::Invalid(format!("observe: '{k}' must be a number"))))? as f32;
                match k.as_str() {
                    "fov" => inputs.fov_y_deg = Some(f),
                    "camera_height" => inputs.camera_height = f,
                    _ => inputs.fov_max_sigma_deg = f,
                }
            }
            other => {
                return Err(rhai_err(Error::Invalid(format!(
                    "observe: unknown option '{other}' (depth, depth_units, masks, labels, models, fov, camera_height, fov_max_sigma)"
                ))))
            }
        }
    }
    let obs = Observations::resolve(&inputs).map_err(rhai_err)?;
    // Where each quantity came from and what was assumed goes into result.json.
    let summary = serde_json::json!({
        "photo": path,
        "sources": obs.sources,
        "warnings": obs.warnings,
        "fov_y_deg": obs.fov_y_deg,
        "fov_estimate": obs.fov_estimate,
        "depth_calibration": obs.depth_calibration,
    });
    let mut r = run.borrow_mut();
    if !r.options.quiet {
        for w in &obs.warnings {
            eprintln!("warning: {w}");
        }
    }
    r.recorded.insert("observations".into(), summary);
    Ok(ObsHandle(Rc::new(obs)))
}

fn class_mask(o: &Observations, class: &str) -> crate::Result<Tensor> {
    let m = o.require_instances()?;
    Ok(Tensor::constant(Image::new(m.width, m.height, 1, m.class_mask(class))?))
}

fn room(run: &RunRef, o: &Observations, opts: &Map) -> crate::Result<SceneHandle> {
    let mut ro = RoomInitOptions::default();
    for (k, v) in opts {
        let num = v
            .as_float()
            .or_else(|_| v.as_int().map(|i| i as f64))
            .map_err(|_| Error::Invalid(format!("room_init: '{k}' must be a number")))?;
        match k.as_str() {
            "erode" => ro.erode = num.max(0.0) as usize,
            "plane_tolerance" => ro.plane_tolerance = num as f32,
            "ransac_iters" => ro.ransac_iters = num.max(1.0) as usize,
            "seed" => ro.seed = num as u64,
            "wall_angle_deg" => ro.wall_angle_deg = num as f32,
            "unseen_wall_margin" => ro.unseen_wall_margin = num as f32,
            other => {
                return Err(Error::Invalid(format!(
                    "room_init: unknown option '{other}' (erode, plane_tolerance, ransac_iters, seed, wall_angle_deg, \
                     unseen_wall_margin)"
                )))
            }
        }
    }
    let depth = o.require_depth()?;
    let fov = o.require_fov()?;
    let inst = o.require_instances()?;
    let as_bool = |c: &str| inst.class_mask(c).into_iter().map(|v| v > 0.5).collect::<Vec<bool>>();
    let k = Intrinsics::new(o.photo.width, o.photo.height, fov);
    // Relative depth that is not affine in distance: the box from the photo's lines and masks (observations).
    let (e, from) = match &o.room_layout {
        Some(layout) => (layout.clone(), "room layout from the photo's lines and masks"),
        None => (
            init_room(&depth.image.data, &as_bool("floor"), &as_bool("wall"), &as_bool("ceiling"), &k, &ro)?,
            "depth and masks",
        ),
    };
    let mut v = serde_json::to_value(&e).map_err(|e| Error::Invalid(e.to_string()))?;
    v["from"] = from.into();
    run.borrow_mut().recorded.insert("room_init".into(), v);
    Ok(SceneHandle(room_scene(&e, fov, o.photo.width as u32, o.photo.height as u32)))
}

/// The embedding of an image (a tensor's value) by the encoder at `model` (loaded once per path and run).
fn embedding(
    cache: &RefCell<Vec<(PathBuf, crate::vision::OnnxModel)>>,
    img: &Tensor,
    model: &str,
) -> crate::Result<Array> {
    let path = PathBuf::from(model);
    let mut c = cache.borrow_mut();
    if !c.iter().any(|(p, _)| *p == path) {
        let m = crate::vision::load_embedding_model(&path)?;
        c.push((path.clone(), m));
    }
    let m =
        c.iter_mut().find(|(p, _)| *p == path).map(|(_, m)| m).ok_or_else(|| Error::Invalid("model cache".into()))?;
    let e = crate::vision::embed(m, img.value())?;
    Ok(e.into_iter().map(|v| Dynamic::from(v as f64)).collect())
}

pub fn register(engine: &mut Engine, run: &RunRef) {
    let cache: Rc<RefCell<Vec<(PathBuf, crate::vision::OnnxModel)>>> = Rc::default();
    engine.register_fn("embedding", move |img: Tensor, model: &str| -> Rr<Array> {
        embedding(&cache, &img, model).map_err(rhai_err)
    });
    engine.register_fn("cosine", |a: Array, b: Array| -> Rr<f64> {
        if a.len() != b.len() || a.is_empty() {
            return Err(rhai_err(Error::Invalid(format!("cosine: vectors of {} and {} numbers", a.len(), b.len()))));
        }
        let f = |v: &Dynamic| v.as_float().unwrap_or(f64::NAN);
        let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
        for (x, y) in a.iter().zip(&b) {
            let (x, y) = (f(x), f(y));
            (ab, aa, bb) = (ab + x * y, aa + x * x, bb + y * y);
        }
        Ok(ab / (aa * bb).sqrt().max(1e-30))
    });
    // A file of the run's models folder (--models, PSDR_MODELS, the cache), or "" where it has none: the
    // optional models (the CLIP image tower) are used when `psdr models fetch` put them there.
    let r = run.clone();
    engine.register_fn("models_file", move |name: &str| -> String {
        let run = r.borrow();
        let folder =
            run.options.observations.as_ref().map_or_else(|| crate::models::models_folder(None), |o| o.models.clone());
        folder.map(|d| d.join(name)).filter(|p| p.is_file()).map(|p| p.display().to_string()).unwrap_or_default()
    });
    engine.register_type_with_name::<ObsHandle>("Observations");
    let r = run.clone();
    engine.register_fn("observe", move |path: &str| observe(&r, path, &Map::new()));
    let r = run.clone();
    engine.register_fn("observe", move |path: &str, opts: Map| observe(&r, path, &opts));
    engine.register_get("photo", |o: &mut ObsHandle| Tensor::constant(o.0.photo.clone()));
    engine.register_get("unclipped", |o: &mut ObsHandle| -> Rr<Tensor> {
        let p = &o.0.photo;
        let mask = crate::vision::unclipped(&p.data, p.width);
        Ok(Tensor::constant(Image::new(p.width, p.height, 1, mask).map_err(rhai_err)?))
    });
    engine.register_get("depth", |o: &mut ObsHandle| -> Rr<Tensor> {
        Ok(Tensor::constant(o.0.require_depth().map_err(rhai_err)?.image.clone()))
    });
    engine.register_get("fov", |o: &mut ObsHandle| -> Rr<f64> { Ok(o.0.require_fov().map_err(rhai_err)? as f64) });
    engine.register_get("width", |o: &mut ObsHandle| o.0.photo.width as i64);
    engine.register_get("height", |o: &mut ObsHandle| o.0.photo.height as i64);
    let r = run.clone();
    engine.register_fn("resized", move |o: &mut ObsHandle, long_side: i64| -> Rr<ObsHandle> {
        let n = usize::try_from(long_side).map_err(|_| {
            rhai_err(Error::Invalid(format!("resized: {long_side} is not a size in pixels (0: as is)")))
        })?;
        let obs = o.0.resized(n).map_err(rhai_err)?;
        let mut c = r.borrow_mut();
        if let Some(v) = c.recorded.get_mut("observations") {
            v["working_size"] = serde_json::json!([obs.photo.width, obs.photo.height]);
            v["working_fov_y_deg"] = serde_json::json!(obs.fov_y_deg);
        }
        if !c.options.quiet && (obs.photo.width, obs.photo.height) != (o.0.photo.width, o.0.photo.height) {
            eprintln!(
                "working size {}x{} (the photo is {}x{}; the final scene is rendered at the photo's size)",
                obs.photo.width, obs.photo.height, o.0.photo.width, o.0.photo.height
            );
        }
        Ok(ObsHandle(Rc::new(obs)))
    });
    engine.register_fn("photo_detail", |o: &mut ObsHandle, working: ObsHandle, long_side: i64| -> Rr<Tensor> {
        let n = usize::try_from(long_side)
            .map_err(|_| rhai_err(Error::Invalid(format!("photo_detail: {long_side} is not a size in pixels"))))?;
        let size = (working.0.photo.width, working.0.photo.height);
        Ok(Tensor::constant(o.0.photo_detail(size, n).map_err(rhai_err)?))
    });
    engine.register_fn("match_photo", |s: &mut SceneHandle, o: ObsHandle| -> Rr<()> {
        let fov = o.0.require_fov().map_err(rhai_err)?;
        let c = &mut s.0.camera;
        (c.width, c.height, c.fov_y_deg) = (o.0.photo.width as u32, o.0.photo.height as u32, fov);
        Ok(())
    });
    engine.register_fn("class_mask", |o: &mut ObsHandle, class: &str| class_mask(&o.0, class).map_err(rhai_err));
    engine.register_fn("classes", |o: &mut ObsHandle| -> Rr<Array> {
        let m = o.0.require_instances().map_err(rhai_err)?;
        let mut names: Vec<String> = m.instances.iter().map(|i| i.class.clone()).collect();
        names.dedup();
        names.sort();
        names.dedup();
        Ok(names.into_iter().map(Dynamic::from).collect())
    });
    let r = run.clone();
    engine.register_fn("room_init", move |o: ObsHandle| room(&r, &o.0, &Map::new()).map_err(rhai_err));
    let r = run.clone();
    engine.register_fn("room_init", move |o: ObsHandle, opts: Map| room(&r, &o.0, &opts).map_err(rhai_err));
}
