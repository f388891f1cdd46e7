//! The Vulkan backend's adjoint pass for light radiances, material albedo, roughness and specular constants,
//! texels, procedural albedo maps and uv transforms (shaders/grad/interior/material_light.comp, the GLSL twin
//! of `grad::radiance_vjp`): each pixel's samples are recorded and swept on the device into the pixel's own row
//! of gradients, and the rows are summed here in pixel order (f64), so the result does not depend on
//! scheduling or on the pass size. Texture-space adjoints (a whole texture's gradient does not fit a row per
//! pixel) come back per path vertex and are carried into texels and transforms here by the CPU's own
//! `texture_read_adjoint`, in pixel, sample and sweep order. Passes cover as many pixels as keep the paths per
//! submission and both buffers within bounds.

use super::vk_backend::{backend_error, upload, upload_scene, VkBackend};
use crate::error::{Error, Result};
use crate::grad::{normal_read_adjoint, texture_read_adjoint, DeviceSlots, GradLayout, PixelwiseAdjoint};
use crate::render::cpu::frame_params;
use crate::render::layout::{FrameParams, NONE};
use crate::render::SceneData;
use crate::scene::RenderSettings;
use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};
use psdr_vk::{Buffer, Groups, Kernel, StorageBinding};

/// Push constants of the adjoint kernel (its `Push` block).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct AdjointParams {
    pub fp: FrameParams,
    pub grad_len: u32,
    pub pixel_begin: u32,
    pub pixel_count: u32,
    pub material_count: u32,
    pub emitter_count: u32,
    /// 1 when some material's texture reads are wanted (the kernel writes them out), else 0.
    pub texture_reads: u32,
}

/// u32 per texture read the kernel writes (TEXTURE_READ_FLOATS): material (NORMAL_READ set for a normal-map
/// read), uv, then d_albedo and d_rough, or d_c and d_uv; padding.
const TEXTURE_READ_WORDS: usize = 12;
/// Records per path (READS_PER_PATH): one per vertex from each of the two sweeps.
const READS_PER_PATH: usize = 2 * MAX_RECORD_DEPTH as usize;
/// The material word's tag of a normal-map read (NORMAL_READ).
const NORMAL_READ: u32 = 0x8000_0000;

/// Longest path the kernel records (MAX_RECORD_DEPTH in shaders/grad/path/record.glsl).
pub const MAX_RECORD_DEPTH: u32 = 16;

/// Largest gradient-rows or texture-reads buffer of one pass, bytes (well inside maxStorageBufferRange, 128 MiB
/// on lavapipe).
const MAX_ROWS_BYTES: u64 = 64 << 20;

/// Push constants of the fused kernel (shaders/grad/interior/fused_l2.comp): the adjoint kernel's, then the
/// second half's seed and the loss's scale.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct FusedParams {
    pub base: AdjointParams,
    pub seed_b: u32,
    pub scale: f32,
}

impl VkBackend {
    /// `grad::radiance_vjp` on the device, when its layout asks only for what the kernel covers
    /// (`GradLayout::device_slots`); `Ok(None)` otherwise.
    pub fn radiance_vjp_on_device(
        &mut self,
        d: &SceneData,
        settings: &RenderSettings,
        layout: &GradLayout,
        adjoint: &[f32],
    ) -> Result<Option<Vec<f64>>> {
        let Some(slots) = layout.device_slots() else { return Ok(None) };
        check_image(d, adjoint, "adjoint image")?;
        check_depth(settings)?;
        if layout.len == 0 {
            return Ok(Some(vec![]));
        }
        let adjoint_buf = upload(&self.ctx, "adjoint", adjoint)?;
        let fp = frame_params(d, settings);
        let grad = self.sweep_passes(
            self.material_light_vjp.get(&self.ctx)?,
            d,
            layout,
            &slots,
            fp,
            &adjoint_buf,
            &[],
            |base| base,
        )?;
        layout.finish(grad).map(Some)
    }

    /// `grad::radiance_vjp_cross` (the fused estimator of an L2 loss) on the device, when the layout asks only
    /// for what the kernel covers; `Ok(None)` otherwise. Returns the gradient and the rendered image.
    pub fn radiance_vjp_cross_on_device(
        &mut self,
        d: &SceneData,
        settings: &RenderSettings,
        layout: &GradLayout,
        adjoint: &PixelwiseAdjoint,
        seed_b: u32,
    ) -> Result<Option<(Vec<f64>, Vec<f32>)>> {
        let Some(slots) = layout.device_slots() else { return Ok(None) };
        check_image(d, adjoint.target, "loss target")?;
        check_depth(settings)?;
        if settings.spp < 2 || seed_b == settings.seed {
            return Err(Error::Invalid("the fused estimator needs spp >= 2 and two different seeds".into()));
        }
        let pixels = (d.camera.width * d.camera.height) as usize;
        let target = upload(&self.ctx, "target", adjoint.target)?;
        let image = Buffer::<f32>::zeroed(&self.ctx, "image", pixels * 3).map_err(backend_error)?;
        let fp = frame_params(d, settings);
        let scale = adjoint.scale;
        let push = |base| FusedParams { base, seed_b, scale };
        let grad =
            self.sweep_passes(self.fused_l2_vjp.get(&self.ctx)?, d, layout, &slots, fp, &target, &[&image], push)?;
        let image = image.download_range(0, pixels * 3).map_err(backend_error)?;
        Ok(Some((layout.finish(grad)?, image)))
    }

    /// Runs a sweep kernel (bindings: the scene, `input` at 9, the slot table, the gradient rows, the texture
    /// reads, then `tail`) over the image in passes, summing the rows in pixel order and carrying the texture
    /// reads with `texture_read_adjoint` in pixel, path and sweep order; returns the extended gradient.
    #[allow(clippy::too_many_arguments)]
    fn sweep_passes<P: Pod>(
        &self,
        kernel: &Kernel<P>,
        d: &SceneData,
        layout: &GradLayout,
        slots: &DeviceSlots,
        fp: FrameParams,
        input: &dyn StorageBinding,
        tail: &[&dyn StorageBinding],
        push: impl Fn(AdjointParams) -> P,
    ) -> Result<Vec<f64>> {
        let ctx = &self.ctx;
        let len = layout.len;
        let scene = upload_scene(ctx, d)?;
        let slots_buf = upload(ctx, "slots", &slots.table)?;
        let pixels = (d.camera.width * d.camera.height) as usize;
        let by_paths = (self.pass_path_samples / u64::from(fp.spp.max(1))).max(1);
        let by_rows = (MAX_ROWS_BYTES / (len as u64 * 4)).max(1);
        let reads_per_pixel = fp.spp as usize * READS_PER_PATH * TEXTURE_READ_WORDS;
        let by_reads =
            if slots.texture_reads { (MAX_ROWS_BYTES / (reads_per_pixel as u64 * 4)).max(1) } else { u64::MAX };
        let per_pass = by_paths.min(by_rows).min(by_reads).min(pixels as u64) as usize;
        let rows = Buffer::<f32>::zeroed(ctx, "grad_rows", per_pass * len).map_err(backend_error)?;
        let reads_len = if slots.texture_reads { per_pass * reads_per_pixel } else { 1 };
        let reads = Buffer::<u32>::zeroed(ctx, "texture_reads", reads_len).map_err(backend_error)?;
        let mut grad = vec![0.0f64; layout.extended_len];
        let mut begin = 0;
        while begin < pixels {
            let count = per_pass.min(pixels - begin);
            let base = AdjointParams {
                fp,
                grad_len: len as u32,
                pixel_begin: begin as u32,
                pixel_count: count as u32,
                material_count: slots.materials as u32,
                emitter_count: slots.emitters as u32,
                texture_reads: u32::from(slots.texture_reads),
            };
            let bindings: Vec<&dyn StorageBinding> = scene
                .iter()
                .map(|b| b.as_ref())
                .chain([input, &slots_buf as &dyn StorageBinding, &rows, &reads])
                .chain(tail.iter().copied())
                .collect();
            kernel.dispatch(&bindings, &push(base), Groups::folded_2d(count as u64, 64)).map_err(backend_error)?;
            let values = rows.download_range(0, count * len).map_err(backend_error)?;
            for row in values.chunks_exact(len) {
                grad.iter_mut().zip(row).for_each(|(g, &v)| *g += v as f64);
            }
            if slots.texture_reads {
                let words = reads.download_range(0, count * reads_per_pixel).map_err(backend_error)?;
                for path in words.chunks_exact(READS_PER_PATH * TEXTURE_READ_WORDS) {
                    for e in path.chunks_exact(TEXTURE_READ_WORDS).take_while(|e| e[0] != NONE) {
                        let f = |k: usize| f32::from_bits(e[k]);
                        let (uv, x) = (Vec2::new(f(1), f(2)), Vec3::new(f(3), f(4), f(5)));
                        let m = (e[0] & !NORMAL_READ) as usize;
                        if e[0] & NORMAL_READ != 0 {
                            normal_read_adjoint(d, layout, m, uv, x, [f(6), f(7), f(8)], &mut grad);
                        } else {
                            texture_read_adjoint(d, layout, m, uv, x, f(6), &mut grad);
                        }
                    }
                }
            }
            begin += count;
        }
        Ok(grad)
    }
}

/// An image-sized input (3 floats per pixel), finite.
pub(super) fn check_image(d: &SceneData, values: &[f32], what: &str) -> Result<()> {
    let n = (d.camera.width * d.camera.height * 3) as usize;
    if values.len() != n {
        return Err(Error::Invalid(format!("{what} has {} values, expected {n}", values.len())));
    }
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(Error::Invalid(format!("{what} value {i} is not finite")));
    }
    Ok(())
}

pub(super) fn check_depth(settings: &RenderSettings) -> Result<()> {
    if settings.max_depth > MAX_RECORD_DEPTH {
        return Err(Error::Invalid(format!(
            "the Vulkan adjoint records paths of at most {MAX_RECORD_DEPTH} vertices; max_depth is {}",
            settings.max_depth
        )));
    }
    Ok(())
}
