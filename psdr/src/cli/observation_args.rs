//! The observation flags shared by `psdr observe` and `psdr run`: each replaces the file beside the photo.

use crate::vision::{DepthUnits, ObservationInputs, DEFAULT_CAMERA_HEIGHT};
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args, Clone, Debug)]
pub struct ObservationArgs {
    /// Depth map (EXR, or 16-bit PNG) instead of STEM.depth.exr/.png beside the photo.
    #[arg(long)]
    depth: Option<PathBuf>,
    /// What the depth values are: metres, relative (affine in depth) or disparity (affine in inverse depth, as
    /// monocular depth networks give); the last two are made metric on the room's planes.
    #[arg(long, default_value = "metres")]
    depth_units: DepthUnits,
    /// Instance ids (16-bit PNG, 0 = none) instead of STEM.masks.png.
    #[arg(long)]
    masks: Option<PathBuf>,
    /// Instance classes ({"<id>": "<class>"}) instead of STEM.labels.json.
    #[arg(long)]
    labels: Option<PathBuf>,
    /// Vertical field of view in degrees instead of STEM.camera.json (else: vanishing points, else a default).
    #[arg(long)]
    fov: Option<f32>,
    /// Camera height above the floor in metres, the prior that sets the scale when depth is relative.
    #[arg(long, default_value_t = DEFAULT_CAMERA_HEIGHT)]
    camera_height: f32,
    /// Folder of ONNX models (depth.onnx, segmentation.onnx, fov.onnx) for what no file gives; default:
    /// PSDR_MODELS (empty: unset), else ~/.cache/psdr/models where `psdr models fetch` puts them.
    #[arg(long)]
    models: Option<PathBuf>,
    /// The vanishing-point fov is used only when its bootstrap standard deviation is below this many degrees.
    #[arg(long, default_value_t = 1.0)]
    fov_max_sigma: f32,
}

impl ObservationArgs {
    /// `--models`, when given.
    pub fn models_flag(&self) -> Option<&Path> {
        self.models.as_deref()
    }

    pub fn inputs(&self, photo: &Path) -> ObservationInputs {
        ObservationInputs {
            photo: photo.to_path_buf(),
            depth: self.depth.clone(),
            depth_units: self.depth_units,
            masks: self.masks.clone(),
            labels: self.labels.clone(),
            fov_y_deg: self.fov,
            camera_height: self.camera_height,
            models: crate::models::models_folder(self.models.as_deref()),
            fov_max_sigma_deg: self.fov_max_sigma,
        }
    }
}
