//! What the chosen device can do, probed once; the optional features listed here are enabled when present.

use ash::{ext, vk};

use crate::device::{Candidate, DeviceKind};
use crate::instance::Instance;

/// Device facts and optional features. Every `bool` feature here is also *enabled* on the device when true.
#[derive(Clone, Debug)]
pub struct Capabilities {
    pub device_name: String,
    pub device_kind: DeviceKind,
    /// (major, minor, patch)
    pub api_version: (u32, u32, u32),
    /// e.g. `llvmpipe`, `NVIDIA`.
    pub driver_name: String,
    /// e.g. `Mesa 22.3.6 (LLVM 15.0.6)`.
    pub driver_info: String,

    /// `VK_EXT_shader_atomic_float` is present (and enabled).
    pub atomic_float_extension: bool,
    /// `atomicAdd(float)` on storage buffers (gradient accumulation).
    pub float32_atomic_add_buffer: bool,
    /// `atomicExchange`/load/store of floats on storage buffers.
    pub float32_atomic_buffer: bool,
    /// `atomicAdd(float)` on shared memory.
    pub float32_atomic_add_shared: bool,
    pub float32_atomic_shared: bool,
    /// `GL_EXT_scalar_block_layout` may be used.
    pub scalar_block_layout: bool,
    /// `uint64_t` in shaders (enabled when present).
    pub shader_int64: bool,
    /// Reported only; not enabled (kernels must not need it).
    pub shader_float64: bool,

    /// Subgroup width (8 on 256-bit llvmpipe, 32 on NVIDIA).
    pub subgroup_size: u32,
    /// Largest buffer that one storage-buffer binding can address; buffers are limited to this.
    pub max_storage_buffer_range: u64,
    pub max_compute_work_group_count: [u32; 3],
    pub max_compute_work_group_size: [u32; 3],
    pub max_compute_work_group_invocations: u32,
    pub max_compute_shared_memory_size: u32,
    pub max_push_constants_size: u32,
    pub max_bound_descriptor_sets: u32,
    pub max_per_stage_storage_buffers: u32,

    /// Timestamps can be written on the compute queue (`timestampValidBits > 0`).
    pub timestamps: bool,
    pub timestamp_valid_bits: u32,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period_ns: f32,

    /// Every device-local memory type is also host-visible (lavapipe, integrated GPUs): no staging needed.
    pub unified_memory: bool,
}

impl Capabilities {
    pub(crate) fn probe(instance: &Instance, candidate: &Candidate) -> Self {
        let raw = &instance.raw;
        let pd = candidate.physical;
        // SAFETY: `pd` was enumerated from this instance (a 1.2 instance, so the *2 queries exist).
        let extensions = unsafe { raw.enumerate_device_extension_properties(pd) }.unwrap_or_default();
        let atomic_float_extension =
            extensions.iter().any(|e| e.extension_name_as_c_str() == Ok(ext::shader_atomic_float::NAME));

        let mut atomic = vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT::default();
        let mut v12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut v12);
        if atomic_float_extension {
            features2 = features2.push_next(&mut atomic);
        }
        // SAFETY: valid physical device; the chain borrows locals that outlive the call.
        unsafe { raw.get_physical_device_features2(pd, &mut features2) };
        let core = features2.features;

        let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
        let mut driver = vk::PhysicalDeviceDriverProperties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut subgroup).push_next(&mut driver);
        // SAFETY: as above.
        unsafe { raw.get_physical_device_properties2(pd, &mut props2) };
        let props = props2.properties;
        let limits = props.limits;
        // SAFETY: valid physical device.
        let memory = unsafe { raw.get_physical_device_memory_properties(pd) };
        let unified_memory = memory.memory_types_as_slice().iter().all(|t| {
            !t.property_flags.contains(vk::MemoryPropertyFlags::DEVICE_LOCAL)
                || t.property_flags
                    .contains(vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT)
        });

        let on = |b: vk::Bool32| b == vk::TRUE;
        let cstr = |r: Result<&std::ffi::CStr, _>| {
            r.map(|s: &std::ffi::CStr| s.to_string_lossy().into_owned()).unwrap_or_default()
        };
        Capabilities {
            device_name: candidate.info.name.clone(),
            device_kind: candidate.info.kind,
            api_version: candidate.info.api_version,
            driver_name: cstr(driver.driver_name_as_c_str()),
            driver_info: cstr(driver.driver_info_as_c_str()),
            atomic_float_extension,
            float32_atomic_add_buffer: atomic_float_extension && on(atomic.shader_buffer_float32_atomic_add),
            float32_atomic_buffer: atomic_float_extension && on(atomic.shader_buffer_float32_atomics),
            float32_atomic_add_shared: atomic_float_extension && on(atomic.shader_shared_float32_atomic_add),
            float32_atomic_shared: atomic_float_extension && on(atomic.shader_shared_float32_atomics),
            scalar_block_layout: on(v12.scalar_block_layout),
            shader_int64: on(core.shader_int64),
            shader_float64: on(core.shader_float64),
            subgroup_size: subgroup.subgroup_size,
            max_storage_buffer_range: u64::from(limits.max_storage_buffer_range),
            max_compute_work_group_count: limits.max_compute_work_group_count,
            max_compute_work_group_size: limits.max_compute_work_group_size,
            max_compute_work_group_invocations: limits.max_compute_work_group_invocations,
            max_compute_shared_memory_size: limits.max_compute_shared_memory_size,
            max_push_constants_size: limits.max_push_constants_size,
            max_bound_descriptor_sets: limits.max_bound_descriptor_sets,
            max_per_stage_storage_buffers: limits.max_per_stage_descriptor_storage_buffers,
            timestamps: candidate.timestamp_valid_bits > 0 && limits.timestamp_period > 0.0,
            timestamp_valid_bits: candidate.timestamp_valid_bits,
            timestamp_period_ns: limits.timestamp_period,
            unified_memory,
        }
    }
}
