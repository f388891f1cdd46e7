//! psdr: single photo to editable 3D room scene by path-space differentiable rendering.
//!
//! Where things are: `base` (what every layer shares: the image type, image files, small geometry), `scene` (the scene model and its JSON file), `render` (flattened buffers and the CPU
//! twins of the GLSL kernels), `backend` (CPU and Vulkan behind one interface), `output` (EXR/PNG),
//! `export` (Mitsuba 3), `grad` (derivatives), `loss` (the image-loss tape), `optim` (parameters, Adam, the
//! optimisation loop), `script` (Rhai stage scripts, `psdr run`), `report` (charts, report.html), `vision`
//! (photo observations), `models` (the image models `psdr models fetch` downloads), `stages` (the photo-to-scene stages), `db` (the furniture model database),
//! `progress` (what a long run is doing, said while it does it), `cli` (the `psdr` binary's commands).

pub mod backend;
pub mod base;
pub mod cli;
pub mod db;
pub mod error;
pub mod export;
pub mod grad;
pub mod loss;
pub mod models;
pub mod optim;
pub mod output;
pub mod progress;
pub mod render;
pub mod report;
pub mod scene;
pub mod script;
pub mod stages;
pub mod vision;

pub use error::{Error, Result};
