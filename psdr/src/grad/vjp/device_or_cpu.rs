//! Where each gradient term runs: on the backend's device when its kernels cover the term (`Backend`'s gradient
//! methods answer `Some`), else the CPU reference term here. Every caller that holds a backend goes through
//! these, so the CPU terms stay the definition and a device is an accelerator of them.

use crate::backend::Backend;
use crate::error::Result;
use crate::grad::{
    aovs_vjp, radiance_primary_boundary, radiance_vjp, radiance_vjp_cross, AovAdjoints, GradLayout, PixelwiseAdjoint,
    PoseLayout,
};
use crate::render::SceneData;
use crate::scene::{RenderSettings, Scene};

/// `radiance_vjp` (material and light parameters' interior term) on `backend`'s device, else on the CPU.
pub fn radiance_vjp_on(
    backend: &mut dyn Backend,
    data: &SceneData,
    settings: &RenderSettings,
    layout: &GradLayout,
    adjoint: &[f32],
) -> Result<Vec<f64>> {
    match backend.radiance_vjp(data, settings, layout, adjoint)? {
        Some(g) => Ok(g),
        None => radiance_vjp(data, settings, layout, adjoint),
    }
}

/// `radiance_vjp_cross` (the fused L2 estimator: gradient and rendered image) on `backend`'s device, else on
/// the CPU.
pub fn radiance_vjp_cross_on(
    backend: &mut dyn Backend,
    data: &SceneData,
    settings: &RenderSettings,
    layout: &GradLayout,
    adjoint: &PixelwiseAdjoint,
    seed_b: u32,
) -> Result<(Vec<f64>, Vec<f32>)> {
    match backend.radiance_vjp_cross(data, settings, layout, adjoint, seed_b)? {
        Some(r) => Ok(r),
        None => radiance_vjp_cross(data, settings, layout, adjoint, seed_b),
    }
}

/// `aovs_vjp` (poses from the adjoints of depth and masks) on `backend`'s device, else on the CPU.
pub fn aovs_vjp_on(
    backend: &mut dyn Backend,
    scene: &Scene,
    data: &SceneData,
    settings: &RenderSettings,
    pose: &PoseLayout,
    adjoints: &AovAdjoints,
    edge_samples: u32,
) -> Result<Vec<f64>> {
    match backend.aovs_vjp(scene, data, settings, pose, adjoints, edge_samples)? {
        Some(g) => Ok(g),
        None => aovs_vjp(scene, data, settings, pose, adjoints, edge_samples),
    }
}

/// `radiance_primary_boundary` (poses' camera silhouettes and creases) on `backend`'s device, else on the CPU.
pub fn radiance_primary_boundary_on(
    backend: &mut dyn Backend,
    scene: &Scene,
    data: &SceneData,
    settings: &RenderSettings,
    pose: &PoseLayout,
    adjoint: &[f32],
    edge_samples: u32,
) -> Result<Vec<f64>> {
    match backend.radiance_primary_boundary(scene, data, settings, pose, adjoint, edge_samples)? {
        Some(g) => Ok(g),
        None => Ok(radiance_primary_boundary(scene, data, settings, pose, adjoint, edge_samples)),
    }
}
