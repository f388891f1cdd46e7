//! The Vulkan backend: shaders/path_trace.comp (the GLSL twin of render::path_trace) on any Vulkan device,
//! lavapipe included. The scene is uploaded once per render; samples run in passes that each add to per-pixel
//! running sums in sample order, so the result does not depend on the pass size and matches the CPU to float
//! rounding. The device is chosen by psdr-vk (a discrete GPU first; `PSDR_VK_DEVICE` picks one by name).

use super::{check_settings, Backend, Progress};
use crate::error::{Error, Result};
use crate::render::cpu::frame_params;
use crate::render::layout::{CameraGpu, FrameParams};
use crate::render::{Frame, SceneData};
use crate::scene::RenderSettings;
use psdr_vk::{Buffer, Context, ContextOptions, Groups, Kernel, StorageBinding};

/// Path samples per pass: keeps each submission well under a second on lavapipe and far below GPU watchdogs.
const PASS_PATH_SAMPLES: u64 = 1 << 20;

pub struct VkBackend {
    ctx: Context,
    path_trace: Kernel<FrameParams>,
    pass_path_samples: u64,
}

fn backend_error(e: psdr_vk::VkError) -> Error {
    Error::Backend(e.to_string())
}

impl VkBackend {
    /// Opens the device named by `device` (a case-insensitive substring), or `PSDR_VK_DEVICE`, or the best one.
    pub fn new(device: Option<&str>) -> Result<VkBackend> {
        let options = ContextOptions { device: device.map(str::to_string), ..Default::default() };
        let ctx = Context::with_options(&options).map_err(backend_error)?;
        let words = psdr_vk::include_spirv!("path_trace").map_err(backend_error)?;
        let path_trace = Kernel::new(&ctx, "path_trace", &words, 16).map_err(backend_error)?;
        Ok(VkBackend { ctx, path_trace, pass_path_samples: PASS_PATH_SAMPLES })
    }

    /// Path samples per submitted pass (at least one sample of every pixel per pass).
    pub fn set_pass_path_samples(&mut self, n: u64) {
        self.pass_path_samples = n;
    }

    pub fn context(&self) -> &Context {
        &self.ctx
    }
}

/// A device buffer holding `data`, or one zeroed element when `data` is empty (Vulkan has no empty buffers).
fn upload<T: bytemuck::Pod>(ctx: &Context, name: &str, data: &[T]) -> Result<Buffer<T>> {
    if data.is_empty() {
        Buffer::zeroed(ctx, name, 1).map_err(backend_error)
    } else {
        Buffer::from_slice(ctx, name, data).map_err(backend_error)
    }
}

impl Backend for VkBackend {
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
        let scene: [&dyn StorageBinding; 9] = [
            &upload(ctx, "nodes", &d.nodes)?,
            &upload(ctx, "triangles", &d.triangles)?,
            &upload(ctx, "shading", &d.shading)?,
            &upload(ctx, "materials", &d.materials)?,
            &upload(ctx, "textures", &d.textures)?,
            &upload(ctx, "texels", &d.texels)?,
            &upload(ctx, "emitters", &d.emitters)?,
            &upload(ctx, "lights", &d.lights)?,
            &upload::<CameraGpu>(ctx, "camera", &[d.camera])?,
        ];
        let zeros = |name: &str, len: usize| Buffer::<f32>::zeroed(ctx, name, len.max(1)).map_err(backend_error);
        let radiance = zeros("radiance_sums", n * 3)?;
        let depth = zeros("depth_sums", n)?;
        let normal = zeros("normal_sums", n * 3)?;
        let albedo = zeros("albedo_sums", n * 3)?;
        let coverage = zeros("coverage", n * nobj)?;
        let ids = Buffer::<u32>::zeroed(ctx, "object_ids", n).map_err(backend_error)?;
        let rays = Buffer::<u32>::zeroed(ctx, "rays", n).map_err(backend_error)?;
        let outputs: [&dyn StorageBinding; 7] = [&radiance, &depth, &normal, &albedo, &coverage, &ids, &rays];
        let bindings: Vec<&dyn StorageBinding> = scene.iter().chain(outputs.iter()).copied().collect();

        let mut fp = frame_params(d, settings);
        let per_pass = (self.pass_path_samples / n.max(1) as u64).clamp(1, settings.spp as u64) as u32;
        let mut begin = 0;
        while begin < settings.spp {
            fp.sample_begin = begin;
            fp.sample_count = per_pass.min(settings.spp - begin);
            self.path_trace
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

/// SPIR-V of the layout round-trip kernel (shaders/layout_check.comp), for the layout test.
pub fn layout_check_spirv() -> Result<Vec<u32>> {
    psdr_vk::include_spirv!("layout_check").map_err(backend_error)
}
