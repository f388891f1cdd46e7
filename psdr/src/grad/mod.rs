//! Derivatives of rendered images with respect to named scene parameters. So far: parameter paths, image losses,
//! central finite differences with standard errors (the ground truth), and the interior term in reverse mode
//! for parameters that do not move geometry.

mod ad_estimate;
mod bsdf_grad;
mod finite_difference;
mod image_loss;
mod interior;
mod param_path;

pub use ad_estimate::{interior_gradient, AdEstimate};
pub use bsdf_grad::{bsdf_eval_grad, BsdfGrad};
pub use finite_difference::{central_difference, mean_and_std_err, FdEstimate, FdOptions};
pub use image_loss::{ImageLoss, Output};
pub use interior::{radiance_vjp, GradLayout};
pub use param_path::{ParamPath, TextureSlot};
