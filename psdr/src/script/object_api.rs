//! The object stage in scripts: `objects_init(scene, obs, #{db, ...})` places a retrieved model for every
//! furniture instance in the scene (in place; `embedding: PATH` adds an ONNX image encoder comparing the
//! photo's crops with the models' thumbnails) and returns what it placed (name, instance, class, model, iou,
//! mask: the instance's with pieces merged into it, merged: their ids), `obs.instance_mask(id)` gives an
//! instance's mask as a loss target. Placements, alternatives and skipped instances go into result.json.

use super::api_support::{rhai_err, Rr, RunRef};
use super::scene_api::SceneHandle;
use super::vision_api::ObsHandle;
use crate::db::ModelSet;
use crate::error::Error;
use crate::loss::{Image, Tensor};
use crate::scene::Material;
use crate::stages::{init_objects_with, model_looks, AppearanceCue, ObjectInitOptions};
use glam::Vec3;
use rhai::{Array, Dynamic, Engine, Map};
use std::path::PathBuf;

fn objects_init(run: &RunRef, obs: &ObsHandle, scene: &mut SceneHandle, opts: &Map) -> crate::Result<Array> {
    let mut o = ObjectInitOptions::default();
    let mut db: Option<PathBuf> = None;
    let (mut encoder, mut embedding_weight): (Option<PathBuf>, f32) = (None, 0.5);
    for (k, v) in opts {
        if k == "placeholders" {
            o.placeholders =
                v.as_bool().map_err(|_| Error::Invalid("objects_init: 'placeholders' must be true or false".into()))?;
            continue;
        }
        if k == "db" || k == "embedding" {
            let path = PathBuf::from(
                v.clone().into_string().map_err(|_| Error::Invalid(format!("objects_init: '{k}' must be a path")))?,
            );
            *(if k == "db" { &mut db } else { &mut encoder }) = Some(path);
            continue;
        }
        let num = v
            .as_float()
            .or_else(|_| v.as_int().map(|i| i as f64))
            .map_err(|_| Error::Invalid(format!("objects_init: '{k}' must be a number")))?;
        match k.as_str() {
            "min_pixels" => o.min_pixels = num.max(0.0) as usize,
            "erode" => o.erode = num.max(0.0) as usize,
            "yaws" => o.yaws = num.max(1.0) as usize,
            "sweep_width" => o.sweep_width = num.max(8.0) as u32,
            "top_k" => o.top_k = num.max(1.0) as usize,
            "depth_weight" => o.depth_weight = num as f32,
            "max_candidates" => o.max_candidates = num.max(1.0) as usize,
            "scale_weight" => o.scale_weight = num as f32,
            "finalists" => o.finalists = num.max(1.0) as usize,
            "scale_step" => o.scale_step = num.clamp(0.0, 0.5) as f32,
            "silhouette_weight" => o.silhouette_weight = num.max(0.0) as f32,
            "embedding_weight" => embedding_weight = num.max(0.0) as f32,
            "merge_bridges" => o.merge_bridges = num.max(0.0) as usize,
            "merge_depth_tolerance" => o.merge_depth_tolerance = num.max(0.0) as f32,
            "merge_min_span" => o.merge_min_span = num.clamp(0.0, 1.0) as f32,
            "wall_tie" => o.wall_tie = num.max(0.0) as f32,
            "occluder_depth" => o.occluder_depth = num.max(0.0) as f32,
            "thin_top" => o.thin_top = num.max(1.0) as f32,
            other => {
                return Err(Error::Invalid(format!(
                    "objects_init: unknown option '{other}' (db, placeholders, min_pixels, erode, yaws, sweep_width, top_k, depth_weight, max_candidates, \
                     scale_weight, finalists, scale_step, silhouette_weight, embedding, embedding_weight, merge_bridges, \
                     merge_depth_tolerance, merge_min_span, wall_tie, occluder_depth, thin_top)"
                )))
            }
        }
    }
    let db = db.ok_or_else(|| Error::Invalid("objects_init: give the model folder as #{ db: PATH }".into()))?;
    let models = ModelSet::from_folder(&db)?;
    let depth = obs.0.require_depth()?;
    let inst = obs.0.require_instances()?;
    // With an image encoder, crops of the photo are compared with the models' thumbnails.
    let mut model = encoder.as_deref().map(crate::vision::load_embedding_model).transpose()?;
    let cue = model.as_mut().map(|m| AppearanceCue { photo: &obs.0.photo, model: m, weight: embedding_weight });
    let (placed, skipped) = init_objects_with(&scene.0, &depth.image.data, inst, &models, &o, cue);
    // One material per part of each placed object (the model's own material groups: a chair's frame and its
    // seat), named OBJECT or OBJECT:PART when it has several, so later stages can give each its own; each
    // starts grey, the model's own colour and picture kept for `object_pictures` (`model_looks`). (Started at
    // those colours, real room08's light stage kept 2 of its 3 lights: its choice is that sensitive to the
    // scene it is handed, benchmarks/README.md.)
    let mut out = Array::new();
    let mut records = vec![];
    for (p, mut object) in placed {
        let mut names: Vec<String> = vec![];
        for part in object.parts.iter_mut() {
            if !names.contains(&part.name) {
                names.push(part.name.clone());
            }
            part.material = names.iter().position(|n| *n == part.name).unwrap_or(0);
        }
        let first = scene.0.materials.len();
        let looks = p.chosen.path.as_deref().map(model_looks).unwrap_or_default();
        for n in &names {
            let name = if names.len() == 1 { p.name.clone() } else { format!("{}:{n}", p.name) };
            let mut material = Material::diffuse(&name, Vec3::splat(0.5));
            material.model_look = looks.get(n).cloned();
            scene.0.materials.push(material);
        }
        object.parts.iter_mut().for_each(|part| part.material += first);
        scene.0.objects.push(object);
        let mut entry = Map::new();
        entry.insert("name".into(), Dynamic::from(p.name.clone()));
        entry.insert("instance".into(), Dynamic::from(p.instance as i64));
        entry.insert("class".into(), Dynamic::from(p.class.clone()));
        entry.insert("model".into(), Dynamic::from(p.chosen.model.clone()));
        entry.insert("iou".into(), Dynamic::from(p.chosen.iou as f64));
        // The instance's mask with any pieces merged into it, as the refinement's target.
        let pieces: Vec<u16> = std::iter::once(p.instance).chain(p.merged.iter().copied()).collect();
        let mask: Vec<f32> = inst.ids.iter().map(|v| pieces.contains(v) as u32 as f32).collect();
        entry.insert("mask".into(), Dynamic::from(Tensor::constant(Image::new(inst.width, inst.height, 1, mask)?)));
        entry.insert(
            "merged".into(),
            Dynamic::from(p.merged.iter().map(|&m| Dynamic::from(m as i64)).collect::<Array>()),
        );
        out.push(Dynamic::from(entry));
        records.push(p);
    }
    let summary = serde_json::json!({
        "db": db,
        "embedding": encoder,
        "models_indexed": models.models.len(),
        "models_skipped": models.skipped.iter().map(|(p, why)| serde_json::json!({"file": p, "reason": why})).collect::<Vec<_>>(),
        "placed": records,
        "skipped": skipped,
    });
    let mut c = run.borrow_mut();
    c.recorded.insert("objects_init".into(), summary);
    // Third-party models keep their licences: each placed model's attribution goes into the report's credits.
    for p in &records {
        let credit = format!("{} ({}): {}", p.chosen.model, p.name, p.chosen.licence);
        if p.chosen.path.is_some() && !c.report.credits.contains(&credit) {
            c.report.credits.push(credit);
        }
    }
    Ok(out)
}

/// `check_models(db, obs, #{ placeholders, min_pixels })`, before any stage runs: the model folder exists and
/// holds models, and has a model of every furniture class the photo shows. A missing class stops the run with
/// the classes and their instances named, unless `placeholders` is true: then each such instance will be a box
/// of its observed size, which result.json (`placeholders`) and the report say.
fn check_models(run: &RunRef, db: &str, obs: &ObsHandle, opts: &Map) -> crate::Result<()> {
    let mut placeholders = false;
    let mut min_pixels = crate::stages::ObjectInitOptions::default().min_pixels;
    for (k, v) in opts {
        match k.as_str() {
            "placeholders" => {
                placeholders = v
                    .as_bool()
                    .map_err(|_| Error::Invalid("check_models: 'placeholders' must be true or false".into()))?
            }
            "min_pixels" => min_pixels = super::api_support::option_number("check_models", k, v)?.max(0.0) as usize,
            other => {
                return Err(Error::Invalid(format!(
                    "check_models: unknown option '{other}' (placeholders, min_pixels)"
                )))
            }
        }
    }
    let dir = std::path::Path::new(db);
    if !dir.is_dir() {
        return Err(Error::io(dir, "the model database folder does not exist (--db DIR, PSDR_DB, or psdr db build)"));
    }
    let models = ModelSet::from_folder(dir)?;
    if models.models.is_empty() {
        return Err(Error::io(
            dir,
            format!(
                "the model database holds no models ({} files could not be read); give a folder of OBJ models or a \
                 `psdr db build` index with --db",
                models.skipped.len()
            ),
        ));
    }
    // Depth too: the run should stop here, before any stage, naming everything the photo lacks.
    let (_, inst) = obs.0.require_depth_and_instances()?;
    let missing = crate::stages::missing_classes(inst, &models, min_pixels);
    if missing.is_empty() {
        return Ok(());
    }
    let list = missing.iter().map(|(c, ids)| format!("{c} (instances {ids:?})")).collect::<Vec<_>>().join(", ");
    if !placeholders {
        return Err(Error::io(
            dir,
            format!(
                "the model database has no model of {list}; add models of these classes, label the instances with \
                 classes it has, or let them be boxes of their size with --set placeholder_boxes=true"
            ),
        ));
    }
    let mut c = run.borrow_mut();
    let note = format!("placeholder boxes for classes the database lacks: {list}");
    if !c.options.quiet {
        eprintln!("warning: {note}");
    }
    c.report.notes.push(note);
    c.recorded.insert(
        "placeholders".into(),
        serde_json::json!(missing
            .iter()
            .map(|(c, ids)| serde_json::json!({"class": c, "instances": ids}))
            .collect::<Vec<_>>()),
    );
    Ok(())
}

fn instance_mask(obs: &ObsHandle, id: i64) -> crate::Result<Tensor> {
    let m = obs.0.require_instances()?;
    let id = u16::try_from(id).map_err(|_| Error::Invalid(format!("instance id {id} is not in 1..65535")))?;
    if !m.instances.iter().any(|i| i.id == id) {
        return Err(Error::Invalid(format!("no instance {id} in the segmentation")));
    }
    Ok(Tensor::constant(Image::new(m.width, m.height, 1, m.instance_mask(id))?))
}

pub fn register(engine: &mut Engine, run: &RunRef) {
    let r = run.clone();
    // The scene comes first: Rhai passes only a first argument by reference.
    engine.register_fn("objects_init", move |scene: &mut SceneHandle, obs: ObsHandle, opts: Map| -> Rr<Array> {
        objects_init(&r, &obs, scene, &opts).map_err(rhai_err)
    });
    engine.register_fn("instance_mask", |obs: &mut ObsHandle, id: i64| instance_mask(obs, id).map_err(rhai_err));
    let r = run.clone();
    engine.register_fn("check_models", move |db: &str, obs: ObsHandle, opts: Map| -> Rr<()> {
        check_models(&r, db, &obs, &opts).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn("model_db", move |fallback: &str| -> Rr<String> {
        let explicit = r.borrow().options.db.clone();
        crate::db::default_db(explicit.as_deref(), std::path::Path::new(fallback))
            .map(|p| p.to_string_lossy().into_owned())
            .map_err(rhai_err)
    });
}
