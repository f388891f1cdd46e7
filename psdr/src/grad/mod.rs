//! Derivatives of rendered images with respect to named scene parameters. So far: parameter paths, image losses,
//! central finite differences with standard errors (the ground truth), the interior term in reverse mode
//! for parameters that do not move geometry, and depth/mask gradients w.r.t. poses (interior + primary boundary).

mod ad_estimate;
mod aov_vjp;
mod bsdf_dual;
mod bsdf_grad;
mod cross_adjoint;
mod dual;
mod edge_tree;
mod finite_difference;
mod geometry_interior;
mod horizon_boundary;
mod image_loss;
mod interior;
mod mesh_edges;
mod normal_map_grad;
mod output_adjoints;
mod param_path;
mod path_record;
mod pose_velocity;
mod primary_edges;
mod radiance_pose_vjp;
mod secondary_edges;

pub use ad_estimate::{analytic_gradient, AdEstimate, AdOptions, GradientEvaluator, ADJOINT_SEED_OFFSET};
pub use aov_vjp::{aov_vjp, aovs_vjp, AovAdjoints};
pub use bsdf_grad::{bsdf_eval_grad, BsdfGrad};
pub use cross_adjoint::radiance_vjp_cross;
pub use finite_difference::{central_difference, mean_and_std_err, FdEstimate, FdOptions};
pub use image_loss::{ImageLoss, Output, PixelwiseAdjoint};
pub use interior::{radiance_vjp, GradLayout};
pub use output_adjoints::{in_param_order, moves_geometry, outputs_vjp, OutputAdjoints};
pub use param_path::{ParamPath, TextureSlot};
pub use pose_velocity::{PoseComponent, PoseLayout};
pub use primary_edges::{project, project_velocity, PrimaryEdges};
pub use radiance_pose_vjp::{radiance_pose_vjp, BoundarySamples};

/// Blocks a parallel gradient accumulation is split into: fixed (the sum's order, hence its rounding, never
/// depends on the thread count) and few (each holds a full gradient vector, and vertex gradients of a large
/// mesh make those long).
const GRAD_BLOCKS: usize = 32;

/// Σ over items 0..n of their contributions to a gradient of `len` floats: `add(range, grad)` adds those of
/// one contiguous block of items; blocks run in parallel and are summed in order.
pub(crate) fn accumulate_blocks<F>(n: usize, len: usize, add: F) -> Vec<f64>
where
    F: Fn(std::ops::Range<usize>, &mut [f64]) + Sync,
{
    use rayon::prelude::*;
    let blocks = n.min(GRAD_BLOCKS);
    let partial: Vec<Vec<f64>> = (0..blocks)
        .into_par_iter()
        .map(|b| {
            let mut g = vec![0.0f64; len];
            add(b * n / blocks..(b + 1) * n / blocks, &mut g);
            g
        })
        .collect();
    let mut grad = vec![0.0f64; len];
    for p in partial {
        grad.iter_mut().zip(p).for_each(|(g, v)| *g += v);
    }
    grad
}

/// Refuses an adjoint image of the wrong size or with non-finite values (they would poison every gradient).
pub(crate) fn check_adjoint(adjoint: &[f32], expected: usize) -> crate::Result<()> {
    if adjoint.len() != expected {
        return Err(crate::Error::Invalid(format!("adjoint image has {} values, expected {expected}", adjoint.len())));
    }
    match adjoint.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(crate::Error::Invalid(format!("adjoint image value {i} is not finite"))),
        None => Ok(()),
    }
}
