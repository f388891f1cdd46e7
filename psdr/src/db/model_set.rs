//! A folder of OBJ models as a model set. Each model's category, display name and licence come from the
//! folder's `catalog.json` when it lists the file (`{"models": [{"file": "chair_2.obj", "name": "...",
//! "category": "chair", "licence": "CC0"}]}`), else the category from the file name (its leading word, mapped
//! to psdr's classes: `chair_2.obj` is a chair) and the licence "unknown". Sizes are the OBJ's bounds, in its
//! units (metres for psdr's and Sweet Home 3D's exports).

use crate::error::{Error, Result};
use crate::scene::load_obj;
use crate::scene::MeshPart;
use crate::vision::canonical_class;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// One model of the set.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ModelEntry {
    pub name: String,
    /// psdr's class.
    pub category: String,
    pub path: PathBuf,
    pub licence: String,
    /// Axis-aligned bounds of the OBJ as stored.
    pub min: [f32; 3],
    pub max: [f32; 3],
    pub triangles: usize,
}

impl ModelEntry {
    pub fn size(&self) -> Vec3 {
        Vec3::from(self.max) - Vec3::from(self.min)
    }

    /// The model's parts moved so that it stands on y = 0 centred on x = z = 0.
    pub fn load_parts(&self) -> Result<Vec<MeshPart>> {
        let mut parts = load_obj(&self.path)?.parts;
        let (min, max) = (Vec3::from(self.min), Vec3::from(self.max));
        let offset = Vec3::new(-(min.x + max.x) / 2.0, -min.y, -(min.z + max.z) / 2.0);
        for p in &mut parts {
            p.positions.iter_mut().for_each(|v| *v += offset);
        }
        Ok(parts)
    }
}

#[derive(serde::Deserialize)]
struct Catalog {
    models: Vec<CatalogEntry>,
}

#[derive(serde::Deserialize)]
struct CatalogEntry {
    file: String,
    name: Option<String>,
    category: Option<String>,
    licence: Option<String>,
}

/// The models of a folder; `skipped` says which files could not be read and why.
#[derive(Clone, Debug, Default)]
pub struct ModelSet {
    pub models: Vec<ModelEntry>,
    pub skipped: Vec<(PathBuf, String)>,
}

impl ModelSet {
    pub fn from_folder(dir: &Path) -> Result<ModelSet> {
        if !dir.is_dir() {
            return Err(Error::io(dir, "model folder not found"));
        }
        let catalog: Vec<CatalogEntry> = match std::fs::read_to_string(dir.join("catalog.json")) {
            Ok(text) => {
                serde_json::from_str::<Catalog>(&text).map_err(|e| Error::io(&dir.join("catalog.json"), e))?.models
            }
            Err(_) => vec![],
        };
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
            .map_err(|e| Error::io(dir, e))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x.eq_ignore_ascii_case("obj")))
            .collect();
        files.sort();
        let mut set = ModelSet::default();
        for path in files {
            let file = path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
            let stem = path.file_stem().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
            let listed = catalog.iter().find(|c| c.file == file);
            let word = stem.split(|c: char| c == '_' || c == '-' || c.is_ascii_digit()).next().unwrap_or("");
            let category = listed.and_then(|c| c.category.clone()).unwrap_or_else(|| word.to_string());
            let mesh = match load_obj(&path) {
                Ok(m) => m,
                Err(e) => {
                    set.skipped.push((path.clone(), e.to_string()));
                    continue;
                }
            };
            let (mut min, mut max) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
            for v in mesh.parts.iter().flat_map(|p| &p.positions) {
                min = min.min(*v);
                max = max.max(*v);
            }
            if !(min.is_finite() && max.is_finite()) || (max - min).min_element() < 0.0 {
                set.skipped.push((path.clone(), "non-finite vertex positions".into()));
                continue;
            }
            set.models.push(ModelEntry {
                name: listed.and_then(|c| c.name.clone()).unwrap_or(stem),
                category: canonical_class(&category).0.to_string(),
                path,
                licence: listed.and_then(|c| c.licence.clone()).unwrap_or_else(|| "unknown".into()),
                min: min.to_array(),
                max: max.to_array(),
                triangles: mesh.parts.iter().map(|p| p.indices.len()).sum(),
            });
        }
        Ok(set)
    }

    /// The models of one class.
    pub fn of_class(&self, class: &str) -> Vec<&ModelEntry> {
        self.models.iter().filter(|m| m.category == class).collect()
    }
}
