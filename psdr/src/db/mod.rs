//! The furniture model database: an index of OBJ models with categories, real sizes and licences, from which
//! the object stage retrieves candidates. `model_set`: the models of a folder (with or without a
//! `catalog.json`); `sh3f`: Sweet Home 3D libraries; `build`: `psdr db build`, indexing libraries, 3D-FUTURE
//! and OBJ folders into one catalog; `silhouette`: outline descriptors that rank a class's models by shape;
//! `thumbnail`: a render of each model; `check`: `psdr db check`, every model through a save and reload.

mod build;
mod check;
mod model_set;
mod sh3f;
mod silhouette;
mod thumbnail;

pub use build::{build_db, BuildReport, CATALOG_VERSION, SWEET_HOME_3D_FURNITURE};
pub use check::{check_model, check_models, CheckFailure};
pub use model_set::{entry_for, ModelEntry, ModelSet};
pub use sh3f::{class_of, extract_sh3f, read_sh3f, Sh3fLibrary, Sh3fModel};
pub use silhouette::{best_view_iou, model_silhouettes, Silhouette};
pub use thumbnail::render_thumbnail;

/// The model folder a run uses: `explicit` (--db or the script's choice) if given; else `PSDR_DB`; else the
/// index of the installed Sweet Home 3D libraries in ~/.cache/psdr/db (built on first use or when its format is
/// older, then reused); else
/// `fallback` (the repository's small model set).
pub fn default_db(explicit: Option<&std::path::Path>, fallback: &std::path::Path) -> crate::Result<std::path::PathBuf> {
    use std::path::{Path, PathBuf};
    if let Some(p) = explicit {
        return Ok(p.to_path_buf());
    }
    if let Some(p) = std::env::var_os("PSDR_DB") {
        return Ok(PathBuf::from(p));
    }
    let installed = Path::new(SWEET_HOME_3D_FURNITURE);
    if let (Some(home), true) = (std::env::var_os("HOME"), installed.is_dir()) {
        let cache = PathBuf::from(home).join(".cache/psdr/db");
        let current = std::fs::read_to_string(cache.join("catalog.json"))
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
            .is_some_and(|c| c["version"].as_u64() == Some(CATALOG_VERSION as u64));
        if !current {
            eprintln!("indexing the Sweet Home 3D furniture libraries into {} (once)...", cache.display());
            build_db(&[installed.to_path_buf()], &cache, false)?;
        }
        return Ok(cache);
    }
    Ok(fallback.to_path_buf())
}
