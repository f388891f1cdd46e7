//! Several commands (dispatches, fills, copies) recorded into one command buffer with full barriers between
//! them, submitted together and waited for: one sample pass of a renderer is one `Batch`.

use std::time::Instant;

use ash::vk;
use bytemuck::Pod;

use crate::buffer::{Buffer, BufferBinding, StorageBinding};
use crate::context::Context;
use crate::error::{Result, VkError};
use crate::groups::Groups;
use crate::kernel::{Kernel, RawKernel};
use crate::timing::{CommandTiming, TimestampPool, Timings};

enum Op<'a> {
    Dispatch { kernel: &'a RawKernel, buffers: Vec<BufferBinding<'a>>, push: Vec<u8>, groups: Groups },
    Fill { target: BufferBinding<'a>, value: u32 },
    Copy { src: BufferBinding<'a>, dst: BufferBinding<'a>, bytes: u64 },
}

/// Commands waiting to be submitted. Buffers and kernels stay borrowed until [`Batch::submit`] returns,
/// so none can be dropped or written from the host while the GPU might use them.
pub struct Batch<'a> {
    ctx: &'a Context,
    commands: Vec<(String, Op<'a>)>,
}

impl<'a> Batch<'a> {
    pub fn new(ctx: &'a Context) -> Self {
        Self { ctx, commands: Vec::new() }
    }

    /// Adds a dispatch of `kernel` with `buffers[i]` at binding `i`. Checks the buffer count, that every buffer
    /// belongs to this context, and the group counts against maxComputeWorkGroupCount.
    pub fn dispatch<P: Pod>(
        &mut self,
        kernel: &'a Kernel<P>,
        buffers: &[&'a dyn StorageBinding],
        push: &P,
        groups: Groups,
    ) -> Result<&mut Self> {
        let raw = &kernel.raw;
        let bad = |reason: String| VkError::BadDispatch { name: raw.name.clone(), reason };
        if raw.ctx.id() != self.ctx.inner.id() {
            return Err(VkError::ForeignObject { what: "kernel", name: raw.name.clone() });
        }
        if buffers.len() != raw.num_buffers as usize {
            return Err(bad(format!("takes {} storage buffers, {} given", raw.num_buffers, buffers.len())));
        }
        let max = self.ctx.inner.caps.max_compute_work_group_count;
        if groups.x > max[0] || groups.y > max[1] || groups.z > max[2] {
            return Err(bad(format!(
                "{groups:?} exceeds maxComputeWorkGroupCount {max:?}; use Groups::folded_2d or a grid-stride loop"
            )));
        }
        let buffers = buffers.iter().map(|b| self.own(b.binding())).collect::<Result<Vec<_>>>()?;
        self.commands.push((
            raw.name.clone(),
            Op::Dispatch { kernel: raw, buffers, push: bytemuck::bytes_of(push).to_vec(), groups },
        ));
        Ok(self)
    }

    /// Adds a fill of the whole buffer with zero bytes (e.g. clearing gradient accumulators before a pass).
    pub fn fill_zero<T: Pod>(&mut self, buffer: &'a Buffer<T>) -> Result<&mut Self> {
        self.fill_u32(buffer, 0)
    }

    /// Adds a fill of the whole buffer with the 32-bit pattern `value` (`f32::to_bits` for floats).
    pub fn fill_u32<T: Pod>(&mut self, buffer: &'a Buffer<T>, value: u32) -> Result<&mut Self> {
        let target = self.own(buffer.binding())?;
        self.commands.push((format!("fill {}", target.name), Op::Fill { target, value }));
        Ok(self)
    }

    /// Adds a copy of all of `src` into `dst` (same length).
    pub fn copy<T: Pod>(&mut self, src: &'a Buffer<T>, dst: &'a Buffer<T>) -> Result<&mut Self> {
        if src.len() != dst.len() {
            return Err(VkError::LengthMismatch {
                name: dst.name().into(),
                what: "copy",
                expected: dst.len(),
                got: src.len(),
            });
        }
        let (s, d) = (self.own(src.binding())?, self.own(dst.binding())?);
        self.commands
            .push((format!("copy {} -> {}", s.name, d.name), Op::Copy { src: s, dst: d, bytes: src.size_bytes() }));
        Ok(self)
    }

    /// Number of commands recorded so far.
    pub fn len(&self) -> usize {
        self.commands.len()
    }

    pub fn is_empty(&self) -> bool {
        self.commands.is_empty()
    }

    fn own(&self, b: BufferBinding<'a>) -> Result<BufferBinding<'a>> {
        if b.ctx_id != self.ctx.inner.id() {
            return Err(VkError::ForeignObject { what: "buffer", name: b.name.into() });
        }
        Ok(b)
    }

    /// Submits every command in order and waits for completion; device writes are then visible to downloads.
    pub fn submit(self) -> Result<Timings> {
        let start = Instant::now();
        let inner = &self.ctx.inner;
        let d = &inner.device;
        let sets = DescriptorSets::new(d, &self.commands)?;
        let stamps = TimestampPool::new(d, &inner.caps, self.commands.len())?;

        inner.submit_and_wait(|d, cmd| {
            if let Some(t) = &stamps {
                t.record_reset(cmd);
            }
            for (i, (_, op)) in self.commands.iter().enumerate() {
                if i > 0 {
                    record_full_barrier(d, cmd);
                }
                if let Some(t) = &stamps {
                    t.record_write(cmd, 2 * i as u32);
                }
                record_op(d, cmd, op, sets.sets.get(i).copied().flatten());
                if let Some(t) = &stamps {
                    t.record_write(cmd, 2 * i as u32 + 1);
                }
            }
            Ok(())
        })?;

        let (per, total) = match &stamps {
            Some(t) => {
                let (per, total) = t.read_ms()?;
                (per.into_iter().map(Some).collect(), Some(total))
            }
            None => (vec![None; self.commands.len()], None),
        };
        Ok(Timings {
            commands: self
                .commands
                .into_iter()
                .zip(per)
                .map(|((label, _), gpu_ms)| CommandTiming { label, gpu_ms })
                .collect(),
            gpu_ms: total,
            wall_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }
}

fn record_op(d: &ash::Device, cmd: vk::CommandBuffer, op: &Op<'_>, set: Option<vk::DescriptorSet>) {
    // SAFETY: recording state; every handle is borrowed by the batch and alive; descriptor sets were written
    // for exactly these buffers; push bytes match the layout's range (the Kernel<P> type guarantees the size).
    unsafe {
        match op {
            Op::Dispatch { kernel, push, groups, .. } => {
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, kernel.pipeline);
                if let Some(set) = set {
                    d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, kernel.layout, 0, &[set], &[]);
                }
                if !push.is_empty() {
                    d.cmd_push_constants(cmd, kernel.layout, vk::ShaderStageFlags::COMPUTE, 0, push);
                }
                d.cmd_dispatch(cmd, groups.x, groups.y, groups.z);
            }
            Op::Fill { target, value } => {
                d.cmd_fill_buffer(cmd, target.handle, 0, vk::WHOLE_SIZE, *value);
            }
            Op::Copy { src, dst, bytes } => {
                if *bytes > 0 {
                    let region = vk::BufferCopy::default().size(*bytes);
                    d.cmd_copy_buffer(cmd, src.handle, dst.handle, &[region]);
                }
            }
        }
    }
}

/// Every earlier compute/transfer write is visible to every later compute/transfer access.
/// Kernels of a path tracer read what the previous pass wrote, so finer barriers would buy little.
fn record_full_barrier(d: &ash::Device, cmd: vk::CommandBuffer) {
    let stages = vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER;
    let barrier = vk::MemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(
            vk::AccessFlags::SHADER_READ
                | vk::AccessFlags::SHADER_WRITE
                | vk::AccessFlags::TRANSFER_READ
                | vk::AccessFlags::TRANSFER_WRITE,
        );
    // SAFETY: recording state, outside any render pass.
    unsafe { d.cmd_pipeline_barrier(cmd, stages, stages, vk::DependencyFlags::empty(), &[barrier], &[], &[]) };
}

/// One descriptor set per dispatch, from a pool that lives for one submission.
struct DescriptorSets<'d> {
    device: &'d ash::Device,
    pool: vk::DescriptorPool,
    /// Per command: its set, if it is a dispatch with buffers.
    sets: Vec<Option<vk::DescriptorSet>>,
}

impl<'d> DescriptorSets<'d> {
    fn new(device: &'d ash::Device, commands: &[(String, Op<'_>)]) -> Result<Self> {
        let mut this = Self { device, pool: vk::DescriptorPool::null(), sets: vec![None; commands.len()] };
        let users: Vec<(usize, &RawKernel, &[BufferBinding<'_>])> = commands
            .iter()
            .enumerate()
            .filter_map(|(i, (_, op))| match op {
                Op::Dispatch { kernel, buffers, .. } if !buffers.is_empty() => Some((i, *kernel, buffers.as_slice())),
                _ => None,
            })
            .collect();
        if users.is_empty() {
            return Ok(this);
        }
        let total: u32 = users.iter().map(|(_, _, b)| b.len() as u32).sum();
        let sizes = [vk::DescriptorPoolSize::default().ty(vk::DescriptorType::STORAGE_BUFFER).descriptor_count(total)];
        let pool_info = vk::DescriptorPoolCreateInfo::default().max_sets(users.len() as u32).pool_sizes(&sizes);
        // SAFETY: valid device and create info.
        this.pool = unsafe { device.create_descriptor_pool(&pool_info, None) }
            .map_err(|result| VkError::Vulkan { call: "vkCreateDescriptorPool", result })?;
        let layouts: Vec<_> = users.iter().map(|(_, k, _)| k.set_layout).collect();
        let alloc = vk::DescriptorSetAllocateInfo::default().descriptor_pool(this.pool).set_layouts(&layouts);
        // SAFETY: the pool was sized for exactly these sets.
        let sets = unsafe { device.allocate_descriptor_sets(&alloc) }
            .map_err(|result| VkError::Vulkan { call: "vkAllocateDescriptorSets", result })?;
        let infos: Vec<Vec<vk::DescriptorBufferInfo>> = users
            .iter()
            .map(|(_, _, buffers)| {
                buffers
                    .iter()
                    .map(|b| vk::DescriptorBufferInfo::default().buffer(b.handle).offset(0).range(b.range))
                    .collect()
            })
            .collect();
        let writes: Vec<vk::WriteDescriptorSet> = infos
            .iter()
            .zip(&sets)
            .flat_map(|(infos, &set)| {
                infos.iter().enumerate().map(move |(binding, info)| {
                    vk::WriteDescriptorSet::default()
                        .dst_set(set)
                        .dst_binding(binding as u32)
                        .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                        .buffer_info(std::slice::from_ref(info))
                })
            })
            .collect();
        // SAFETY: sets are fresh and not in use; buffer infos point at live buffers.
        unsafe { device.update_descriptor_sets(&writes, &[]) };
        for ((i, _, _), set) in users.iter().zip(sets) {
            this.sets[*i] = Some(set);
        }
        Ok(this)
    }
}

impl Drop for DescriptorSets<'_> {
    fn drop(&mut self) {
        // SAFETY: the submission using these sets completed (or was never made); null pools are ignored.
        unsafe { self.device.destroy_descriptor_pool(self.pool, None) };
    }
}
