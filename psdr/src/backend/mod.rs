//! One interface over the CPU reference and the Vulkan backend, so every stage runs on either: the primal render
//! and the adjoint kernels a device offers. Each gradient method answers `None` for what the device's kernels do
//! not cover (the CPU backend covers none: its gradients are grad's reference terms); grad's orchestration
//! (`grad::radiance_vjp_on` and its kin) chooses the device's answer or the CPU term. This module uses only
//! grad's public term API (its layouts, adjoint types and the host-side pieces the kernels share).

mod cpu_backend;
mod vk_adjoint;
mod vk_aov;
mod vk_backend;
mod vk_primary;
mod vk_radiance_pose;
mod vk_rows;

pub use cpu_backend::CpuBackend;
pub use vk_adjoint::{AdjointParams, MAX_RECORD_DEPTH};
pub use vk_backend::{layout_check_spirv, VkBackend, SHADER_DIR_ENV};

use crate::error::{Error, Result};
use crate::grad::{AovAdjoints, GradLayout, PixelwiseAdjoint, PoseLayout};
use crate::render::{Frame, SceneData};
use crate::scene::{RenderSettings, Scene};

/// Progress callback: (units done, units total).
pub type Progress<'a> = &'a (dyn Fn(usize, usize) + Sync);

pub trait Backend {
    /// Human-readable name, including the device for GPU backends.
    fn name(&self) -> String;
    /// Renders radiance and all AOVs of `data` with `settings`.
    fn render(&mut self, data: &SceneData, settings: &RenderSettings, progress: Progress) -> Result<Frame>;
    /// The unit render of each of `emitters` (indices into `data`'s emitters, each at most once): the radiance
    /// of `data` with that emitter alone at radiance 1 and every other dark, as `render` renders it. By default
    /// one `render` per emitter; the CPU backend traces each path once for all (`render::unit_paths`, the same
    /// images). Leaves `data`'s emitter radiances changed: callers set their own again.
    fn unit_radiances(
        &mut self,
        data: &mut SceneData,
        settings: &RenderSettings,
        emitters: &[usize],
    ) -> Result<Vec<Vec<f32>>> {
        let n = data.emitter_count as usize;
        emitters
            .iter()
            .map(|&e| {
                let alone: Vec<glam::Vec3> =
                    (0..n).map(|i| if i == e { glam::Vec3::ONE } else { glam::Vec3::ZERO }).collect();
                data.set_emitter_radiances(&alone)?;
                Ok(self.render(data, settings, &|_, _| {})?.radiance)
            })
            .collect()
    }
    /// dLoss/dθ of the material and light parameters of `layout` given dLoss/d(radiance) (the interior term,
    /// twin of `grad::radiance_vjp`) on the device, or `None` where its kernels do not cover the layout (the
    /// default: `grad::radiance_vjp_on` then runs the CPU reference).
    fn radiance_vjp(
        &mut self,
        _data: &SceneData,
        _settings: &RenderSettings,
        _layout: &GradLayout,
        _adjoint: &[f32],
    ) -> Result<Option<Vec<f64>>> {
        Ok(None)
    }
    /// The fused estimator of an L2 radiance loss's gradient w.r.t. the material and light parameters of
    /// `layout` and the rendered image (twin of `grad::radiance_vjp_cross`) on the device, or `None` where its
    /// kernels do not cover the layout.
    fn radiance_vjp_cross(
        &mut self,
        _data: &SceneData,
        _settings: &RenderSettings,
        _layout: &GradLayout,
        _adjoint: &PixelwiseAdjoint,
        _seed_b: u32,
    ) -> Result<Option<(Vec<f64>, Vec<f32>)>> {
        Ok(None)
    }
    /// dLoss/dθ of the pose entries of `pose` given the adjoints of depth and masks (twin of `grad::aovs_vjp`:
    /// the depth interior and the silhouette boundary with `edge_samples` samples) on the device, or `None`.
    fn aovs_vjp(
        &mut self,
        _scene: &Scene,
        _data: &SceneData,
        _settings: &RenderSettings,
        _pose: &PoseLayout,
        _adjoints: &AovAdjoints,
        _edge_samples: u32,
    ) -> Result<Option<Vec<f64>>> {
        Ok(None)
    }
    /// The primary boundary term of radiance for the pose entries of `pose` given dLoss/d(radiance) (twin of
    /// `grad::radiance_primary_boundary`, `edge_samples` silhouette and crease samples) on the device, or `None`.
    fn radiance_primary_boundary(
        &mut self,
        _scene: &Scene,
        _data: &SceneData,
        _settings: &RenderSettings,
        _pose: &PoseLayout,
        _adjoint: &[f32],
        _edge_samples: u32,
    ) -> Result<Option<Vec<f64>>> {
        Ok(None)
    }
    /// The ray-form interior term of radiance for the pose entries of `pose`, with the secondary boundary when
    /// `secondary_samples` > 0, on the device; or `None` to have `grad::radiance_pose_vjp` compute them on the
    /// CPU (the default, and a device's answer where its kernels do not cover the entries).
    fn radiance_pose_interior(
        &mut self,
        _scene: &Scene,
        _data: &SceneData,
        _settings: &RenderSettings,
        _pose: &PoseLayout,
        _adjoint: &[f32],
        _secondary_samples: u32,
    ) -> Result<Option<Vec<f64>>> {
        Ok(None)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendKind {
    Cpu,
    /// Vulkan compute (any device; `PSDR_VK_DEVICE` picks one by name).
    Vk,
}

impl std::str::FromStr for BackendKind {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "cpu" => Ok(BackendKind::Cpu),
            "vk" | "vulkan" => Ok(BackendKind::Vk),
            _ => Err(format!("unknown backend '{s}' (cpu, vk)")),
        }
    }
}

pub fn create_backend(kind: BackendKind) -> Result<Box<dyn Backend>> {
    create_backend_on(kind, None)
}

/// Like [`create_backend`], on the GPU whose name contains `device` (case-insensitive; `None`: `PSDR_VK_DEVICE`,
/// else the best device). The CPU backend has one device and rejects a name rather than ignoring it.
pub fn create_backend_on(kind: BackendKind, device: Option<&str>) -> Result<Box<dyn Backend>> {
    match (kind, device) {
        (BackendKind::Cpu, None) => Ok(Box::new(CpuBackend)),
        (BackendKind::Cpu, Some(name)) => {
            Err(Error::Invalid(format!("device \"{name}\" was given but the cpu backend has no devices to pick")))
        }
        (BackendKind::Vk, device) => Ok(Box::new(VkBackend::new(device)?)),
    }
}

/// Checks the settings a backend is asked to render with.
pub fn check_settings(s: &RenderSettings) -> Result<()> {
    if s.spp == 0 {
        return Err(Error::Invalid("spp must be at least 1".into()));
    }
    if s.max_depth == 0 {
        return Err(Error::Invalid("max_depth must be at least 1".into()));
    }
    Ok(())
}
