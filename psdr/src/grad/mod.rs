//! Derivatives of rendered images with respect to named scene parameters. So far: the parameter paths, image
//! losses and central finite differences with standard errors (the ground truth for analytic gradients).

mod finite_difference;
mod image_loss;
mod param_path;

pub use finite_difference::{central_difference, mean_and_std_err, FdEstimate, FdOptions};
pub use image_loss::{ImageLoss, Output};
pub use param_path::{ParamPath, TextureSlot};
