//! A model set: the models of a folder. With a `catalog.json` (what `psdr db build` writes, or written by hand:
//! `{"models": [{"file": "chairs/chair_2.obj", "name": "...", "category": "chair", "licence": "CC0",
//! "size": [w, h, d], "rotation": [9 numbers]}]}`) exactly its entries, each OBJ rotated by `rotation` (row-major,
//! optional) and scaled to `size` in metres (optional: else as stored); without one, every OBJ of the folder,
//! its category from the file name's leading word (`chair_2.obj` is a chair) and the licence "unknown".

use super::silhouette::{model_silhouettes, Silhouette};
use crate::error::{Error, Result};
use crate::scene::{drop_unseen_triangles, load_obj, MeshPart};
use crate::vision::canonical_class;
use glam::{Mat3, Vec3};
use std::path::{Path, PathBuf};

/// One model of the set.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ModelEntry {
    pub name: String,
    /// psdr's class.
    pub category: String,
    pub path: PathBuf,
    pub licence: String,
    /// Rotation (row-major) applied before scaling, as Sweet Home 3D's `modelRotation`.
    pub rotation: Option<[f32; 9]>,
    /// Per-axis factors from the OBJ's units (after rotation) to metres.
    pub scale: [f32; 3],
    /// Bounds after rotation and scaling, metres.
    pub min: [f32; 3],
    pub max: [f32; 3],
    pub triangles: usize,
    /// Outline descriptors (`silhouette::model_silhouettes`), when the catalog has them.
    #[serde(default)]
    pub silhouettes: Option<Vec<Silhouette>>,
    /// A render of the model (`psdr db build` writes one), when there is one.
    #[serde(default)]
    pub thumbnail: Option<PathBuf>,
}

impl ModelEntry {
    pub fn size(&self) -> Vec3 {
        Vec3::from(self.max) - Vec3::from(self.min)
    }

    fn transform(&self, v: Vec3) -> Vec3 {
        let r = self.rotation.map_or(v, |m| Mat3::from_cols_array(&m).transpose() * v);
        r * Vec3::from(self.scale)
    }

    /// The model's parts in metres, standing on y = 0 centred on x = z = 0.
    pub fn load_parts(&self) -> Result<Vec<MeshPart>> {
        let mut parts = load_obj(&self.path)?.parts;
        let (min, max) = (Vec3::from(self.min), Vec3::from(self.max));
        let offset = Vec3::new(-(min.x + max.x) / 2.0, -min.y, -(min.z + max.z) / 2.0);
        let rotated = self.rotation.is_some();
        for p in &mut parts {
            p.positions.iter_mut().for_each(|v| *v = self.transform(*v) + offset);
            if let Some(normals) = p.normals.as_mut() {
                // Normals follow the rotation and the inverse scale.
                let inv = Vec3::from(self.scale).recip();
                for n in normals.iter_mut() {
                    let r = if rotated {
                        self.rotation.map_or(*n, |m| Mat3::from_cols_array(&m).transpose() * *n)
                    } else {
                        *n
                    };
                    *n = (r * inv).normalize_or_zero();
                }
            }
        }
        // Scaled to metres, a sliver may round flat or onto another triangle.
        drop_unseen_triangles(&mut parts);
        if parts.is_empty() {
            return Err(Error::io(&self.path, "no triangle left with an area after scaling to metres"));
        }
        Ok(parts)
    }

    /// The catalog's outline descriptors, else rendered now.
    pub fn silhouettes_or_render(&self) -> Result<Vec<Silhouette>> {
        match &self.silhouettes {
            Some(s) => Ok(s.clone()),
            None => model_silhouettes(&self.load_parts()?),
        }
    }
}

/// Reads an OBJ and makes its entry: bounds after `rotation`, scaled so they span `size` where given.
pub fn entry_for(
    path: &Path,
    name: String,
    category: &str,
    licence: String,
    size: Option<[f32; 3]>,
    rotation: Option<[f32; 9]>,
) -> Result<ModelEntry> {
    let mesh = load_obj(path)?;
    let mut e = ModelEntry {
        name,
        category: canonical_class(category).0.to_string(),
        path: path.to_path_buf(),
        licence,
        rotation,
        scale: [1.0; 3],
        min: [0.0; 3],
        max: [0.0; 3],
        triangles: mesh.parts.iter().map(|p| p.indices.len()).sum(),
        silhouettes: None,
        thumbnail: None,
    };
    let bounds = |e: &ModelEntry| {
        mesh.parts.iter().flat_map(|p| &p.positions).fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(a, b), v| {
                let t = e.transform(*v);
                (a.min(t), b.max(t))
            },
        )
    };
    let (min, max) = bounds(&e);
    if !(min.is_finite() && max.is_finite()) {
        return Err(Error::io(path, "non-finite vertex positions"));
    }
    if let Some(s) = size {
        let ext = max - min;
        e.scale = [0, 1, 2].map(|k| if s[k] > 0.0 && ext[k] > 1e-9 { s[k] / ext[k] } else { 1.0 });
    }
    let (min, max) = bounds(&e);
    (e.min, e.max) = (min.to_array(), max.to_array());
    Ok(e)
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
    size: Option<[f32; 3]>,
    rotation: Option<[f32; 9]>,
    /// Written by `psdr db build` so a run need not read every OBJ to index it.
    scale: Option<[f32; 3]>,
    min: Option<[f32; 3]>,
    max: Option<[f32; 3]>,
    triangles: Option<usize>,
    silhouettes: Option<Vec<Silhouette>>,
    thumbnail: Option<String>,
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
        let mut set = ModelSet::default();
        let catalog_path = dir.join("catalog.json");
        if catalog_path.is_file() {
            let text = std::fs::read_to_string(&catalog_path).map_err(|e| Error::io(&catalog_path, e))?;
            let catalog: Catalog = serde_json::from_str(&text).map_err(|e| Error::io(&catalog_path, e))?;
            for c in catalog.models {
                let path = dir.join(&c.file);
                let stem = path.file_stem().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
                let name = c.name.unwrap_or(stem.clone());
                let category = c.category.unwrap_or_else(|| leading_word(&stem));
                let licence = c.licence.unwrap_or_else(|| "unknown".into());
                if let (Some(scale), Some(min), Some(max), Some(triangles)) = (c.scale, c.min, c.max, c.triangles) {
                    if path.is_file() {
                        let category = canonical_class(&category).0.to_string();
                        let e = ModelEntry {
                            name,
                            category,
                            path,
                            licence,
                            rotation: c.rotation,
                            scale,
                            min,
                            max,
                            triangles,
                            silhouettes: c.silhouettes,
                            thumbnail: c.thumbnail.map(|t| dir.join(t)),
                        };
                        set.models.push(e);
                    } else {
                        set.skipped.push((path, "file listed in catalog.json not found".into()));
                    }
                    continue;
                }
                match entry_for(&path, name, &category, licence, c.size, c.rotation) {
                    Ok(e) => set.models.push(e),
                    Err(e) => set.skipped.push((path, e.to_string())),
                }
            }
            return Ok(set);
        }
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
            .map_err(|e| Error::io(dir, e))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x.eq_ignore_ascii_case("obj")))
            .collect();
        files.sort();
        for path in files {
            let stem = path.file_stem().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
            match entry_for(&path, stem.clone(), &leading_word(&stem), "unknown".into(), None, None) {
                Ok(e) => set.models.push(e),
                Err(e) => set.skipped.push((path, e.to_string())),
            }
        }
        Ok(set)
    }

    /// The models of one class.
    pub fn of_class(&self, class: &str) -> Vec<&ModelEntry> {
        self.models.iter().filter(|m| m.category == class).collect()
    }
}

/// `chair_2` -> `chair`.
fn leading_word(stem: &str) -> String {
    stem.split(|c: char| c == '_' || c == '-' || c.is_ascii_digit()).next().unwrap_or("").to_string()
}
