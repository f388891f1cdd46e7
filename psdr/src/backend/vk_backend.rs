//! The Vulkan backend: shaders/render/path_trace.comp (the GLSL twin of render::path_trace) on any Vulkan device,
//! lavapipe included. The scene is uploaded once per render; samples run in passes that each add to per-pixel
//! running sums in sample order, so the result does not depend on the pass size and matches the CPU to float
//! rounding. The device is chosen by psdr-vk (a discrete GPU first; `PSDR_VK_DEVICE` picks one by name).

use super::{check_settings, Backend, Progress};
use crate::error::{Error, Result};
use crate::grad::{AovAdjoints, GradLayout, PixelwiseAdjoint, PoseLayout};
use crate::render::cpu::frame_params;
use crate::render::layout::{CameraGpu, FrameParams};
use crate::render::{Frame, SceneData};
use crate::scene::{RenderSettings, Scene};
use psdr_vk::{Buffer, Context, ContextOptions, Groups, Kernel, StorageBinding};
use std::path::{Path, PathBuf};

/// Path samples per pass: keeps each submission well under a second on lavapipe and far below GPU watchdogs.
const PASS_PATH_SAMPLES: u64 = 1 << 20;

pub struct VkBackend {
    pub(super) ctx: Context,
    path_trace: LazyKernel<FrameParams>,
    /// The adjoint pass of material and light parameters (shaders/grad/interior/material_light.comp).
    pub(super) material_light_vjp: LazyKernel<super::vk_adjoint::AdjointParams>,
    /// The fused estimator of an L2 loss for material and light parameters (shaders/grad/interior/fused_l2.comp).
    pub(super) fused_l2_vjp: LazyKernel<super::vk_adjoint::FusedParams>,
    /// The adjoint pass of depth and masks for poses (shaders/grad/vjp/aov.comp).
    pub(super) aov_vjp: LazyKernel<super::vk_aov::AovParams>,
    /// The primary boundary of radiance for poses (shaders/grad/vjp/radiance_pose.comp).
    pub(super) radiance_pose_vjp: LazyKernel<super::vk_radiance_pose::RadiancePoseParams>,
    /// The same with the secondary boundary (shaders/grad/vjp/radiance_pose_secondary.comp, 64 entries per path,
    /// and radiance_pose_secondary_small.comp, 16, for drivers that refuse the first); `None` on a device without
    /// shaderFloat64.
    pub(super) radiance_pose_secondary_vjp: Option<[LazyKernel<super::vk_radiance_pose::RadiancePoseParams>; 2]>,
    pub(super) pass_path_samples: u64,
    /// Only the 16-entry secondary kernel, as on a driver that refuses the 64-entry one (for tests).
    pub(super) small_secondary_only: bool,
}

/// A kernel whose pipeline is created at its first use. Creating one costs 0.2-3 s on lavapipe (its LLVM
/// compile; lavapipe's pipeline cache keeps nothing, 32 bytes of header), 9 s for all six, and most commands
/// use one or two: `psdr render` only path_trace.
pub(super) struct LazyKernel<P: bytemuck::Pod> {
    name: &'static str,
    words: Vec<u32>,
    buffers: u32,
    /// The pipeline, or why the driver refused it (kept, so a refused kernel is not compiled again per call).
    kernel: std::sync::OnceLock<std::result::Result<Kernel<P>, String>>,
}

impl<P: bytemuck::Pod> LazyKernel<P> {
    /// Kernel `rel` (`render/path_trace`) with `buffers` bindings, its SPIR-V from `shader_dir` or the build's.
    fn new(
        shader_dir: Option<&Path>,
        name: &'static str,
        rel: &str,
        built: psdr_vk::Result<Vec<u32>>,
        buffers: u32,
    ) -> Result<Self> {
        let words = kernel_words(shader_dir, rel, built)?;
        Ok(LazyKernel { name, words, buffers, kernel: std::sync::OnceLock::new() })
    }

    /// The kernel, created on `ctx` the first time it is asked for.
    pub(super) fn get(&self, ctx: &Context) -> Result<&Kernel<P>> {
        // Two threads may both create it: both are the same pipeline, either will do.
        let made = self.kernel.get_or_init(|| {
            Kernel::new(ctx, self.name, &self.words, self.buffers).map_err(|e| format!("{}: {e}", self.name))
        });
        made.as_ref().map_err(|e| Error::Backend(e.clone()))
    }
}

/// The folder of GLSL kernels to compile at run time instead of the build's (`shaders/` layout).
pub const SHADER_DIR_ENV: &str = "PSDR_SHADER_DIR";

/// SPIR-V of kernel `rel` (`render/path_trace`): from `shader_dir`/`rel`.comp compiled now when a folder is given,
/// else the build's.
fn kernel_words(shader_dir: Option<&Path>, rel: &str, built: psdr_vk::Result<Vec<u32>>) -> Result<Vec<u32>> {
    match shader_dir {
        Some(dir) => psdr_vk::compile_glsl_file(dir, &format!("{rel}.comp")).map_err(backend_error),
        None => built.map_err(backend_error),
    }
}

pub(super) fn backend_error(e: psdr_vk::VkError) -> Error {
    Error::Backend(e.to_string())
}

impl VkBackend {
    /// Opens the device named by `device` (a case-insensitive substring), or `PSDR_VK_DEVICE`, or the best one,
    /// with the kernels compiled at build time, or at run time from `PSDR_SHADER_DIR` when it is set.
    pub fn new(device: Option<&str>) -> Result<VkBackend> {
        let shader_dir = std::env::var_os(SHADER_DIR_ENV).filter(|v| !v.is_empty()).map(PathBuf::from);
        VkBackend::with_shader_dir(device, shader_dir.as_deref())
    }

    /// Like `new`, with the kernels compiled at run time from `shader_dir` (a copy of the repository's
    /// shaders/ folder, edited) when it is given: a researcher changes a kernel and reruns without rebuilding.
    pub fn with_shader_dir(device: Option<&str>, shader_dir: Option<&Path>) -> Result<VkBackend> {
        let options = ContextOptions { device: device.map(str::to_string), ..Default::default() };
        let ctx = Context::with_options(&options).map_err(backend_error)?;
        // SPIR-V is read (or compiled from `shader_dir`) now, so a broken kernel fails at start; pipelines later.
        let dir = shader_dir;
        let path_trace =
            LazyKernel::new(dir, "path_trace", "render/path_trace", psdr_vk::include_spirv!("render/path_trace"), 16)?;
        let material_light_vjp = LazyKernel::new(
            dir,
            "material_light_vjp",
            "grad/interior/material_light",
            psdr_vk::include_spirv!("grad/interior/material_light"),
            13,
        )?;
        let fused_l2_vjp = LazyKernel::new(
            dir,
            "fused_l2_vjp",
            "grad/interior/fused_l2",
            psdr_vk::include_spirv!("grad/interior/fused_l2"),
            14,
        )?;
        let aov_vjp = LazyKernel::new(dir, "aov_vjp", "grad/vjp/aov", psdr_vk::include_spirv!("grad/vjp/aov"), 17)?;
        let radiance_pose_vjp = LazyKernel::new(
            dir,
            "radiance_pose_vjp",
            "grad/vjp/radiance_pose",
            psdr_vk::include_spirv!("grad/vjp/radiance_pose"),
            15,
        )?;
        let radiance_pose_secondary_vjp = if ctx.capabilities().shader_float64 {
            Some([
                LazyKernel::new(
                    dir,
                    "radiance_pose_secondary_vjp",
                    "grad/vjp/radiance_pose_secondary",
                    psdr_vk::include_spirv!("grad/vjp/radiance_pose_secondary"),
                    18,
                )?,
                LazyKernel::new(
                    dir,
                    "radiance_pose_secondary_small_vjp",
                    "grad/vjp/radiance_pose_secondary_small",
                    psdr_vk::include_spirv!("grad/vjp/radiance_pose_secondary_small"),
                    18,
                )?,
            ])
        } else {
            None
        };
        Ok(VkBackend {
            ctx,
            path_trace,
            material_light_vjp,
            fused_l2_vjp,
            aov_vjp,
            radiance_pose_vjp,
            radiance_pose_secondary_vjp,
            pass_path_samples: PASS_PATH_SAMPLES,
            small_secondary_only: false,
        })
    }

    /// Path samples per submitted pass (at least one sample of every pixel per pass).
    pub fn set_pass_path_samples(&mut self, n: u64) {
        self.pass_path_samples = n;
    }

    /// Uses only the secondary boundary's 16-entry kernel, which a driver that refuses the 64-entry one runs
    /// (NVIDIA's), so that any device can compare it with the CPU.
    pub fn set_small_secondary_only(&mut self, on: bool) {
        self.small_secondary_only = on;
    }

    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// Creates every kernel's pipeline now (they are made at first use otherwise): each kernel's name and
    /// whether its driver built it. A device check: a driver may refuse a kernel that lavapipe accepts.
    pub fn create_kernels(&self) -> Vec<(&'static str, Result<()>)> {
        let ctx = &self.ctx;
        let mut out = vec![
            (self.path_trace.name, self.path_trace.get(ctx).map(drop)),
            (self.material_light_vjp.name, self.material_light_vjp.get(ctx).map(drop)),
            (self.fused_l2_vjp.name, self.fused_l2_vjp.get(ctx).map(drop)),
            (self.aov_vjp.name, self.aov_vjp.get(ctx).map(drop)),
            (self.radiance_pose_vjp.name, self.radiance_pose_vjp.get(ctx).map(drop)),
        ];
        // The small secondary kernel only matters where the large one is refused.
        if let Some([large, small]) = &self.radiance_pose_secondary_vjp {
            out.push((large.name, large.get(ctx).map(drop)));
            if out.last().is_some_and(|(_, r)| r.is_err()) {
                out.push((small.name, small.get(ctx).map(drop)));
            }
        }
        out
    }
}

/// A device buffer holding `data`, or one zeroed element when `data` is empty (Vulkan has no empty buffers).
pub(super) fn upload<T: bytemuck::Pod>(ctx: &Context, name: &str, data: &[T]) -> Result<Buffer<T>> {
    if data.is_empty() {
        Buffer::zeroed(ctx, name, 1).map_err(backend_error)
    } else {
        Buffer::from_slice(ctx, name, data).map_err(backend_error)
    }
}

impl Backend for VkBackend {
    /// Where the adjoint kernel covers the layout (`GradLayout::device_slots`: everything but normal maps).
    fn radiance_vjp(
        &mut self,
        data: &SceneData,
        settings: &RenderSettings,
        layout: &GradLayout,
        adjoint: &[f32],
    ) -> Result<Option<Vec<f64>>> {
        self.radiance_vjp_on_device(data, settings, layout, adjoint)
    }

    /// Where the sweep kernel covers the layout.
    fn radiance_vjp_cross(
        &mut self,
        data: &SceneData,
        settings: &RenderSettings,
        layout: &GradLayout,
        adjoint: &PixelwiseAdjoint,
        seed_b: u32,
    ) -> Result<Option<(Vec<f64>, Vec<f32>)>> {
        self.radiance_vjp_cross_on_device(data, settings, layout, adjoint, seed_b)
    }

    fn aovs_vjp(
        &mut self,
        scene: &Scene,
        data: &SceneData,
        settings: &RenderSettings,
        pose: &PoseLayout,
        adjoints: &AovAdjoints,
        edge_samples: u32,
    ) -> Result<Option<Vec<f64>>> {
        self.aovs_vjp_on_device(scene, data, settings, pose, adjoints, edge_samples)
    }

    fn radiance_primary_boundary(
        &mut self,
        scene: &Scene,
        data: &SceneData,
        settings: &RenderSettings,
        pose: &PoseLayout,
        adjoint: &[f32],
        edge_samples: u32,
    ) -> Result<Option<Vec<f64>>> {
        self.radiance_primary_on_device(scene, data, settings, pose, adjoint, edge_samples)
    }

    /// With the secondary term where its kernel covers the entries.
    fn radiance_pose_interior(
        &mut self,
        scene: &Scene,
        data: &SceneData,
        settings: &RenderSettings,
        pose: &PoseLayout,
        adjoint: &[f32],
        secondary_samples: u32,
    ) -> Result<Option<Vec<f64>>> {
        self.radiance_pose_interior_on_device(scene, data, settings, pose, adjoint, secondary_samples)
    }

    fn name(&self) -> String {
        let c = self.ctx.capabilities();
        format!("vk ({}, {})", c.device_name, c.driver_info)
    }

    fn render(&mut self, d: &SceneData, settings: &RenderSettings, progress: Progress) -> Result<Frame> {
        check_settings(settings)?;
        let ctx = &self.ctx;
        let (w, h) = (d.camera.width as usize, d.camera.height as usize);
        let n = w * h;
        let nobj = d.object_count as usize;
        let scene = upload_scene(ctx, d)?;
        let zeros = |name: &str, len: usize| Buffer::<f32>::zeroed(ctx, name, len.max(1)).map_err(backend_error);
        let radiance = zeros("radiance_sums", n * 3)?;
        let depth = zeros("depth_sums", n)?;
        let normal = zeros("normal_sums", n * 3)?;
        let albedo = zeros("albedo_sums", n * 3)?;
        let coverage = zeros("coverage", n * nobj)?;
        let ids = Buffer::<u32>::zeroed(ctx, "object_ids", n).map_err(backend_error)?;
        let rays = Buffer::<u32>::zeroed(ctx, "rays", n).map_err(backend_error)?;
        let outputs: [&dyn StorageBinding; 7] = [&radiance, &depth, &normal, &albedo, &coverage, &ids, &rays];
        let bindings: Vec<&dyn StorageBinding> =
            scene.iter().map(|b| b.as_ref()).chain(outputs.iter().copied()).collect();

        let mut fp = frame_params(d, settings);
        let per_pass = (self.pass_path_samples / n.max(1) as u64).clamp(1, settings.spp as u64) as u32;
        let path_trace = self.path_trace.get(&self.ctx)?;
        let mut begin = 0;
        while begin < settings.spp {
            fp.sample_begin = begin;
            fp.sample_count = per_pass.min(settings.spp - begin);
            path_trace
                .dispatch(&bindings, &fp, Groups::covering_image(d.camera.width, d.camera.height, [8, 8]))
                .map_err(backend_error)?;
            begin += fp.sample_count;
            progress(begin as usize, settings.spp as usize);
        }

        // The same divisions as render_cpu, so both backends round alike.
        let inv = settings.spp as f32;
        let mean = |b: &Buffer<f32>, len: usize| -> Result<Vec<f32>> {
            let mut v = b.download().map_err(backend_error)?;
            v.truncate(len);
            v.iter_mut().for_each(|x| *x /= inv);
            Ok(v)
        };
        let rays_total: u64 = rays.download().map_err(backend_error)?.iter().map(|&r| r as u64 + 1).sum();
        Ok(Frame {
            width: w as u32,
            height: h as u32,
            object_count: nobj as u32,
            radiance: mean(&radiance, n * 3)?,
            depth: mean(&depth, n)?,
            normal: mean(&normal, n * 3)?,
            albedo: mean(&albedo, n * 3)?,
            object_id: ids.download().map_err(backend_error)?,
            coverage: mean(&coverage, n * nobj)?,
            rays: rays_total,
        })
    }
}

/// The scene's buffers, bindings 0-8 of every rendering kernel (shaders/render/scene_buffers.glsl).
pub(super) fn upload_scene(ctx: &Context, d: &SceneData) -> Result<Vec<Box<dyn StorageBinding>>> {
    Ok(vec![
        Box::new(upload(ctx, "nodes", &d.nodes)?),
        Box::new(upload(ctx, "triangles", &d.triangles)?),
        Box::new(upload(ctx, "shading", &d.shading)?),
        Box::new(upload(ctx, "materials", &d.materials)?),
        Box::new(upload(ctx, "textures", &d.textures)?),
        Box::new(upload(ctx, "texels", &d.texels)?),
        Box::new(upload(ctx, "emitters", &d.emitters)?),
        Box::new(upload(ctx, "lights", &d.lights)?),
        Box::new(upload::<CameraGpu>(ctx, "camera", &[d.camera])?),
    ])
}

/// SPIR-V of the layout round-trip kernel (shaders/render/layout_check.comp), for the layout test.
pub fn layout_check_spirv() -> Result<Vec<u32>> {
    psdr_vk::include_spirv!("render/layout_check").map_err(backend_error)
}
