//! Sweet Home 3D furniture libraries (`.sh3f`: a zip of OBJ models, their MTL and textures, and
//! `PluginFurnitureCatalog.properties` naming each model with its category, size in centimetres, orientation,
//! creator and the library's licence). Entries are read from the catalog; psdr's class comes from the model's
//! name (then its words, then its tags), not from Sweet Home 3D's room categories.

use crate::error::{Error, Result};
use crate::vision::canonical_class;
use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

/// One catalog entry.
#[derive(Clone, Debug, PartialEq)]
pub struct Sh3fModel {
    pub id: String,
    pub name: String,
    /// psdr's class ("object" when nothing matches).
    pub class: String,
    /// Path of the OBJ inside the archive (no leading '/').
    pub model: String,
    /// Width (x), height (y), depth (z) in metres.
    pub size: [f32; 3],
    /// Row-major 3x3 rotation applied to the model before it is scaled to `size`.
    pub rotation: Option<[f32; 9]>,
    pub creator: Option<String>,
    pub door_or_window: bool,
}

/// A library: its licence and models.
#[derive(Clone, Debug, PartialEq)]
pub struct Sh3fLibrary {
    pub name: String,
    pub licence: String,
    pub models: Vec<Sh3fModel>,
}

/// Java properties: `key=value` lines, `#`/`!` comments, `\uXXXX` escapes, `\` line continuations.
fn parse_properties(text: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut pending = String::new();
    for raw in text.lines() {
        let line = raw.trim_start();
        if pending.is_empty() && (line.starts_with('#') || line.starts_with('!') || line.is_empty()) {
            continue;
        }
        if let Some(cont) = line.strip_suffix('\\').filter(|l| !l.ends_with('\\')) {
            pending.push_str(cont);
            continue;
        }
        pending.push_str(line);
        let full = std::mem::take(&mut pending);
        let Some(eq) = full.find(['=', ':']) else { continue };
        let (k, v) = (full[..eq].trim(), full[eq + 1..].trim());
        out.insert(unescape(k), unescape(v));
    }
    out
}

fn unescape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut chars = s.chars().peekable();
    while let Some(c) = chars.next() {
        if c != '\\' {
            out.push(c);
            continue;
        }
        match chars.next() {
            Some('u') => {
                let hex: String = chars.by_ref().take(4).collect();
                out.extend(u32::from_str_radix(&hex, 16).ok().and_then(char::from_u32));
            }
            Some('n') => out.push('\n'),
            Some('t') => out.push('\t'),
            Some(other) => out.push(other),
            None => {}
        }
    }
    out
}

/// psdr's class for a model: its name, then each word of the name from the last, then its tags. Floor, wall
/// and ceiling are never a model's class ("Wall socket" is an object).
pub fn class_of(name: &str, tags: &str) -> String {
    let known = |s: &str| {
        let (c, kind) = canonical_class(s);
        Some(c).filter(|c| *c != crate::vision::UNKNOWN_CLASS && kind != crate::vision::ClassKind::Structure)
    };
    known(name)
        .or_else(|| name.split_whitespace().rev().find_map(known))
        .or_else(|| tags.split(',').find_map(|t| known(t.trim())))
        .unwrap_or(crate::vision::UNKNOWN_CLASS)
        .to_string()
}

/// Reads a library's catalog.
pub fn read_sh3f(path: &Path) -> Result<Sh3fLibrary> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut zip =
        zip::ZipArchive::new(file).map_err(|e| Error::io(path, format!("not a readable .sh3f (zip): {e}")))?;
    let mut text = String::new();
    {
        let mut entry = zip
            .by_name("PluginFurnitureCatalog.properties")
            .map_err(|_| Error::io(path, "no PluginFurnitureCatalog.properties inside"))?;
        let mut bytes = vec![];
        entry.read_to_end(&mut bytes).map_err(|e| Error::io(path, e))?;
        // Properties files are ISO-8859-1.
        text.extend(bytes.iter().map(|&b| b as char));
    }
    let props = parse_properties(&text);
    let mut models = vec![];
    for n in 1.. {
        let get = |k: &str| props.get(&format!("{k}#{n}")).cloned();
        let Some(model) = get("model") else { break };
        let num = |k: &str| get(k).and_then(|v| v.parse::<f32>().ok());
        let name = get("name").unwrap_or_else(|| format!("model {n}"));
        let rotation = get("modelRotation").and_then(|r| {
            let v: Vec<f32> = r.split_whitespace().filter_map(|x| x.parse().ok()).collect();
            <[f32; 9]>::try_from(v).ok()
        });
        models.push(Sh3fModel {
            id: get("id").unwrap_or_else(|| format!("#{n}")),
            class: class_of(&name, &get("tags").unwrap_or_default()),
            name,
            model: model.trim_start_matches('/').to_string(),
            size: [
                num("width").unwrap_or(0.0) / 100.0,
                num("height").unwrap_or(0.0) / 100.0,
                num("depth").unwrap_or(0.0) / 100.0,
            ],
            rotation,
            creator: get("creator"),
            door_or_window: get("doorOrWindow").is_some_and(|v| v == "true"),
        });
    }
    Ok(Sh3fLibrary {
        name: props
            .get("name")
            .cloned()
            .unwrap_or_else(|| path.file_stem().unwrap_or_default().to_string_lossy().into()),
        licence: props.get("license").cloned().unwrap_or_else(|| "unknown (see the library's LICENSE.TXT)".into()),
        models,
    })
}

/// Extracts every file of the archive but its catalogs and icons into `dir` (entries with unsafe paths are
/// skipped). Returns the number of files written.
pub fn extract_sh3f(path: &Path, dir: &Path) -> Result<usize> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut zip =
        zip::ZipArchive::new(file).map_err(|e| Error::io(path, format!("not a readable .sh3f (zip): {e}")))?;
    let mut written = 0;
    for i in 0..zip.len() {
        let mut entry = zip.by_index(i).map_err(|e| Error::io(path, e))?;
        let Some(rel) = entry.enclosed_name() else { continue };
        let name = rel.to_string_lossy().to_string();
        if entry.is_dir() || name.ends_with(".properties") {
            continue;
        }
        let out = dir.join(&rel);
        if let Some(parent) = out.parent() {
            std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
        }
        let mut bytes = vec![];
        entry.read_to_end(&mut bytes).map_err(|e| Error::io(path, format!("{name}: {e}")))?;
        std::fs::write(&out, bytes).map_err(|e| Error::io(&out, e))?;
        written += 1;
    }
    Ok(written)
}
