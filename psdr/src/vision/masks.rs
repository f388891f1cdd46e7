//! Instance segmentation: a 16-bit PNG of instance ids (0 = no instance) and a labels file naming each id's
//! class (`{"3": "sofa", ...}`), mapped to psdr's classes. An id without a label is an `object`.

use super::classes::{canonical_class, ClassKind};
use crate::error::{Error, Result};
use std::collections::BTreeMap;
use std::path::Path;

/// One segmented instance.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Instance {
    pub id: u16,
    /// The label as given (None: no label for this id).
    pub label: Option<String>,
    /// psdr's class for it.
    pub class: String,
    #[serde(skip)]
    pub kind: ClassKind,
    pub pixels: usize,
}

/// Instance ids per pixel and the instances.
#[derive(Clone, Debug, PartialEq)]
pub struct Instances {
    pub width: usize,
    pub height: usize,
    pub ids: Vec<u16>,
    pub instances: Vec<Instance>,
}

impl Instances {
    /// The binary mask (1.0 inside) of every instance of `class`.
    pub fn class_mask(&self, class: &str) -> Vec<f32> {
        let ids: Vec<u16> = self.instances.iter().filter(|i| i.class == class).map(|i| i.id).collect();
        self.ids.iter().map(|id| ids.contains(id) as u32 as f32).collect()
    }

    /// The binary mask of one instance.
    pub fn instance_mask(&self, id: u16) -> Vec<f32> {
        self.ids.iter().map(|&v| (v == id) as u32 as f32).collect()
    }
}

/// Reads the ids (a 16-bit grey PNG; 8-bit is accepted for small scenes) and labels; with `size`, a mask of
/// another size is refused first (before its labels are checked against it). Labels of ids the mask does not
/// hold (an object cropped out of the photo, an exporter that lists every class) are left out with a warning
/// (returned); labels none of whose ids the mask holds are an error (a mask of another photo).
pub fn load_instances(
    masks: &Path,
    labels: Option<&Path>,
    size: Option<(usize, usize)>,
) -> Result<(Instances, Vec<String>)> {
    if !masks.is_file() {
        return Err(Error::io(masks, "mask file not found"));
    }
    let img = image::open(masks).map_err(|e| Error::io(masks, e))?;
    let ids: Vec<u16> = match &img {
        image::DynamicImage::ImageLuma16(g) => g.as_raw().clone(),
        image::DynamicImage::ImageLuma8(g) => g.as_raw().iter().map(|&v| v as u16).collect(),
        _ => return Err(Error::io(masks, "instance ids must be a 16-bit (or 8-bit) grey PNG, 0 = no instance")),
    };
    let (width, height) = (img.width() as usize, img.height() as usize);
    if let Some((w, h)) = size.filter(|s| *s != (width, height)) {
        return Err(Error::io(
            masks,
            format!("the instance mask is {width}x{height} but the photo is {w}x{h}; they must be the same size"),
        ));
    }
    let mut counts: BTreeMap<u16, usize> = BTreeMap::new();
    for &id in ids.iter().filter(|&&id| id != 0) {
        *counts.entry(id).or_default() += 1;
    }
    if counts.is_empty() {
        return Err(Error::io(masks, "the mask holds no instance (every id is 0)"));
    }
    let mut names: BTreeMap<u16, String> = BTreeMap::new();
    let mut warnings = vec![];
    if let Some(path) = labels {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let raw: BTreeMap<String, String> = serde_json::from_str(&text)
            .map_err(|e| Error::io(path, format!("expected {{\"<id>\": \"<class>\"}}: {e}")))?;
        let mut absent = vec![];
        for (k, v) in raw {
            let id: u16 =
                k.trim().parse().map_err(|_| Error::io(path, format!("'{k}' is not an instance id (1..65535)")))?;
            if !counts.contains_key(&id) {
                absent.push(id);
            }
            names.insert(id, v);
        }
        if !absent.is_empty() && absent.len() == names.len() {
            return Err(Error::io(
                path,
                format!(
                    "the labels name ids {absent:?}, none of which the mask {} contains (ids there: {:?}; a mask of \
                     another photo?)",
                    masks.display(),
                    counts.keys().collect::<Vec<_>>()
                ),
            ));
        }
        if !absent.is_empty() {
            warnings.push(format!(
                "labels: {} names ids {absent:?} that the mask {} does not contain; they are left out",
                path.display(),
                masks.display()
            ));
            names.retain(|id, _| !absent.contains(id));
        }
    }
    let unknown: Vec<String> = names
        .iter()
        .filter(|(_, label)| canonical_class(label).0 == super::classes::UNKNOWN_CLASS && label.as_str() != "object")
        .map(|(id, label)| format!("'{label}' (id {id})"))
        .collect();
    if !unknown.is_empty() {
        warnings.push(format!(
            "labels: no psdr class for {}; kept as `object` (retrieved from the whole database). Known: {}",
            unknown.join(", "),
            super::classes::class_names().join(", ")
        ));
    }
    let instances = counts
        .into_iter()
        .map(|(id, pixels)| {
            let label = names.get(&id).cloned();
            let (class, kind) = canonical_class(label.as_deref().unwrap_or(""));
            Instance { id, label, class: class.to_string(), kind, pixels }
        })
        .collect();
    Ok((Instances { width, height, ids, instances }, warnings))
}
