//! The image models psdr can download (`psdr models fetch`, `psdr models list`): the pinned manifest
//! (`manifest`), where models live and whether a file there is the pinned one (`folder`), and the resumable,
//! verified download (`download`). The estimators that run them are in `vision` (`onnx_*`).

mod download;
mod folder;
mod manifest;

pub use download::{fetch_model, Fetched};
pub use folder::{
    cache_folder, fetch_folder, fetch_hint, fetch_hint_files, model_state, models_env, models_folder, part_path,
    sha256_file, ModelState,
};
pub use manifest::{Manifest, ModelEntry};
