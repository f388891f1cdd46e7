//! `psdr db check`: every model of a database through the life a retrieved model has in a run: read and scaled
//! to metres (`ModelEntry::load_parts`), placed in a scene with a material per part, the scene saved as a stage
//! saves it, read back, compared (`scene::same_scene`) and made ready to render (its BVH within the traversal
//! stack). A model that fails is reported by name with the
//! step and the reason; nothing is fatal.

use super::{ModelEntry, ModelSet};
use crate::error::{Error, Result};
use crate::scene::{load_scene, same_scene, save_scene, Camera, Material, Object, Pose, Scene};
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

/// One model that did not survive, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckFailure {
    pub model: String,
    pub path: String,
    /// "load", "save", "reload", "compare" or "render" (the scene data the renderers trace), then the reason.
    pub reason: String,
}

/// A one-object scene of `entry`'s parts, each with a material of its own named as the object stage names them.
fn model_scene(entry: &ModelEntry) -> Result<Scene> {
    let parts = entry.load_parts()?;
    let mut scene = Scene {
        camera: Camera::look_at(Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, Vec3::Y, 50.0, 8, 8),
        settings: Default::default(),
        materials: vec![],
        textures: vec![],
        objects: vec![],
        source: None,
        requires_grad: vec![],
    };
    let mut parts = parts;
    for p in parts.iter_mut() {
        let name = format!("model:{}", p.name);
        p.material = match scene.material_index(&name) {
            Some(m) => m,
            None => {
                scene.materials.push(Material::diffuse(&name, Vec3::splat(0.5)));
                scene.materials.len() - 1
            }
        };
    }
    scene.objects.push(Object { name: "model".into(), parts, pose: Pose::default(), emitter: None });
    Ok(scene)
}

/// Checks one model in `scratch` (a folder of its own, left behind only on failure for a look).
pub fn check_model(entry: &ModelEntry, scratch: &Path) -> std::result::Result<(), String> {
    let scene = model_scene(entry).map_err(|e| format!("load: {e}"))?;
    let file = scratch.join("scene.json");
    save_scene(&scene, &file).map_err(|e| format!("save: {e}"))?;
    let back = load_scene(&file).map_err(|e| format!("reload: {e}"))?;
    same_scene(&scene, &back).map_err(|e| format!("compare: {e}"))?;
    crate::render::SceneData::build(&back).map_err(|e| format!("render: {e}"))?;
    let _ = std::fs::remove_dir_all(scratch);
    Ok(())
}

/// Checks every model of `set` (in parallel) with scratch folders under `scratch`; `progress(done, total)` is
/// called as models finish. Returns the failures in the set's order.
pub fn check_models(
    set: &ModelSet,
    scratch: &Path,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<CheckFailure>> {
    std::fs::create_dir_all(scratch).map_err(|e| Error::io(scratch, e))?;
    let done = AtomicUsize::new(0);
    let total = set.models.len();
    let results: Vec<Option<CheckFailure>> = set
        .models
        .par_iter()
        .enumerate()
        .map(|(k, e)| {
            let r = check_model(e, &scratch.join(format!("{k:04}")));
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
            r.err().map(|reason| CheckFailure { model: e.name.clone(), path: e.path.display().to_string(), reason })
        })
        .collect();
    Ok(results.into_iter().flatten().collect())
}
