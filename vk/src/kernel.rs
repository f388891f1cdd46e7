//! A compute kernel: SPIR-V module, descriptor set layout of N storage buffers (binding i = buffer i,
//! set 0) and push constants of one Pod type `P`, turned into a compute pipeline.

use std::marker::PhantomData;
use std::sync::Arc;

use ash::vk;
use bytemuck::Pod;

use crate::buffer::StorageBinding;
use crate::context::{Context, ContextInner};
use crate::error::{Result, VkError, VkResultExt};
use crate::groups::Groups;
use crate::spirv::check_spirv;
use crate::timing::Timings;

/// The untyped part of a [`Kernel`].
pub(crate) struct RawKernel {
    pub(crate) ctx: Arc<ContextInner>,
    pub(crate) pipeline: vk::Pipeline,
    pub(crate) layout: vk::PipelineLayout,
    pub(crate) set_layout: vk::DescriptorSetLayout,
    pub(crate) num_buffers: u32,
    pub(crate) name: String,
}

/// A compute pipeline whose push constants are a `P` (use `()` for none) and whose set 0 holds
/// `num_buffers` storage buffers. In GLSL:
///
/// ```glsl
/// layout(local_size_x = 256) in;
/// layout(push_constant) uniform Push { float a; uint n; } pc;   // matches #[repr(C)] struct P
/// layout(std430, set = 0, binding = 0) readonly buffer X { float x[]; };
/// layout(std430, set = 0, binding = 1) buffer Y { float y[]; };
/// ```
pub struct Kernel<P: Pod = ()> {
    pub(crate) raw: RawKernel,
    _push: PhantomData<fn(P)>,
}

impl<P: Pod> Kernel<P> {
    /// Builds the pipeline from SPIR-V words (entry point `main`). Uses the context's pipeline cache.
    pub fn new(ctx: &Context, name: &str, spirv: &[u32], num_buffers: u32) -> Result<Self> {
        check_spirv(name, spirv)?;
        let inner = &ctx.inner;
        let caps = &inner.caps;
        let bad = |reason: String| VkError::BadDispatch { name: name.into(), reason };
        let push_bytes = std::mem::size_of::<P>();
        if !push_bytes.is_multiple_of(4) || push_bytes > caps.max_push_constants_size as usize {
            return Err(bad(format!(
                "push constants are {push_bytes} bytes; they must be a multiple of 4 and at most \
                 maxPushConstantsSize = {}",
                caps.max_push_constants_size
            )));
        }
        if num_buffers > caps.max_per_stage_storage_buffers {
            return Err(bad(format!(
                "{num_buffers} storage buffers exceed maxPerStageDescriptorStorageBuffers = {}",
                caps.max_per_stage_storage_buffers
            )));
        }

        let d = &inner.device;
        let mut raw = RawKernel {
            ctx: inner.clone(),
            pipeline: vk::Pipeline::null(),
            layout: vk::PipelineLayout::null(),
            set_layout: vk::DescriptorSetLayout::null(),
            num_buffers,
            name: name.into(),
        };
        let bindings: Vec<_> = (0..num_buffers)
            .map(|i| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let set_info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid device and create info; `raw` destroys what was made if a later step fails.
        raw.set_layout =
            unsafe { d.create_descriptor_set_layout(&set_info, None) }.call("vkCreateDescriptorSetLayout")?;

        let ranges = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .offset(0)
            .size(push_bytes as u32)];
        let set_layouts = [raw.set_layout];
        let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        if push_bytes > 0 {
            layout_info = layout_info.push_constant_ranges(&ranges);
        }
        // SAFETY: as above.
        raw.layout = unsafe { d.create_pipeline_layout(&layout_info, None) }.call("vkCreatePipelineLayout")?;

        let module_info = vk::ShaderModuleCreateInfo::default().code(spirv);
        // SAFETY: `spirv` has a valid header (checked); the driver/validation layer checks the rest.
        let module = unsafe { d.create_shader_module(&module_info, None) }.call("vkCreateShaderModule")?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        let info = vk::ComputePipelineCreateInfo::default().stage(stage).layout(raw.layout);
        // SAFETY: valid module, layout and cache; the module may be destroyed once the pipeline exists.
        let created = unsafe {
            let r = d.create_compute_pipelines(inner.pipeline_cache, &[info], None);
            d.destroy_shader_module(module, None);
            r
        };
        raw.pipeline =
            created.map_err(|(_, result)| VkError::Vulkan { call: "vkCreateComputePipelines", result })?.remove(0);
        Ok(Self { raw, _push: PhantomData })
    }

    pub fn name(&self) -> &str {
        &self.raw.name
    }

    /// Number of storage buffers the kernel binds (set 0, bindings 0..n).
    pub fn num_buffers(&self) -> u32 {
        self.raw.num_buffers
    }

    /// Runs the kernel once as its own submission and waits for it. `buffers[i]` goes to binding `i`.
    /// For several kernels per frame, record them into one [`crate::Batch`] instead.
    pub fn dispatch(&self, buffers: &[&dyn StorageBinding], push: &P, groups: Groups) -> Result<Timings> {
        let ctx = Context { inner: self.raw.ctx.clone() };
        let mut batch = ctx.batch();
        batch.dispatch(self, buffers, push, groups)?;
        batch.submit()
    }
}

impl Drop for RawKernel {
    fn drop(&mut self) {
        // SAFETY: batches borrow kernels until their submission has completed, so nothing uses these objects;
        // null handles (from a failed constructor) are ignored by Vulkan.
        unsafe {
            let d = &self.ctx.device;
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.layout, None);
            d.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
