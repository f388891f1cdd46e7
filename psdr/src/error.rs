//! One error type for user-facing failures: every message names the file, the field and what is wrong.

use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene or asset file is wrong; `field` is a JSON-pointer-like path ("shapes[2].transform.scale").
    #[error("{file}: {field}: {message}")]
    Scene { file: PathBuf, field: String, message: String },
    #[error("{file}: {message}")]
    Io { file: PathBuf, message: String },
    #[error("{0}")]
    Invalid(String),
    #[error("backend: {0}")]
    Backend(String),
}

impl Error {
    pub fn scene(file: &Path, field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Scene { file: file.to_path_buf(), field: field.into(), message: message.into() }
    }
    pub fn io(file: &Path, err: impl std::fmt::Display) -> Self {
        Error::Io { file: file.to_path_buf(), message: err.to_string() }
    }
}

pub type Result<T> = std::result::Result<T, Error>;
