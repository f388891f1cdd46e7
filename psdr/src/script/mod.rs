//! Rhai stage scripts: the researcher's surface. A script loads scenes and images, defines losses as closures
//! over image tensors, runs `optimize` inside named `stage`s, and its schedule, weights, rates and crops are
//! all script text (`scripts/README.md` documents the API). `run_script` is `psdr run`.
//!
//! Files: `engine` (the engine, limits, `--set`, errors, `stage`), `scene_api` (scenes, renders, images),
//! `tensor_api` (loss ops and operators), `vision_api` (observations, room initialisation), `optimize_api` (`optimize`), `crops` (crop strategies),
//! `run_context` (output folder, stages, resumption, result.json and report.html).

mod api_support;
mod crops;
mod engine;
mod evaluation_api;
mod light_api;
mod material_api;
mod object_api;
mod optimize_api;
mod run_context;
mod scene_api;
mod tensor_api;
mod vision_api;

pub use crops::{largest_rect, load_rects, random_crops, squarest_rect, Rect};
pub use engine::{build_engine, overrides, MAX_OPERATIONS};
pub use run_context::{RunContext, RunOptions};
pub use scene_api::{read_image, write_image, SceneHandle};

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::report::RunReport;
use rhai::{Dynamic, Scope};
use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// One `psdr run`.
pub struct ScriptRun {
    pub script: PathBuf,
    pub photo: PathBuf,
    pub out: PathBuf,
    /// `--set key=value` overrides of the script's top-level literal variables.
    pub sets: Vec<String>,
    pub options: RunOptions,
    /// The command line, for the report.
    pub command: String,
}

/// What a run produced.
#[derive(Debug)]
pub struct RunSummary {
    pub stages: usize,
    /// `DIR/scene.json` when the script ended with a scene.
    pub scene: Option<PathBuf>,
    pub seconds: f64,
}

fn dir_of(p: &Path) -> String {
    let d = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    d.to_string_lossy().into_owned()
}

/// Makes the output folder, or says why it cannot be used, before any stage runs: an existing file of that
/// name, a folder that cannot be created or written to.
pub fn check_output_folder(out: &Path) -> Result<()> {
    if out.exists() && !out.is_dir() {
        return Err(Error::io(out, "-o names an existing file; give a folder (it is made if missing)"));
    }
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, format!("cannot make the output folder: {e}")))?;
    let probe = out.join(format!(".psdr-write-check-{}", std::process::id()));
    std::fs::write(&probe, b"").map_err(|e| Error::io(out, format!("cannot write into the output folder: {e}")))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Runs a stage script on a photo. Inputs are checked before anything is written to the output folder.
pub fn run_script(run: ScriptRun, backend: Box<dyn Backend>) -> Result<RunSummary> {
    let source = std::fs::read_to_string(&run.script).map_err(|e| Error::io(&run.script, e))?;
    if !run.photo.is_file() {
        return Err(Error::io(&run.photo, "photo not found"));
    }
    let probe = rhai::Engine::new();
    let ast = probe.compile(&source).map_err(|e| engine::script_error(&run.script, &e.into()))?;
    let sets = overrides(&ast, &run.sets)?;
    check_output_folder(&run.out)?;
    let report = RunReport {
        title: format!("psdr run {}", run.script.display()),
        script: run.script.display().to_string(),
        photo: run.photo.display().to_string(),
        command: run.command.clone(),
        seed: 0,
        images: vec![],
        stages: vec![],
        total_seconds: 0.0,
        credits: vec![],
        notes: vec![],
        summary: Default::default(),
    };
    let _reporter = crate::progress::start_reporter(run.options.quiet);
    let ctx = Rc::new(RefCell::new(RunContext::new(run.out.clone(), run.options.clone(), backend, report)));
    let mut engine = build_engine(&ctx);
    if !sets.is_empty() {
        // `--set`: reads of an overridden top-level variable see the given value.
        #[allow(deprecated)]
        engine.on_var(move |name, _, _| Ok(sets.get(name).cloned()));
    }
    let mut scope = Scope::new();
    scope.push_constant("PHOTO", run.photo.to_string_lossy().into_owned());
    scope.push_constant("PHOTO_DIR", dir_of(&run.photo));
    scope.push_constant("SCRIPT_DIR", dir_of(&run.script));
    scope.push_constant("OUT_DIR", run.out.to_string_lossy().into_owned());
    let result = engine.eval_ast_with_scope::<Dynamic>(&mut scope, &ast);
    let mut c = ctx.borrow_mut();
    let value = match (result, c.stopped_after.take()) {
        (Ok(v), _) => v,
        // `--until STAGE`: stopped after that stage, on purpose; its scene is the run's.
        (Err(_), Some(scene)) => Dynamic::from(SceneHandle(scene)),
        (Err(e), None) => {
            let err = engine::script_error(&run.script, &e);
            c.fail_stage(&err.to_string());
            c.report.notes.push(format!("the run failed: {err}"));
            let _ = c.write_summary(None);
            return Err(err);
        }
    };
    let mut scene_path = None;
    let final_scene = value.try_cast::<SceneHandle>().map(|s| s.0);
    if let Some(scene) = &final_scene {
        crate::progress::set_stage(Some("outputs"));
        let _writing = crate::progress::activity(
            format!(
                "scene.json, scene.glb, the Mitsuba export and render.png at {}x{}, {} spp",
                scene.camera.width,
                scene.camera.height,
                if c.options.final_spp > 0 { c.options.final_spp } else { c.options.preview_spp }
            ),
            None,
        );
        let path = run.out.join("scene.json");
        crate::scene::save_scene(scene, &path)?;
        // The scene for Blender and the web, and for Mitsuba 3, as well.
        crate::export::gltf::export_glb(scene, &run.out.join("scene.glb"))?;
        crate::export::mitsuba::export_mitsuba(scene, &run.out.join("mitsuba"))?;
        c.render_final(scene, &run.out.join("render.png"))?;
        scene_path = Some(path);
    }
    c.write_summary(final_scene.as_ref())?;
    Ok(RunSummary { stages: c.report.stages.len(), scene: scene_path, seconds: c.started.elapsed().as_secs_f64() })
}
