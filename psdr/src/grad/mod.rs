//! Derivatives of rendered images with respect to named scene parameters (`scene::ParamPath`), by path-space
//! differentiable rendering: dI/dθ = interior + boundary. Where each piece lives, by what is differentiated:
//!
//! | output | parameters | term | function (file) |
//! |---|---|---|---|
//! | radiance | lights; material constants, texels, uv transform; procedural graphs and tints | interior: reverse-mode replay of recorded paths | `radiance_vjp` (interior/material_light.rs); for an L2 loss the fused estimator `radiance_vjp_cross` (interior/fused_l2.rs) |
//! | radiance | object poses, mesh vertices | interior: ray-form replay in dual numbers | `replay_radiance` (interior/geometry.rs; normal maps interior/normal_map.rs), called by `radiance_pose_vjp` (vjp/radiance_pose.rs; on Vulkan for poses: shaders/grad/interior/geometry.glsl) |
//! | radiance | poses, vertices | primary boundary: silhouettes seen by the camera | `primary_boundary` (boundary/primary.rs), `radiance_primary_boundary` (vjp/radiance_pose.rs; on Vulkan for poses: shaders/grad/vjp/radiance_pose.comp) |
//! | radiance | poses, vertices | secondary boundary: direct (shadows) and indirect | `secondary_boundary` (boundary/secondary.rs; candidate edges from boundary/edge_tree.rs over boundary/mesh_edges.rs; on Vulkan for poses: shaders/grad/boundary/secondary.glsl) |
//! | radiance | poses | secondary boundary, direct shadows seen by the camera: the light's emitted jump across moving silhouettes, sampled from the lights (edge point, light point, then the shadowed point) | `shadow_boundary` (boundary/shadow.rs; on the host for either backend) |
//! | radiance | poses, vertices | horizon boundary: a vertex's own tangent plane | `horizon_boundary` (boundary/horizon.rs) |
//! | depth, masks | poses, vertices | interior (depth only) + primary boundary | `aov_vjp`, `aovs_vjp` (vjp/aov.rs; on Vulkan for poses: shaders/grad/vjp/aov.comp) |
//! | depth, masks | materials, lights | none (zero) | |
//! | a loss of any outputs | any | all of the above | `outputs_vjp` (vjp/outputs.rs) |
//!
//! Estimators: `analytic_gradient` (estimate/analytic.rs) averages the above over seeds with standard errors;
//! `central_difference` (estimate/finite_difference.rs) is the truth every test compares with; image losses in
//! estimate/image_loss.rs. Shared machinery: dual numbers, BSDF derivatives and dual texture lookups (ad/), the
//! path recorder and the velocity fields of geometric parameters (path/).

mod ad;
pub(crate) mod boundary;
mod estimate;
mod interior;
mod path;
mod vjp;

pub use crate::scene::{ParamPath, TextureSlot};
pub use ad::bsdf_grad::{bsdf_eval_grad, BsdfGrad};
pub use boundary::primary::{project, project_velocity, PrimaryEdges};
pub use estimate::analytic::{analytic_gradient, AdEstimate, AdOptions, GradientEvaluator, ADJOINT_SEED_OFFSET};
pub use estimate::finite_difference::{central_difference, mean_and_std_err, FdEstimate, FdOptions};
pub use estimate::image_loss::{ImageLoss, Output, PixelwiseAdjoint};
pub use interior::fused_l2::radiance_vjp_cross;
pub use interior::material_light::{radiance_vjp, DeviceSlots, GradLayout};
pub use path::velocity::{PoseComponent, PoseLayout};
pub use vjp::aov::{aov_vjp, aovs_vjp, AovAdjoints};
pub use vjp::device_or_cpu::{aovs_vjp_on, radiance_primary_boundary_on, radiance_vjp_cross_on, radiance_vjp_on};
pub use vjp::outputs::{in_param_order, moves_geometry, outputs_vjp, OutputAdjoints};
pub use vjp::radiance_pose::{radiance_pose_vjp, radiance_primary_boundary, BoundarySamples};

// The host-side pieces the Vulkan kernels share with the CPU terms (the term API `backend` uses): the edge
// lists the boundary kernels sample, each object's mask adjoint, and the texture and normal-map reads' adjoints
// the host finishes in the CPU's order.
pub use boundary::secondary::SecondaryEdges;
pub use interior::material_light::{normal_read_adjoint, texture_read_adjoint};
pub use vjp::aov::masks_by_object;

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
