//! The `psdr` command line (clap). One file per subcommand.

mod db_cmd;
mod export_cmd;
mod grad_cmd;
mod materials_cmd;
mod models_cmd;
mod observation_args;
mod observe_cmd;
mod render_cmd;
mod run_cmd;

use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// `--backend`'s values, listed in `--help`: cpu (the reference) or vk (Vulkan compute).
pub(crate) fn backend_parser() -> impl TypedValueParser<Value = crate::backend::BackendKind> {
    PossibleValuesParser::new(["cpu", "vk"])
        .map(|s| s.parse::<crate::backend::BackendKind>().unwrap_or(crate::backend::BackendKind::Cpu))
}

#[derive(Parser)]
#[command(
    name = "psdr",
    version,
    about = "Single photo to editable 3D room scene by path-space differentiable rendering"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file to EXR/PNG with optional AOVs.
    Render(render_cmd::RenderArgs),
    /// Export a scene for another renderer.
    Export(export_cmd::ExportArgs),
    /// Gradient of an image loss with respect to one scene parameter.
    Grad(grad_cmd::GradArgs),
    /// Resolve a photo's observations (depth, segmentation, field of view) and write them for inspection.
    Observe(observe_cmd::ObserveArgs),
    /// Run a stage script (Rhai) on a photo: optimisation stages, checkpoints, result.json, report.html.
    Run(run_cmd::RunArgs),
    /// The procedural material library: list, render maps, contact sheet.
    Materials(materials_cmd::MaterialsArgs),
    /// The furniture model database: build (index libraries and folders), list, show.
    Db(db_cmd::DbArgs),
    /// The image models (depth, segmentation): fetch the pinned ones once, list what the models folder holds.
    Models(models_cmd::ModelsArgs),
}

pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => render_cmd::run(a),
        Command::Export(a) => export_cmd::run(a),
        Command::Materials(a) => materials_cmd::run(a),
        Command::Grad(a) => grad_cmd::run(a),
        Command::Run(a) => run_cmd::run(a),
        Command::Observe(a) => observe_cmd::run(a),
        Command::Db(a) => db_cmd::run(a),
        Command::Models(a) => models_cmd::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
