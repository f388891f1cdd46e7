//! The differentiable ops of losses, one family per file; each records its backward pass on the tape.

mod masks;
mod normalize;
mod pointwise;
mod reduce;
mod resample;
mod texture_descriptor;

pub use masks::{mean_color, soft_iou};
pub use normalize::{normalize, normalize_in};
pub use pointwise::{abs, add, div, mul, neg, scale, sqr, sqrt, sub};
pub use reduce::{charbonnier, l1, l2, masked_mean, mean, sum, weighted_mean};
pub use resample::{blur, crop, downsample, gaussian_pyramid};
pub use texture_descriptor::{texture_descriptor, texture_loss, texture_loss_to, MIN_CROP};
