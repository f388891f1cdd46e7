//! `psdr models fetch [NAME...] [--dir DIR]` and `psdr models list [--dir DIR]`: the pinned image models
//! (depth, segmentation) downloaded once into the models folder, and what that folder holds.

use crate::models::{fetch_folder, fetch_model, model_state, Manifest, ModelState};
use clap::{Args, Subcommand};
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct ModelsArgs {
    #[command(subcommand)]
    command: ModelsCommand,
}

#[derive(Subcommand)]
enum ModelsCommand {
    /// Download the pinned models (all, or those named) unless present and valid; an interrupted download
    /// continues where it stopped; each file is checked against its pinned size and SHA-256 before it is used.
    Fetch {
        /// Model names (depth, segmentation) or files (depth.onnx); default: all.
        names: Vec<String>,
        #[command(flatten)]
        place: Place,
    },
    /// Each pinned model: present and valid, partly downloaded, different or missing; size, licence, source.
    List {
        #[command(flatten)]
        place: Place,
    },
}

#[derive(Args)]
struct Place {
    /// The models folder (default: PSDR_MODELS, else ~/.cache/psdr/models, where `psdr run` looks).
    #[arg(long)]
    dir: Option<PathBuf>,
    /// A manifest of the same shape as psdr/models.json instead of the pinned one (a mirror).
    #[arg(long)]
    manifest: Option<PathBuf>,
}

impl Place {
    fn resolve(&self) -> anyhow::Result<(Manifest, PathBuf)> {
        let manifest = match &self.manifest {
            Some(p) => Manifest::load(p)?,
            None => Manifest::pinned(),
        };
        Ok((manifest, fetch_folder(self.dir.as_deref())))
    }
}

pub fn run(a: ModelsArgs) -> anyhow::Result<()> {
    match a.command {
        ModelsCommand::Fetch { names, place } => {
            let (manifest, dir) = place.resolve()?;
            let mut failed = vec![];
            for entry in manifest.select(&names)? {
                let bar = indicatif::ProgressBar::new(entry.size);
                bar.set_style(
                    indicatif::ProgressStyle::with_template(&format!(
                        "{} {{bar:40}} {{bytes}}/{{total_bytes}} ({{bytes_per_sec}}, {{eta}} left)",
                        entry.file
                    ))
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
                );
                let result = fetch_model(entry, &dir, &|done, _| bar.set_position(done));
                bar.finish_and_clear();
                match result {
                    Ok(f) if f.cached => println!("{}: present and valid ({})", entry.name, f.path.display()),
                    Ok(f) => println!(
                        "{}: downloaded{} and verified ({}, {})",
                        entry.name,
                        if f.resumed_from > 0 {
                            format!(" (continued from byte {})", f.resumed_from)
                        } else {
                            "".into()
                        },
                        f.path.display(),
                        entry.licence
                    ),
                    Err(e) => {
                        eprintln!("{}: {e}", entry.name);
                        failed.push(entry.name.clone());
                    }
                }
            }
            if !failed.is_empty() {
                anyhow::bail!("{} of the models could not be fetched: {}", failed.len(), failed.join(", "));
            }
            Ok(())
        }
        ModelsCommand::List { place } => {
            let (manifest, dir) = place.resolve()?;
            println!("models folder: {}", dir.display());
            for e in &manifest.models {
                let state = match model_state(e, &dir, true)? {
                    ModelState::Valid => "present, valid".to_string(),
                    ModelState::Missing => "missing (psdr models fetch)".to_string(),
                    ModelState::Partial(n) => format!("partly downloaded, {n} of {} bytes (psdr models fetch)", e.size),
                    ModelState::Different(why) => format!("a different file: {why}"),
                };
                println!("{:<14} {:<18} {:>7.1} MB  {state}", e.name, e.file, e.size as f64 / 1e6);
                println!("{:<14} licence: {}; {}", "", e.licence, e.source);
            }
            let others = onnx_files(&dir).into_iter().filter(|f| manifest.by_file(f).is_none()).collect::<Vec<_>>();
            if !others.is_empty() {
                println!("also in the folder (not pinned, used as they are): {}", others.join(", "));
            }
            Ok(())
        }
    }
}

/// The `.onnx` files in a folder, sorted.
fn onnx_files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| r.filter_map(|e| e.ok()?.file_name().into_string().ok()).filter(|n| n.ends_with(".onnx")).collect())
        .unwrap_or_default();
    v.sort();
    v
}
