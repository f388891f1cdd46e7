//! `psdr db build | list | check | show`: the furniture model database the object stage retrieves from.

use crate::db::{build_db, check_models, ModelSet, SWEET_HOME_3D_FURNITURE};
use clap::{Args, Subcommand};
use std::path::PathBuf;

#[derive(Args)]
pub struct DbArgs {
    #[command(subcommand)]
    command: DbCommand,
}

fn default_dir() -> PathBuf {
    std::env::var_os("HOME").map_or_else(|| PathBuf::from(".psdr-db"), |h| PathBuf::from(h).join(".cache/psdr/db"))
}

#[derive(Subcommand)]
enum DbCommand {
    /// Index model sources (Sweet Home 3D .sh3f libraries or folders of them, a 3D-FUTURE folder, folders of
    /// OBJ files) into DIR/catalog.json; models that cannot be read are listed with the reason.
    Build {
        /// Sources; default: the installed Sweet Home 3D libraries.
        sources: Vec<PathBuf>,
        /// The database folder (default ~/.cache/psdr/db, where `psdr run` looks).
        #[arg(short, long)]
        out: Option<PathBuf>,
        /// Skip the thumbnails (a 96 px render of every model in DIR/thumbs/).
        #[arg(long)]
        no_thumbnails: bool,
    },
    /// List a database's models: name, class, size in metres, triangles, licence.
    List {
        /// The database folder (default ~/.cache/psdr/db).
        dir: Option<PathBuf>,
        /// Only models of this psdr class.
        #[arg(long)]
        class: Option<String>,
    },
    /// Load, save and reload every model of a database as a run's stages do (scaled to metres, a material per
    /// part, written as a stage's scene and read back) and report each model that does not come back the same.
    Check {
        /// The database folder (default ~/.cache/psdr/db).
        dir: Option<PathBuf>,
    },
    /// Everything known about one model (by name, or part of its file path).
    Show {
        name: String,
        /// The database folder (default ~/.cache/psdr/db).
        #[arg(long)]
        dir: Option<PathBuf>,
    },
}

pub fn run(args: DbArgs) -> anyhow::Result<()> {
    match args.command {
        DbCommand::Build { sources, out, no_thumbnails } => {
            let sources = if sources.is_empty() {
                let installed = PathBuf::from(SWEET_HOME_3D_FURNITURE);
                anyhow::ensure!(
                    installed.is_dir(),
                    "no sources given and no Sweet Home 3D libraries at {SWEET_HOME_3D_FURNITURE} \
                     (apt-get install sweethome3d-furniture, or name .sh3f files or model folders)"
                );
                vec![installed]
            } else {
                sources
            };
            let out = out.unwrap_or_else(default_dir);
            let report = build_db(&sources, &out, !no_thumbnails)?;
            for (src, model, why) in &report.skipped {
                println!("skipped {model} ({src}): {why}");
            }
            let mut classes: std::collections::BTreeMap<&str, usize> = Default::default();
            for e in &report.indexed {
                *classes.entry(e.category.as_str()).or_default() += 1;
            }
            println!(
                "indexed {} models ({} skipped) into {}",
                report.indexed.len(),
                report.skipped.len(),
                out.join("catalog.json").display()
            );
            println!("{}", classes.iter().map(|(c, n)| format!("{c} {n}")).collect::<Vec<_>>().join(", "));
        }
        DbCommand::List { dir, class } => {
            let set = ModelSet::from_folder(&dir.unwrap_or_else(default_dir))?;
            for m in set.models.iter().filter(|m| class.as_ref().is_none_or(|c| &m.category == c)) {
                let s = m.size();
                println!(
                    "{:<32} {:<10} {:>5.2} x {:>5.2} x {:>5.2} m {:>7} tris  {}",
                    m.name, m.category, s.x, s.y, s.z, m.triangles, m.licence
                );
            }
        }
        DbCommand::Check { dir } => {
            let dir = dir.unwrap_or_else(default_dir);
            let set = ModelSet::from_folder(&dir)?;
            let scratch = std::env::temp_dir().join(format!("psdr-db-check-{}", std::process::id()));
            let bar = indicatif::ProgressBar::new(set.models.len() as u64);
            bar.set_style(
                indicatif::ProgressStyle::with_template("checking models {bar:40} {pos}/{len} ({eta} left)")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            let failures = check_models(&set, &scratch, &|done, _| bar.set_position(done as u64))?;
            bar.finish_and_clear();
            for (path, why) in &set.skipped {
                println!("FAIL {}: catalog: {why}", path.display());
            }
            for f in &failures {
                println!("FAIL {} ({}): {}", f.model, f.path, f.reason);
            }
            let failed = failures.len() + set.skipped.len();
            println!("{} models checked, {failed} failed ({})", set.models.len() + set.skipped.len(), dir.display());
            if failed == 0 {
                let _ = std::fs::remove_dir_all(&scratch);
            } else {
                println!("the failed models' files are kept in {}", scratch.display());
                anyhow::bail!("{failed} models do not survive a save and reload");
            }
        }
        DbCommand::Show { name, dir } => {
            let set = ModelSet::from_folder(&dir.unwrap_or_else(default_dir))?;
            let hits: Vec<_> =
                set.models.iter().filter(|m| m.name == name || m.path.to_string_lossy().contains(&name)).collect();
            anyhow::ensure!(!hits.is_empty(), "no model named '{name}' (psdr db list shows the names)");
            println!("{}", serde_json::to_string_pretty(&hits)?);
        }
    }
    Ok(())
}
