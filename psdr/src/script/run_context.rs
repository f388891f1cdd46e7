//! The state of one `psdr run`: where outputs go, which stage is running, the backend, the report and the
//! result being built. Stages are the unit of resumption: a finished stage leaves `stages/NN_name/scene.json`
//! and a `stage.json` marker; `--resume` loads finished stages instead of running them again and continues an
//! unfinished one from its optimisers' checkpoints. Every file is written atomically.

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::report::{ReportImage, RunReport, StageReport};
use crate::scene::{load_scene, save_scene, Scene};
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How `psdr run` was asked to treat earlier outputs in the output folder.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunOptions {
    /// Load finished stages and continue unfinished optimisations from their checkpoints.
    pub resume: bool,
    /// Load every finished stage before this one (by name or number) and run from it on.
    pub from_stage: Option<String>,
    /// Stop the run after this stage (by name or number): its scene becomes the run's scene.
    pub until_stage: Option<String>,
    pub quiet: bool,
    /// Samples per pixel of the preview render written at the end of each stage.
    pub preview_spp: u32,
    /// Samples per pixel of the final `render.png` the report compares with the photo (0: `preview_spp`).
    pub final_spp: u32,
    /// Where `observe(PHOTO)` takes the photo's observations from (the command line's flags); None: the
    /// files beside the photo.
    pub observations: Option<crate::vision::ObservationInputs>,
    /// The model database `model_db(...)` returns (`--db`); None: PSDR_DB, the installed Sweet Home 3D
    /// libraries' index, or the script's fallback.
    pub db: Option<PathBuf>,
}

pub struct CurrentStage {
    pub index: usize,
    pub name: String,
    pub dir: PathBuf,
    pub started: Instant,
    /// Optimisations run so far in this stage (names their checkpoints).
    pub optimizations: usize,
    pub report: StageReport,
}

pub struct RunContext {
    pub out: PathBuf,
    pub options: RunOptions,
    /// Taken out while an optimisation runs (the loss closure must not render).
    pub backend: Option<Box<dyn Backend>>,
    pub stages_started: usize,
    /// True once `--from`'s stage has been reached (always true without `--from`).
    pub from_reached: bool,
    pub current: Option<CurrentStage>,
    pub report: RunReport,
    /// The scene of the `--until` stage once it has finished (the script is then stopped).
    pub stopped_after: Option<Scene>,
    /// Values the script recorded with `record(key, value)`.
    pub recorded: Map<String, Value>,
    pub started: Instant,
}

/// The marker a finished stage leaves.
const STAGE_MARKER: &str = "stage.json";

impl RunContext {
    pub fn new(out: PathBuf, options: RunOptions, backend: Box<dyn Backend>, report: RunReport) -> RunContext {
        let from_reached = options.from_stage.is_none();
        RunContext {
            out,
            options,
            backend: Some(backend),
            stages_started: 0,
            from_reached,
            current: None,
            report,
            stopped_after: None,
            recorded: Map::new(),
            started: Instant::now(),
        }
    }

    pub fn stage_dir(&self, index: usize, name: &str) -> PathBuf {
        self.out.join("stages").join(format!("{index:02}_{name}"))
    }

    /// Starts stage `name`: Some(scene) when it is already finished and should be loaded instead of run
    /// (`--resume`, or a stage before `--from`'s); None when the stage must run (then it is the current one).
    pub fn begin_stage(&mut self, name: &str) -> Result<Option<Scene>> {
        if self.current.is_some() {
            return Err(Error::Invalid(format!("stage '{name}' started inside another stage; stages do not nest")));
        }
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
            return Err(Error::Invalid(format!("stage name '{name}': use letters, digits, '_' and '-'")));
        }
        self.stages_started += 1;
        let index = self.stages_started;
        let dir = self.stage_dir(index, name);
        if let Some(from) = &self.options.from_stage {
            if from == name || from.parse::<usize>().ok() == Some(index) {
                self.from_reached = true;
            }
        }
        let finished = dir.join(STAGE_MARKER).is_file() && dir.join("scene.json").is_file();
        if !self.from_reached {
            if !finished {
                return Err(Error::Invalid(format!(
                    "--from {}: stage {index:02}_{name} before it has no finished result in {}",
                    self.options.from_stage.as_deref().unwrap_or(""),
                    dir.display()
                )));
            }
            return self.load_finished(index, name, &dir).map(Some);
        }
        if self.options.resume && finished {
            return self.load_finished(index, name, &dir).map(Some);
        }
        if !self.options.resume && dir.exists() {
            // A fresh run must not pick up an earlier run's checkpoints.
            std::fs::remove_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        }
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        crate::progress::set_stage(Some(name));
        crate::progress::take_times();
        self.current = Some(CurrentStage {
            index,
            name: name.to_string(),
            dir,
            started: Instant::now(),
            optimizations: 0,
            report: StageReport {
                index,
                name: name.to_string(),
                seconds: 0.0,
                status: "running".into(),
                images: vec![],
                optimizations: vec![],
                phases: vec![],
            },
        });
        Ok(None)
    }

    fn load_finished(&mut self, index: usize, name: &str, dir: &Path) -> Result<Scene> {
        let marker = dir.join(STAGE_MARKER);
        let text = std::fs::read_to_string(&marker).map_err(|e| Error::io(&marker, e))?;
        let mut report: StageReport = serde_json::from_str(&text).map_err(|e| {
            Error::io(&marker, format!("not a stage record: {e}; delete the folder to rerun the stage"))
        })?;
        report.status = "loaded".into();
        self.report.stages.push(report);
        if !self.options.quiet {
            eprintln!("stage {index:02} {name}: finished earlier, loaded {}", dir.join("scene.json").display());
        }
        load_scene(&dir.join("scene.json"))
    }

    /// Finishes the current stage: writes its scene, reads it back and checks it is the same (`same_scene`),
    /// then a preview render and its record; returns the scene as read back from disk, so a run resumed after
    /// this stage continues from exactly the same state.
    pub fn end_stage(&mut self, scene: &Scene) -> Result<Scene> {
        let Some(mut stage) = self.current.take() else {
            return Err(Error::Invalid("end of a stage that was not started".into()));
        };
        let _saving = crate::progress::activity("saving and checking the stage's scene, preview render", None);
        let path = stage.dir.join("scene.json");
        save_scene(scene, &path)?;
        // A stage is finished only once its file reads back as the scene it holds: the next stage and any
        // resumed run start from the file, so a file psdr cannot read (or reads differently) stops the run here,
        // naming the stage, before the marker makes it "finished".
        let back = load_scene(&path)?;
        crate::scene::same_scene(scene, &back).map_err(|e| {
            Error::io(&path, format!("stage '{}': the scene does not read back as written: {e}", stage.name))
        })?;
        let preview = stage.dir.join("final.png");
        let render = self.preview(scene, &preview)?;
        stage.report.images.push(ReportImage { label: "final".into(), path: preview });
        // Beside it, how far it is from the photo (at the stage's size): where the stage left the error.
        let difference = stage.dir.join("difference.png");
        if crate::report::write_difference(Path::new(&self.report.photo), &render, &difference) {
            stage.report.images.push(ReportImage { label: "|final - photo|".into(), path: difference });
        }
        stage.report.seconds = stage.started.elapsed().as_secs_f64();
        stage.report.status = "done".into();
        stage.report.phases = crate::progress::take_times();
        let text = serde_json::to_string_pretty(&stage.report).map_err(|e| Error::io(&path, e))?;
        let marker = stage.dir.join(STAGE_MARKER);
        crate::output::write_atomically(&marker, |tmp| std::fs::write(tmp, &text).map_err(|e| Error::io(tmp, e)))?;
        if !self.options.quiet {
            eprintln!("stage {:02} {}: done in {:.1} s", stage.index, stage.name, stage.report.seconds);
        }
        self.report.stages.push(stage.report);
        crate::progress::set_stage(None);
        Ok(back)
    }

    /// Records a failed stage in the report (the run is ending with an error).
    pub fn fail_stage(&mut self, why: &str) {
        if let Some(mut stage) = self.current.take() {
            stage.report.seconds = stage.started.elapsed().as_secs_f64();
            stage.report.status = format!("failed: {why}");
            self.report.stages.push(stage.report);
        }
        crate::progress::set_stage(None);
    }

    /// Renders `scene` at the preview spp to a PNG (sRGB), and returns the render (linear RGB).
    pub fn preview(&mut self, scene: &Scene, path: &Path) -> Result<crate::loss::Image> {
        self.render_png(scene, path, self.options.preview_spp)
    }

    /// The final scene's `render.png` at `final_spp`: clean enough to compare with the photo by eye (the
    /// report's difference image shows the fit's error, not the render's noise).
    pub fn render_final(&mut self, scene: &Scene, path: &Path) -> Result<crate::loss::Image> {
        let spp = if self.options.final_spp > 0 { self.options.final_spp } else { self.options.preview_spp };
        self.render_png(scene, path, spp)
    }

    fn render_png(&mut self, scene: &Scene, path: &Path, spp: u32) -> Result<crate::loss::Image> {
        let backend = self.backend.as_mut().ok_or_else(|| Error::Invalid("render inside a loss closure".into()))?;
        let mut settings = scene.settings.clone();
        settings.spp = spp.max(1);
        let data = crate::render::SceneData::build(scene)?;
        let frame = backend.render(&data, &settings, &|_, _| {})?;
        crate::output::write_png_srgb(path, frame.width, frame.height, &frame.radiance)?;
        crate::loss::Image::new(frame.width as usize, frame.height as usize, 3, frame.radiance)
    }

    /// Where the current stage keeps its files (the output folder outside stages).
    pub fn current_dir(&self) -> PathBuf {
        self.current.as_ref().map_or_else(|| self.out.clone(), |s| s.dir.clone())
    }

    /// Writes `result.json` and `report.html` for what has run so far.
    pub fn write_summary(&mut self, scene: Option<&Scene>) -> Result<()> {
        self.report.total_seconds = self.started.elapsed().as_secs_f64();
        let stages: Vec<Value> = self
            .report
            .stages
            .iter()
            .map(|s| {
                json!({
                    "index": s.index, "name": s.name, "status": s.status, "seconds": s.seconds,
                    "phases": s.phases.iter().map(|(l, t)| json!({"step": l, "seconds": t})).collect::<Vec<_>>(),
                    "optimizations": s.optimizations.iter().map(|o| json!({
                        "label": o.label,
                        "iterations": o.iterations.len(),
                        "first_loss": o.iterations.first().map(|r| r.loss),
                        "final_loss": o.iterations.last().map(|r| r.loss),
                        "best_loss": o.iterations.iter().map(|r| r.loss).filter(|l| l.is_finite()).reduce(f64::min),
                        "seconds": o.iterations.iter().map(|r| r.seconds_render + r.seconds_loss + r.seconds_backward + r.seconds_step).sum::<f64>(),
                        "events": o.events,
                        "params": o.params,
                    })).collect::<Vec<_>>(),
                })
            })
            .collect();
        let mut result = json!({
            "format": "psdr-result",
            "script": self.report.script,
            "photo": self.report.photo,
            "command": self.report.command,
            "seed": self.report.seed,
            "stages": stages,
            "recorded": Value::Object(self.recorded.clone()),
            "total_seconds": self.report.total_seconds,
            "credits": self.report.credits,
        });
        if let Some(scene) = scene {
            self.report.summary = crate::report::build_summary(
                &self.out,
                Path::new(&self.report.photo),
                &self.out.join("render.png"),
                scene,
                &self.recorded,
            );
            result["camera"] = super::scene_api::camera_json(scene);
            result["scene"] = super::scene_api::scene_summary(scene);
            if let Some(room) = crate::stages::room_summary(scene) {
                result["room"] = room;
            }
        }
        let path = self.out.join("result.json");
        let text = serde_json::to_string_pretty(&result).map_err(|e| Error::io(&path, e))?;
        crate::output::write_atomically(&path, |tmp| std::fs::write(tmp, &text).map_err(|e| Error::io(tmp, e)))?;
        crate::report::write_report(&self.report, &self.out.join("report.html"))
    }
}
