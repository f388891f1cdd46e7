//! `psdr run SCRIPT PHOTO [-o DIR] [--set key=value]... [--from STAGE] [--until STAGE] [--resume] [observation flags]`: runs a
//! Rhai stage script.

use super::observation_args::ObservationArgs;
use crate::backend::{create_backend_on, BackendKind};
use crate::script::{run_script, RunOptions, ScriptRun};
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct RunArgs {
    /// The stage script (Rhai), e.g. scripts/fit.rhai.
    script: PathBuf,
    /// The photo to fit (PNG, JPEG or EXR); the script sees its path as PHOTO.
    photo: PathBuf,
    /// Output folder: stages/NN_name/ per stage, result.json, report.html, scene.json.
    #[arg(short, long, default_value = "out")]
    output: PathBuf,
    /// Override a top-level variable of the script (`let iters = 200;` -> --set iters=50). Repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Load the finished stages before this one (name or number) from DIR and run from it on.
    #[arg(long)]
    from: Option<String>,
    /// Stop after this stage (name or number): its scene is written as the run's scene.json with the outputs.
    #[arg(long)]
    until: Option<String>,
    /// Continue an interrupted run in DIR: finished stages are loaded, an unfinished optimisation continues
    /// from its last checkpoint (same result as an uninterrupted run).
    #[arg(long)]
    resume: bool,
    /// Where the stages render and differentiate (vk: a Vulkan GPU, or lavapipe without one); the object
    /// retrieval's ray casts stay on the CPU.
    #[arg(long, default_value = "cpu", value_parser = super::backend_parser())]
    backend: BackendKind,
    /// GPU to render on (vk backend), a part of its name.
    #[arg(long)]
    device: Option<String>,
    /// Samples per pixel of each stage's preview render.
    #[arg(long, default_value_t = 16)]
    preview_spp: u32,
    /// Samples per pixel of the final render.png, which the report compares with the photo (64: half the noise
    /// of 16 spp; 16 s at 512x384 on 2 cores).
    #[arg(long, default_value_t = 64)]
    final_spp: u32,
    /// No progress bars or log lines.
    #[arg(long)]
    quiet: bool,
    /// Furniture model database (a folder indexed by `psdr db build`, or of OBJ files) for the object stage;
    /// default: PSDR_DB, else the installed Sweet Home 3D libraries (indexed once into ~/.cache/psdr/db), else
    /// the script's fallback (the repository's small set).
    #[arg(long)]
    db: Option<PathBuf>,
    /// Download the pinned image models (depth, segmentation) that the models folder lacks before the run
    /// (as `psdr models fetch` does); without it nothing is downloaded.
    #[arg(long)]
    fetch_models: bool,
    /// Observation sources for PHOTO (the script's `observe(PHOTO)`), instead of the files beside it.
    #[command(flatten)]
    observations: ObservationArgs,
}

pub fn run(a: RunArgs) -> anyhow::Result<()> {
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let backend = create_backend_on(a.backend, a.device.as_deref())?;
    if a.fetch_models {
        let dir = crate::models::fetch_folder(a.observations.models_flag());
        for entry in &crate::models::Manifest::pinned().models {
            let f = crate::models::fetch_model(entry, &dir, &|_, _| {})?;
            if !f.cached && !a.quiet {
                eprintln!("fetched {} into {} ({})", entry.name, f.path.display(), entry.licence);
            }
        }
    }
    let summary = run_script(
        ScriptRun {
            script: a.script,
            photo: a.photo.clone(),
            out: a.output.clone(),
            sets: a.set,
            options: RunOptions {
                resume: a.resume,
                from_stage: a.from,
                until_stage: a.until,
                quiet: a.quiet,
                preview_spp: a.preview_spp,
                final_spp: a.final_spp,
                observations: Some(a.observations.inputs(&a.photo)),
                db: a.db,
            },
            command,
        },
        backend,
    )?;
    if !a.quiet {
        eprintln!(
            "{} stage(s) in {:.1} s; {}report: {}",
            summary.stages,
            summary.seconds,
            summary.scene.map(|p| format!("scene: {}; ", p.display())).unwrap_or_default(),
            a.output.join("report.html").display()
        );
    }
    Ok(())
}
