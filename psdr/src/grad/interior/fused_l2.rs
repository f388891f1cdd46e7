//! The fused primal-adjoint estimator of an L2 radiance loss's gradient w.r.t. parameters that do not move
//! geometry: one pass of recorded paths gives both the image the adjoint is computed from and the paths the
//! adjoint is distributed along, where the two-pass estimator (`analytic_gradient`'s primal render, then
//! `radiance_vjp`) traces every sample twice.
//!
//! The loss gradient is Σ_p δ(I_p) · ∂I_p/∂θ with δ(I) = s (I − T) affine. Using one set of paths for both
//! factors would multiply correlated estimates (biased by their covariance); instead each pixel's samples are
//! split into two halves A and B drawn with independent seeds, and
//!     G_p = ½ [ δ(I_A) · ∂I_B + δ(I_B) · ∂I_A ],
//! each product of independent estimates, so E[G_p] = δ(E I_p) · E ∂I_p exactly (δ is affine). Per traced path
//! this does the work of one `radiance_vjp` path, against two paths (primal + adjoint) before.
//! Variance at equal spp: the first-order term gains 2 μ_δ μ_∂ Cov(I, ∂I)/spp (either sign) over the two-pass
//! estimator, and the second-order term grows 2-4x (4x where I and ∂I are proportional, as at an emitter's
//! silhouette); each half is also stratified on its own, which costs more where edges dominate. Measured on the
//! example room (benchmarks/README.md): 1.4-1.9x the two-pass error per spp at 0.5-0.6x its time per iteration,
//! so at equal time it is ahead at 4 and 64 spp and about even at 16.
//! Memory: half a pixel's path records per thread (spp/2 x max_depth vertices), reused across pixels; nothing
//! grows with the image.

use crate::error::{Error, Result};
use crate::grad::estimate::image_loss::PixelwiseAdjoint;
use crate::grad::interior::material_light::{backward_sweep, normal_map_sweep, GradLayout};
use crate::grad::path::record::{record_path, PathRecord};
use crate::grad::GRAD_BLOCKS;
use crate::render::cpu::frame_params;
use crate::render::SceneData;
use crate::scene::RenderSettings;
use glam::Vec3;
use rayon::prelude::*;

/// dLoss/dθ for the marked parameters and the rendered radiance image (w·h·3, all spp samples), for a loss whose
/// adjoint is `adjoint`. Half A of each pixel's samples uses `settings.seed`, half B `seed_b` (which must differ,
/// so that the halves are independent). Needs spp >= 2.
pub fn radiance_vjp_cross(
    d: &SceneData,
    settings: &RenderSettings,
    layout: &GradLayout,
    adjoint: &PixelwiseAdjoint,
    seed_b: u32,
) -> Result<(Vec<f64>, Vec<f32>)> {
    let (w, h) = (d.camera.width as usize, d.camera.height as usize);
    if adjoint.target.len() != w * h * 3 {
        return Err(Error::Invalid(format!(
            "loss target has {} values, the {w}x{h} render has {}",
            adjoint.target.len(),
            w * h * 3
        )));
    }
    if settings.spp < 2 || seed_b == settings.seed {
        return Err(Error::Invalid("the fused estimator needs spp >= 2 and two different seeds".into()));
    }
    let fp_a = frame_params(d, settings);
    let fp_b = crate::render::layout::FrameParams { seed: seed_b, ..fp_a };
    let (n_a, n_b) = (fp_a.spp / 2, fp_a.spp - fp_a.spp / 2);
    // Fixed row blocks (never dependent on the thread count), each with its own gradient, summed in order.
    let rows_per_block = h.div_ceil(h.clamp(1, GRAD_BLOCKS));
    let mut image = vec![0.0f32; w * h * 3];
    let partial: Vec<Vec<f64>> = image
        .par_chunks_mut(rows_per_block * w * 3)
        .enumerate()
        .map(|(b, rows)| {
            let mut grad = vec![0.0f64; layout.extended_len];
            let mut half_a = vec![PathRecord::default(); n_a as usize];
            let mut rec = PathRecord::default();
            let sweep = |rec: &PathRecord, delta: Vec3, grad: &mut [f64]| {
                if delta != Vec3::ZERO {
                    backward_sweep(d, layout, &rec.vertices, delta, grad);
                    if layout.shading_normal_wanted {
                        normal_map_sweep(d, layout, rec, delta, grad);
                    }
                }
            };
            for (i, px) in rows.chunks_exact_mut(3).enumerate() {
                let p = b * rows_per_block * w + i;
                let (x, y) = ((p % w) as u32, (p / w) as u32);
                let mut i_a = Vec3::ZERO;
                for (k, r) in half_a.iter_mut().enumerate() {
                    record_path(d, &fp_a, x, y, k as u32, r);
                    i_a += r.radiance();
                }
                i_a /= n_a as f32;
                // Half B's paths carry δ(I_A) as they are traced; half A's, kept, carry δ(I_B) afterwards.
                let delta_b = adjoint.at(p, i_a) * (0.5 / n_b as f32);
                let mut i_b = Vec3::ZERO;
                for k in 0..n_b {
                    record_path(d, &fp_b, x, y, k, &mut rec);
                    i_b += rec.radiance();
                    sweep(&rec, delta_b, &mut grad);
                }
                i_b /= n_b as f32;
                let delta_a = adjoint.at(p, i_b) * (0.5 / n_a as f32);
                for r in &half_a {
                    sweep(r, delta_a, &mut grad);
                }
                let value = (i_a * n_a as f32 + i_b * n_b as f32) / fp_a.spp as f32;
                px.copy_from_slice(&value.to_array());
            }
            grad
        })
        .collect();
    let mut grad = vec![0.0f64; layout.extended_len];
    for part in partial {
        grad.iter_mut().zip(part).for_each(|(g, v)| *g += v);
    }
    Ok((layout.finish(grad)?, image))
}
