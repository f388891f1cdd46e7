//! The Vulkan backend's adjoint pass for light radiances and material albedo constants
//! (shaders/grad/interior/material_light.comp, the GLSL twin of `grad::radiance_vjp`): each pixel's samples
//! are recorded and swept on the device into the pixel's own row of gradients, and the rows are summed here in
//! pixel order (f64), so the result does not depend on scheduling or on the pass size. Passes cover as many
//! pixels as keep both the paths per submission and the rows' buffer within bounds.

use super::vk_backend::{backend_error, upload, upload_scene, VkBackend};
use crate::error::{Error, Result};
use crate::grad::GradLayout;
use crate::render::cpu::frame_params;
use crate::render::layout::FrameParams;
use crate::render::SceneData;
use crate::scene::RenderSettings;
use bytemuck::{Pod, Zeroable};
use psdr_vk::{Buffer, Groups, StorageBinding};

/// Push constants of the adjoint kernel (its `Push` block).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct AdjointParams {
    pub fp: FrameParams,
    pub grad_len: u32,
    pub pixel_begin: u32,
    pub pixel_count: u32,
    pub material_count: u32,
}

/// Longest path the kernel records (MAX_RECORD_DEPTH in shaders/grad/path/record.glsl).
pub const MAX_RECORD_DEPTH: u32 = 16;

/// Largest gradient-rows buffer of one pass, bytes (well inside maxStorageBufferRange, 128 MiB on lavapipe).
const MAX_ROWS_BYTES: u64 = 64 << 20;

impl VkBackend {
    /// `grad::radiance_vjp` on the device, when its layout asks only for what the kernel computes (light
    /// radiances and albedo constants, `GradLayout::device_slots`); `Ok(None)` otherwise.
    pub fn radiance_vjp_on_device(
        &mut self,
        d: &SceneData,
        settings: &RenderSettings,
        layout: &GradLayout,
        adjoint: &[f32],
    ) -> Result<Option<Vec<f64>>> {
        let Some((albedo, emitters)) = layout.device_slots() else { return Ok(None) };
        let (w, h) = (d.camera.width as usize, d.camera.height as usize);
        if adjoint.len() != w * h * 3 {
            return Err(Error::Invalid(format!("adjoint image has {} values, expected {}", adjoint.len(), w * h * 3)));
        }
        if let Some(i) = adjoint.iter().position(|v| !v.is_finite()) {
            return Err(Error::Invalid(format!("adjoint image value {i} is not finite")));
        }
        if settings.max_depth > MAX_RECORD_DEPTH {
            return Err(Error::Invalid(format!(
                "the Vulkan adjoint records paths of at most {MAX_RECORD_DEPTH} vertices; max_depth is {}",
                settings.max_depth
            )));
        }
        let len = layout.len;
        if len == 0 {
            return Ok(Some(vec![]));
        }
        let ctx = &self.ctx;
        let scene = upload_scene(ctx, d)?;
        let adjoint_buf = upload(ctx, "adjoint", adjoint)?;
        let slots: Vec<u32> = albedo.iter().chain(&emitters).copied().collect();
        let slots_buf = upload(ctx, "slots", &slots)?;
        let fp = frame_params(d, settings);
        let pixels = w * h;
        let by_paths = (self.pass_path_samples / u64::from(fp.spp.max(1))).max(1);
        let by_rows = (MAX_ROWS_BYTES / (len as u64 * 4)).max(1);
        let per_pass = by_paths.min(by_rows).min(pixels as u64) as usize;
        let rows = Buffer::<f32>::zeroed(ctx, "grad_rows", per_pass * len).map_err(backend_error)?;
        let mut grad = vec![0.0f64; len];
        let mut begin = 0;
        while begin < pixels {
            let count = per_pass.min(pixels - begin);
            let push = AdjointParams {
                fp,
                grad_len: len as u32,
                pixel_begin: begin as u32,
                pixel_count: count as u32,
                material_count: albedo.len() as u32,
            };
            let bindings: Vec<&dyn StorageBinding> = scene
                .iter()
                .map(|b| b.as_ref())
                .chain([&adjoint_buf as &dyn StorageBinding, &slots_buf, &rows])
                .collect();
            self.material_light_vjp
                .dispatch(&bindings, &push, Groups::folded_2d(count as u64, 64))
                .map_err(backend_error)?;
            let values = rows.download_range(0, count * len).map_err(backend_error)?;
            for row in values.chunks_exact(len) {
                grad.iter_mut().zip(row).for_each(|(g, &v)| *g += v as f64);
            }
            begin += count;
        }
        Ok(Some(grad))
    }
}
