//! Atomic file output: write next to the target under a temporary name, then rename over it.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    let name = path.file_name().ok_or_else(|| Error::io(path, "not a file path"))?;
    // Keep the extension last: encoders pick the format from it.
    let tmp: PathBuf = path.with_file_name(format!(
        ".{}.{}.partial.{}",
        name.to_string_lossy(),
        std::process::id(),
        path.extension().and_then(|e| e.to_str()).unwrap_or("tmp")
    ));
    let result = write(&tmp).and_then(|_| std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e)));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
