//! The pinned image models (`psdr/models.json`, compiled in): for each its file name in the models folder, the
//! URL at a fixed revision, size, SHA-256, licence, source and input/output contract. `--manifest FILE` reads
//! another of the same shape (a mirror, or the tests' models served from 127.0.0.1).

use crate::error::{Error, Result};
use serde::Deserialize;
use std::path::Path;

/// The manifest shipped with psdr.
const PINNED: &str = include_str!("../../models.json");

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ModelEntry {
    /// What the model estimates: `depth`, `segmentation`, `fov`, `embedding`.
    pub name: String,
    /// Its file in the models folder, the name the observations look for (`depth.onnx`).
    pub file: String,
    pub url: String,
    /// Bytes.
    pub size: u64,
    /// Lower-case hex.
    pub sha256: String,
    pub licence: String,
    pub source: String,
    pub contract: String,
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    #[serde(default)]
    pub about: String,
    pub models: Vec<ModelEntry>,
}

impl Manifest {
    /// The manifest compiled into psdr.
    pub fn pinned() -> Manifest {
        // Checked by a unit test; a broken file in the repository fails it, not a user's run.
        Manifest::parse(PINNED, Path::new("psdr/models.json")).expect("psdr/models.json is valid")
    }

    pub fn load(path: &Path) -> Result<Manifest> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Manifest::parse(&text, path)
    }

    /// Parses and checks a manifest: plain file names, http(s) URLs, sizes above 0, 64-digit hex checksums,
    /// no name or file twice.
    pub fn parse(text: &str, path: &Path) -> Result<Manifest> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let mut m: Manifest = serde_path_to_error::deserialize(de)
            .map_err(|e| Error::io(path, format!("{}: {}", e.path(), e.inner())))?;
        for (i, e) in m.models.iter_mut().enumerate() {
            let bad = |what: String| Error::io(path, format!("models[{i}] ('{}'): {what}", e.name));
            e.sha256 = e.sha256.to_ascii_lowercase();
            if e.sha256.len() != 64 || !e.sha256.bytes().all(|b| b.is_ascii_hexdigit()) {
                return Err(bad(format!("sha256 must be 64 hex digits, not '{}'", e.sha256)));
            }
            let plain = Path::new(&e.file).file_name().is_some_and(|n| n == e.file.as_str());
            if !plain || !e.file.ends_with(".onnx") {
                return Err(bad(format!("file must be a plain NAME.onnx, not '{}'", e.file)));
            }
            if !(e.url.starts_with("https://") || e.url.starts_with("http://")) {
                return Err(bad(format!("url must be http(s), not '{}'", e.url)));
            }
            if e.size == 0 {
                return Err(bad("size must be above 0".into()));
            }
        }
        for (i, e) in m.models.iter().enumerate() {
            if m.models[..i].iter().any(|o| o.name == e.name || o.file == e.file) {
                return Err(Error::io(path, format!("models[{i}]: '{}' ({}) is listed twice", e.name, e.file)));
            }
        }
        Ok(m)
    }

    /// The entries named (all when `names` is empty), or an error listing the known names.
    pub fn select(&self, names: &[String]) -> Result<Vec<&ModelEntry>> {
        if names.is_empty() {
            return Ok(self.models.iter().collect());
        }
        names
            .iter()
            .map(|n| {
                self.models.iter().find(|e| &e.name == n || &e.file == n).ok_or_else(|| {
                    let known: Vec<&str> = self.models.iter().map(|e| e.name.as_str()).collect();
                    Error::Invalid(format!("no model named '{n}' in the manifest (known: {})", known.join(", ")))
                })
            })
            .collect()
    }

    /// The entry whose file is `file` (`depth.onnx`).
    pub fn by_file(&self, file: &str) -> Option<&ModelEntry> {
        self.models.iter().find(|e| e.file == file)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pinned_manifest_is_valid_and_pins_revisions() {
        let m = Manifest::pinned();
        assert!(m.models.iter().any(|e| e.file == "depth.onnx"));
        assert!(m.models.iter().any(|e| e.file == "segmentation.onnx"));
        for e in &m.models {
            // A URL at a moving branch would change under the checksum: each names a 40-digit revision.
            let rev = e.url.split('/').find(|s| s.len() == 40 && s.bytes().all(|b| b.is_ascii_hexdigit()));
            assert!(rev.is_some() && e.url.starts_with("https://"), "{} is not pinned: {}", e.name, e.url);
            assert!(!e.licence.is_empty() && !e.contract.is_empty() && !e.source.is_empty());
        }
    }

    #[test]
    fn malformed_manifests_name_the_entry_and_field() {
        let p = Path::new("m.json");
        let entry = |sha: &str, file: &str| {
            format!(
                r#"{{"models": [{{"name": "depth", "file": "{file}", "url": "https://x/y", "size": 3, "sha256": "{sha}",
                "licence": "MIT", "source": "s", "contract": "c"}}]}}"#
            )
        };
        let good = "ab".repeat(32);
        assert!(Manifest::parse(&entry(&good, "depth.onnx"), p).is_ok());
        let e = Manifest::parse(&entry("abc", "depth.onnx"), p).unwrap_err().to_string();
        assert!(e.contains("models[0] ('depth')") && e.contains("64 hex"), "{e}");
        let e = Manifest::parse(&entry(&good, "../depth.onnx"), p).unwrap_err().to_string();
        assert!(e.contains("plain NAME.onnx"), "{e}");
        let e = Manifest::parse(r#"{"models": [{"name": "depth"}]}"#, p).unwrap_err().to_string();
        assert!(e.contains("models[0]") && e.contains("file"), "{e}");
    }
}
