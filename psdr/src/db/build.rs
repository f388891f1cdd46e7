//! `psdr db build`: indexes model sources into one folder with a `catalog.json` that `ModelSet` reads without
//! opening every OBJ. Sources: Sweet Home 3D libraries (`.sh3f` files, or folders of them: extracted under
//! `sh3d/LIBRARY/`), the 3D-FUTURE layout (a folder with `model_info.json` and one folder per model id holding
//! `raw_model.obj` or `normalized_model.obj`), and folders of OBJ files (indexed in place). Every model is read
//! once; one that cannot be read is reported with the reason and left out, never fatal.

use super::model_set::{entry_for, ModelEntry};
use super::sh3f::{class_of, extract_sh3f, read_sh3f};
use crate::error::{Error, Result};
use rayon::prelude::*;
use serde_json::json;
use std::path::{Path, PathBuf};

/// Where Debian's `sweethome3d-furniture` package puts its libraries.
pub const SWEET_HOME_3D_FURNITURE: &str = "/usr/share/sweethome3d/furniture";

/// What a build did.
#[derive(Clone, Debug, Default)]
pub struct BuildReport {
    pub indexed: Vec<ModelEntry>,
    /// (source, model, reason)
    pub skipped: Vec<(String, String, String)>,
}

fn relative(dir: &Path, path: &Path) -> String {
    path.strip_prefix(dir).unwrap_or(path).to_string_lossy().replace('\\', "/")
}

fn add_sh3f(file: &Path, out: &Path, report: &mut BuildReport) -> Result<()> {
    let lib = read_sh3f(file)?;
    let stem = file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "library".into());
    let dir = out.join("sh3d").join(&stem);
    extract_sh3f(file, &dir)?;
    for m in lib.models {
        let path = dir.join(&m.model);
        let licence = match &m.creator {
            Some(c) => format!("{} ({}), by {c}", lib.licence, lib.name),
            None => format!("{} ({})", lib.licence, lib.name),
        };
        let class = if m.door_or_window && m.class == crate::vision::UNKNOWN_CLASS {
            "window".to_string()
        } else {
            m.class.clone()
        };
        match entry_for(&path, m.name.clone(), &class, licence, Some(m.size), m.rotation) {
            Ok(e) => report.indexed.push(e),
            Err(e) => report.skipped.push((file.display().to_string(), m.name, e.to_string())),
        }
    }
    Ok(())
}

fn add_future(dir: &Path, report: &mut BuildReport) -> Result<()> {
    let info_path = dir.join("model_info.json");
    let text = std::fs::read_to_string(&info_path).map_err(|e| Error::io(&info_path, e))?;
    let info: Vec<serde_json::Value> = serde_json::from_str(&text).map_err(|e| Error::io(&info_path, e))?;
    for m in info {
        let id = m["model_id"].as_str().unwrap_or_default().to_string();
        let category = m["category"].as_str().or(m["super-category"].as_str()).unwrap_or("object");
        let class = class_of(category, m["super-category"].as_str().unwrap_or(""));
        let path =
            ["raw_model.obj", "normalized_model.obj"].iter().map(|f| dir.join(&id).join(f)).find(|p| p.is_file());
        let Some(path) = path else {
            report.skipped.push((dir.display().to_string(), id, "no raw_model.obj or normalized_model.obj".into()));
            continue;
        };
        match entry_for(&path, id.clone(), &class, "3D-FUTURE licence (research use)".into(), None, None) {
            Ok(e) => report.indexed.push(e),
            Err(e) => report.skipped.push((dir.display().to_string(), id, e.to_string())),
        }
    }
    Ok(())
}

fn add_obj_folder(dir: &Path, report: &mut BuildReport) -> Result<()> {
    let set = super::ModelSet::from_folder(dir)?;
    report.indexed.extend(set.models);
    for (p, why) in set.skipped {
        report.skipped.push((dir.display().to_string(), p.display().to_string(), why));
    }
    Ok(())
}

/// The catalog format `build_db` writes (2: with silhouettes); an older cached index is rebuilt.
pub const CATALOG_VERSION: u32 = 2;

/// Indexes `sources` into `out` (writing `out/catalog.json`, and with `thumbnails` a 96 px render of every
/// model in `out/thumbs/`).
pub fn build_db(sources: &[PathBuf], out: &Path, thumbnails: bool) -> Result<BuildReport> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let mut report = BuildReport::default();
    for src in sources {
        let is_sh3f = |p: &Path| p.extension().is_some_and(|x| x.eq_ignore_ascii_case("sh3f"));
        if src.is_file() && is_sh3f(src) {
            if let Err(e) = add_sh3f(src, out, &mut report) {
                report.skipped.push((src.display().to_string(), "(library)".into(), e.to_string()));
            }
        } else if src.join("model_info.json").is_file() {
            add_future(src, &mut report)?;
        } else if src.is_dir() {
            let mut libs: Vec<PathBuf> = std::fs::read_dir(src)
                .map_err(|e| Error::io(src, e))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| is_sh3f(p))
                .collect();
            libs.sort();
            if libs.is_empty() {
                add_obj_folder(src, &mut report)?;
            }
            for lib in libs {
                if let Err(e) = add_sh3f(&lib, out, &mut report) {
                    report.skipped.push((lib.display().to_string(), "(library)".into(), e.to_string()));
                }
            }
        } else {
            return Err(Error::io(src, "not a .sh3f file, a 3D-FUTURE folder or a folder of models"));
        }
    }
    // Outline descriptors for every model, so retrieval can rank a large class without loading it.
    let silhouettes: Vec<Option<Vec<super::Silhouette>>> = report
        .indexed
        .par_iter()
        .map(|e| match e.silhouettes_or_render() {
            Ok(s) => Some(s),
            Err(err) => {
                eprintln!("  {}: no silhouettes ({err})", e.name);
                None
            }
        })
        .collect();
    let mut thumbs: Vec<Option<String>> = vec![None; report.indexed.len()];
    if thumbnails {
        let dir = out.join("thumbs");
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        for (k, e) in report.indexed.iter().enumerate() {
            let clean: String = e.name.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect();
            let file = format!("thumbs/{k:04}_{clean}.png");
            match super::thumbnail::render_thumbnail(e, &out.join(&file), 96) {
                Ok(()) => thumbs[k] = Some(file),
                Err(err) => {
                    report.skipped.push((e.path.display().to_string(), e.name.clone(), format!("thumbnail: {err}")))
                }
            }
        }
    }
    let models: Vec<serde_json::Value> = report
        .indexed
        .iter()
        .zip(&thumbs)
        .zip(&silhouettes)
        .map(|((e, thumb), sil)| {
            json!({
                "file": relative(out, &e.path), "name": e.name, "category": e.category, "licence": e.licence,
                "rotation": e.rotation, "scale": e.scale, "min": e.min, "max": e.max, "triangles": e.triangles,
                "thumbnail": thumb, "silhouettes": sil,
            })
        })
        .collect();
    let skipped: Vec<serde_json::Value> =
        report.skipped.iter().map(|(s, m, r)| json!({"source": s, "model": m, "reason": r})).collect();
    let catalog = json!({ "format": "psdr-models", "version": CATALOG_VERSION, "models": models, "skipped": skipped });
    let path = out.join("catalog.json");
    let text = serde_json::to_string_pretty(&catalog).map_err(|e| Error::io(&path, e))?;
    crate::output::write_atomically(&path, |tmp| std::fs::write(tmp, &text).map_err(|e| Error::io(tmp, e)))?;
    Ok(report)
}
