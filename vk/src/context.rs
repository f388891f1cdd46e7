//! `Context`: one logical device with its compute queue, memory allocator and pipeline cache.
//! Everything else (buffers, kernels, batches) is made from a `Context` and keeps it alive.

use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex, MutexGuard};

use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use gpu_allocator::{AllocationSizes, AllocatorDebugSettings};

use crate::batch::Batch;
use crate::capabilities::Capabilities;
use crate::device::{create_logical_device, enumerate, select, DEVICE_ENV};
use crate::error::{Result, VkError, VkResultExt};
use crate::instance::Instance;
use crate::validation::{Severity, ValidationMessage, ValidationMode};

/// How to open a [`Context`]. `Default` reads the environment (`PSDR_VK_DEVICE`, `PSDR_VK_VALIDATION`).
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Case-insensitive substring of the device name. `None`: `PSDR_VK_DEVICE` if set, else the best device.
    pub device: Option<String>,
    /// `None`: [`ValidationMode::from_env`].
    pub validation: Option<ValidationMode>,
    /// Move data through staging buffers even when device memory is host-mapped. Real discrete GPUs
    /// always take that path; this option lets a CPU-only CI exercise it too.
    pub force_staging: bool,
}

/// A Vulkan device ready for compute. Cheap to clone (shared handle); safe to share across threads.
/// GPU work is submitted one batch at a time and waited for, so results are readable when a call returns.
#[derive(Clone)]
pub struct Context {
    pub(crate) inner: Arc<ContextInner>,
}

/// The compute queue and the command buffer recorded for it: used under one lock (Vulkan requires
/// external synchronisation of both).
pub(crate) struct Submitter {
    pub(crate) queue: vk::Queue,
    pool: vk::CommandPool,
    pub(crate) cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

pub(crate) struct ContextInner {
    pub(crate) device: ash::Device,
    pub(crate) caps: Capabilities,
    pub(crate) force_staging: bool,
    pub(crate) pipeline_cache: vk::PipelineCache,
    submitter: Mutex<Submitter>,
    // ManuallyDrop: the allocator must be dropped after every allocation is freed and before the device dies.
    allocator: ManuallyDrop<Mutex<Allocator>>,
    // Declared last: dropped after `Drop for ContextInner` has destroyed the device.
    instance: Instance,
}

impl Context {
    /// Opens the device chosen by the environment (see [`ContextOptions`]).
    pub fn new() -> Result<Self> {
        Self::with_options(&ContextOptions::default())
    }

    pub fn with_options(options: &ContextOptions) -> Result<Self> {
        let validation = options.validation.unwrap_or_else(ValidationMode::from_env);
        let instance = Instance::new(validation)?;
        let wanted = options.device.clone().or_else(|| std::env::var(DEVICE_ENV).ok().filter(|s| !s.is_empty()));
        let candidate = select(enumerate(&instance)?, wanted.as_deref())?;
        let caps = Capabilities::probe(&instance, &candidate);
        let device = create_logical_device(&instance, &candidate, &caps)?;

        // From here on, a failure must destroy what was made; `Partial` does that on early return.
        let mut partial = Partial {
            device: &device,
            pool: vk::CommandPool::null(),
            fence: vk::Fence::null(),
            cache: vk::PipelineCache::null(),
        };
        // SAFETY: valid device; the queue family/index were used in vkCreateDevice.
        let queue = unsafe { device.get_device_queue(candidate.queue_family, 0) };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(candidate.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid device and create infos.
        unsafe {
            partial.pool = device.create_command_pool(&pool_info, None).call("vkCreateCommandPool")?;
            partial.fence = device.create_fence(&vk::FenceCreateInfo::default(), None).call("vkCreateFence")?;
            partial.cache = device
                .create_pipeline_cache(&vk::PipelineCacheCreateInfo::default(), None)
                .call("vkCreatePipelineCache")?;
        }
        let alloc_info = vk::CommandBufferAllocateInfo::default()
            .command_pool(partial.pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: valid pool.
        let cmd = unsafe { device.allocate_command_buffers(&alloc_info) }.call("vkAllocateCommandBuffers")?[0];

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.raw.clone(),
            device: device.clone(),
            physical_device: candidate.physical,
            debug_settings: AllocatorDebugSettings::default(),
            buffer_device_address: false,
            allocation_sizes: AllocationSizes::default(),
        })
        .map_err(|source| VkError::Allocation { name: "allocator".into(), source })?;

        let (pool, fence, pipeline_cache) = (partial.pool, partial.fence, partial.cache);
        std::mem::forget(partial);
        Ok(Self {
            inner: Arc::new(ContextInner {
                device,
                caps,
                force_staging: options.force_staging,
                pipeline_cache,
                submitter: Mutex::new(Submitter { queue, pool, cmd, fence }),
                allocator: ManuallyDrop::new(Mutex::new(allocator)),
                instance,
            }),
        })
    }

    /// What the device is and can do.
    pub fn capabilities(&self) -> &Capabilities {
        &self.inner.caps
    }

    /// Starts recording several commands for one submission.
    pub fn batch(&self) -> Batch<'_> {
        Batch::new(self)
    }

    /// True when the Khronos validation layer is loaded and its messages are collected.
    pub fn validation_enabled(&self) -> bool {
        self.inner.instance.validating()
    }

    /// All warnings and errors the validation layer reported so far.
    pub fn validation_messages(&self) -> Vec<ValidationMessage> {
        self.inner.instance.messages()
    }

    /// Only the errors among [`Self::validation_messages`].
    pub fn validation_errors(&self) -> Vec<ValidationMessage> {
        let mut m = self.validation_messages();
        m.retain(|m| m.severity == Severity::Error);
        m
    }

    pub fn clear_validation_messages(&self) {
        if let Ok(mut log) = self.inner.instance.log.lock() {
            log.clear();
        }
    }

    /// Sends one message through debug-utils as the validation layer would, so a test can prove that
    /// collection works (and that "zero errors" means something). No-op without validation.
    #[doc(hidden)]
    pub fn emit_test_validation_message(&self, severity: Severity) {
        let flag = match severity {
            Severity::Error => vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            Severity::Warning => vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
        };
        self.inner.instance.submit_message(flag, c"psdr-vk self-test message");
    }

    /// Waits until the device has finished all work.
    pub fn wait_idle(&self) -> Result<()> {
        let _queue = self.inner.lock_submitter();
        // SAFETY: valid device; holding the submitter lock keeps other threads off the queue.
        unsafe { self.inner.device.device_wait_idle() }.call("vkDeviceWaitIdle")
    }

    /// The raw `ash` device, for what this crate does not wrap. Objects made from it must be destroyed
    /// before the last clone of this `Context` is dropped.
    pub fn raw_device(&self) -> &ash::Device {
        &self.inner.device
    }
}

impl ContextInner {
    pub(crate) fn id(&self) -> usize {
        self as *const Self as usize
    }

    pub(crate) fn lock_submitter(&self) -> MutexGuard<'_, Submitter> {
        // A panic while recording leaves no broken state worth refusing to use: recover the guard.
        self.submitter.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub(crate) fn lock_allocator(&self) -> MutexGuard<'_, Allocator> {
        self.allocator.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Records commands with `record` into the context's command buffer, submits them and waits.
    /// `record` runs under the queue lock, so submissions never interleave.
    pub(crate) fn submit_and_wait(
        &self,
        record: impl FnOnce(&ash::Device, vk::CommandBuffer) -> Result<()>,
    ) -> Result<()> {
        let submitter = self.lock_submitter();
        let d = &self.device;
        let cmd = submitter.cmd;
        let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: the command buffer is not in use (the previous submission was waited for, we hold the lock).
        unsafe {
            d.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()).call("vkResetCommandBuffer")?;
            d.begin_command_buffer(cmd, &begin).call("vkBeginCommandBuffer")?;
        }
        let recorded = record(d, cmd).map(|()| {
            // Make this submission's device writes visible to the host and to later submissions.
            let barrier = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
                .dst_access_mask(
                    vk::AccessFlags::HOST_READ
                        | vk::AccessFlags::HOST_WRITE
                        | vk::AccessFlags::SHADER_READ
                        | vk::AccessFlags::SHADER_WRITE
                        | vk::AccessFlags::TRANSFER_READ
                        | vk::AccessFlags::TRANSFER_WRITE,
                );
            // SAFETY: recording state; barrier outside any render pass.
            unsafe {
                d.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::HOST
                        | vk::PipelineStageFlags::COMPUTE_SHADER
                        | vk::PipelineStageFlags::TRANSFER,
                    vk::DependencyFlags::empty(),
                    &[barrier],
                    &[],
                    &[],
                )
            };
        });
        // SAFETY: the buffer is in the recording state.
        let ended = unsafe { d.end_command_buffer(cmd) }.call("vkEndCommandBuffer");
        recorded?;
        ended?;
        let cmds = [cmd];
        let submit = vk::SubmitInfo::default().command_buffers(&cmds);
        // SAFETY: recorded command buffer, unsignalled fence, queue externally synchronised by the lock.
        unsafe {
            d.queue_submit(submitter.queue, &[submit], submitter.fence).call("vkQueueSubmit")?;
            let waited = d.wait_for_fences(&[submitter.fence], true, u64::MAX).call("vkWaitForFences");
            d.reset_fences(&[submitter.fence]).call("vkResetFences")?;
            waited
        }
    }
}

impl Drop for ContextInner {
    fn drop(&mut self) {
        let submitter = self.submitter.get_mut().unwrap_or_else(|p| p.into_inner());
        // SAFETY: last reference: no buffer/kernel (they hold an Arc) and no submission remain. Order: wait idle,
        // destroy device children, free the allocator's memory blocks, destroy the device; the instance
        // (a later field) is dropped after this body.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_fence(submitter.fence, None);
            self.device.destroy_command_pool(submitter.pool, None);
            self.device.destroy_pipeline_cache(self.pipeline_cache, None);
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
        }
    }
}

/// Device children made during `Context::with_options`; destroyed (with the device) if it fails halfway.
struct Partial<'a> {
    device: &'a ash::Device,
    pool: vk::CommandPool,
    fence: vk::Fence,
    cache: vk::PipelineCache,
}

impl Drop for Partial<'_> {
    fn drop(&mut self) {
        // SAFETY: only reached on an error path, before any work was submitted; null handles are ignored.
        unsafe {
            self.device.destroy_pipeline_cache(self.cache, None);
            self.device.destroy_fence(self.fence, None);
            self.device.destroy_command_pool(self.pool, None);
            self.device.destroy_device(None);
        }
    }
}
