//! Estimators of a loss's gradient: analytic (averaged over seeds), finite differences (the truth), and the losses.

pub(crate) mod analytic;
pub(crate) mod finite_difference;
pub(crate) mod image_loss;
