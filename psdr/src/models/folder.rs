//! Where the image models are, and whether a model file there is the pinned one.
//!
//! The models folder is `--models DIR`, else `PSDR_MODELS` (an empty value counts as unset), else the cache
//! `psdr models fetch` fills: `$XDG_CACHE_HOME/psdr/models`, else `~/.cache/psdr/models`, when it exists.

use super::manifest::ModelEntry;
use crate::error::{Error, Result};
use sha2::{Digest, Sha256};
use std::io::Read;
use std::path::{Path, PathBuf};

/// The cache folder `psdr models fetch` writes into by default (it may not exist yet).
pub fn cache_folder() -> PathBuf {
    let non_empty = |v: &str| std::env::var_os(v).filter(|s| !s.is_empty()).map(PathBuf::from);
    match (non_empty("XDG_CACHE_HOME"), non_empty("HOME")) {
        (Some(c), _) => c.join("psdr/models"),
        (None, Some(h)) => h.join(".cache/psdr/models"),
        (None, None) => PathBuf::from(".psdr-models"),
    }
}

/// `PSDR_MODELS`, unless unset or empty.
pub fn models_env() -> Option<PathBuf> {
    std::env::var_os("PSDR_MODELS").filter(|s| !s.is_empty()).map(PathBuf::from)
}

/// The folder the observations read models from: the flag, else `PSDR_MODELS`, else the cache if it exists.
pub fn models_folder(flag: Option<&Path>) -> Option<PathBuf> {
    flag.map(Path::to_path_buf).or_else(models_env).or_else(|| Some(cache_folder()).filter(|c| c.is_dir()))
}

/// Where `psdr models fetch` writes: the flag, else `PSDR_MODELS`, else the cache.
pub fn fetch_folder(flag: Option<&Path>) -> PathBuf {
    flag.map(Path::to_path_buf).or_else(models_env).unwrap_or_else(cache_folder)
}

/// What the models folder holds for one manifest entry.
#[derive(Clone, Debug, PartialEq)]
pub enum ModelState {
    /// The file, with the pinned size and checksum.
    Valid,
    Missing,
    /// An interrupted download (`FILE.part`): bytes so far.
    Partial(u64),
    /// A file of that name that is not the pinned one (size or checksum differ): why.
    Different(String),
}

/// The state of `entry` in `dir`. `verify`: compare the checksum too (reads the whole file), else the size only.
pub fn model_state(entry: &ModelEntry, dir: &Path, verify: bool) -> Result<ModelState> {
    let path = dir.join(&entry.file);
    let Ok(meta) = std::fs::metadata(&path) else {
        let part = part_path(&path);
        return Ok(match std::fs::metadata(&part) {
            Ok(m) => ModelState::Partial(m.len()),
            Err(_) => ModelState::Missing,
        });
    };
    if meta.len() != entry.size {
        return Ok(ModelState::Different(format!("{} bytes, the pinned file has {}", meta.len(), entry.size)));
    }
    if verify {
        let sum = sha256_file(&path)?;
        if sum != entry.sha256 {
            return Ok(ModelState::Different(format!("SHA-256 {sum}, the pinned file's is {}", entry.sha256)));
        }
    }
    Ok(ModelState::Valid)
}

/// `FILE.part`: where a download goes until it is complete and verified.
pub fn part_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".part");
    path.with_file_name(name)
}

/// The SHA-256 of a file, lower-case hex.
pub fn sha256_file(path: &Path) -> Result<String> {
    let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = f.read(&mut buf).map_err(|e| Error::io(path, e))?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    Ok(hasher.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// How to get the model for `file` (`depth.onnx`): the command, and the manual way on a machine without
/// internet. Every "no depth / no segmentation" message ends with it.
pub fn fetch_hint(file: &str) -> String {
    fetch_hint_files(&[file])
}

/// How to get the models for `files` at once (a photo with nothing beside it lacks depth and segmentation):
/// one `psdr models fetch`, or each file by hand with its URL and checksum.
pub fn fetch_hint_files(files: &[&str]) -> String {
    let manifest = super::Manifest::pinned();
    let dir = cache_folder();
    let pinned: Vec<_> = files.iter().filter_map(|f| manifest.by_file(f)).collect();
    let unpinned: Vec<&str> = files.iter().copied().filter(|f| manifest.by_file(f).is_none()).collect();
    let mut parts = vec![];
    if !pinned.is_empty() {
        let what: Vec<String> =
            pinned.iter().map(|e| format!("{}, {:.0} MB, {}", e.file, e.size as f64 / 1e6, e.licence)).collect();
        let by_hand: Vec<String> = pinned
            .iter()
            .map(|e| format!("{} (SHA-256 {}) to {}", e.url, e.sha256, dir.join(&e.file).display()))
            .collect();
        parts.push(format!(
            "or run `psdr models fetch` once (downloads {} into {}); without internet, download elsewhere and check \
             the SHA-256: {}",
            what.join("; "),
            dir.display(),
            by_hand.join(", ")
        ));
    }
    for f in unpinned {
        parts.push(format!("or put a {f} (docs/observations.md gives its contract) into {}", dir.display()));
    }
    parts.join(", ")
}
