//! Physical device discovery and choice, and creation of the logical device with the features kernels use.

use ash::{ext, vk};

use crate::capabilities::Capabilities;
use crate::error::{Result, VkError, VkResultExt};
use crate::instance::{Instance, API_VERSION};
use crate::validation::ValidationMode;

/// Environment variable naming (a substring of) the device to use.
pub const DEVICE_ENV: &str = "PSDR_VK_DEVICE";

/// Kind of physical device, in order of preference.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum DeviceKind {
    Discrete,
    Integrated,
    Virtual,
    /// A software rasteriser such as lavapipe (llvmpipe).
    Cpu,
    Other,
}

impl From<vk::PhysicalDeviceType> for DeviceKind {
    fn from(t: vk::PhysicalDeviceType) -> Self {
        match t {
            vk::PhysicalDeviceType::DISCRETE_GPU => Self::Discrete,
            vk::PhysicalDeviceType::INTEGRATED_GPU => Self::Integrated,
            vk::PhysicalDeviceType::VIRTUAL_GPU => Self::Virtual,
            vk::PhysicalDeviceType::CPU => Self::Cpu,
            _ => Self::Other,
        }
    }
}

/// What a physical device is, as listed for choosing one.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    pub name: String,
    pub kind: DeviceKind,
    /// (major, minor, patch) of the Vulkan version the device supports.
    pub api_version: (u32, u32, u32),
    /// Why psdr cannot use it (`None` when it can).
    pub unusable_because: Option<String>,
}

/// A physical device with the queue family we would use on it.
pub(crate) struct Candidate {
    pub(crate) physical: vk::PhysicalDevice,
    pub(crate) info: DeviceInfo,
    pub(crate) queue_family: u32,
    pub(crate) timestamp_valid_bits: u32,
}

/// Lists the Vulkan devices on this machine without creating any (a temporary instance, no validation).
pub fn list_devices() -> Result<Vec<DeviceInfo>> {
    let instance = Instance::new(ValidationMode::Off)?;
    Ok(enumerate(&instance)?.into_iter().map(|c| c.info).collect())
}

pub(crate) fn enumerate(instance: &Instance) -> Result<Vec<Candidate>> {
    // SAFETY: valid instance.
    let physicals = unsafe { instance.raw.enumerate_physical_devices() }.call("vkEnumeratePhysicalDevices")?;
    let mut out = Vec::with_capacity(physicals.len());
    for physical in physicals {
        // SAFETY: `physical` was just enumerated from this instance.
        let (props, families) = unsafe {
            (
                instance.raw.get_physical_device_properties(physical),
                instance.raw.get_physical_device_queue_family_properties(physical),
            )
        };
        let name = props
            .device_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|_| "<unnamed>".into());
        let v = props.api_version;
        // A compute family, preferably one that can write timestamps.
        let family = families
            .iter()
            .enumerate()
            .filter(|(_, f)| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
            .max_by_key(|(i, f)| (f.timestamp_valid_bits > 0, std::cmp::Reverse(*i)))
            .map(|(i, f)| (i as u32, f.timestamp_valid_bits));
        let unusable_because = if v < API_VERSION {
            Some(format!(
                "supports Vulkan {}.{} only, psdr needs 1.2",
                vk::api_version_major(v),
                vk::api_version_minor(v)
            ))
        } else if family.is_none() {
            Some("has no compute queue".into())
        } else {
            None
        };
        let (queue_family, timestamp_valid_bits) = family.unwrap_or((0, 0));
        out.push(Candidate {
            physical,
            info: DeviceInfo {
                name,
                kind: props.device_type.into(),
                api_version: (vk::api_version_major(v), vk::api_version_minor(v), vk::api_version_patch(v)),
                unusable_because,
            },
            queue_family,
            timestamp_valid_bits,
        });
    }
    Ok(out)
}

/// Picks a device: by case-insensitive name substring when `wanted` is given, otherwise the most
/// capable kind (discrete, integrated, virtual, CPU), first enumerated among equals.
pub(crate) fn select(candidates: Vec<Candidate>, wanted: Option<&str>) -> Result<Candidate> {
    if candidates.is_empty() {
        return Err(VkError::NoDevice { detail: " (the loader found no physical device)".into() });
    }
    let describe = |c: &Candidate| match &c.info.unusable_because {
        None => format!("{} ({:?})", c.info.name, c.info.kind),
        Some(why) => format!("{} ({:?}, unusable: {why})", c.info.name, c.info.kind),
    };
    let available: Vec<String> = candidates.iter().map(describe).collect();
    let mut matching: Vec<Candidate> = match wanted {
        Some(w) => {
            let w_lower = w.to_lowercase();
            let m: Vec<Candidate> =
                candidates.into_iter().filter(|c| c.info.name.to_lowercase().contains(&w_lower)).collect();
            if m.is_empty() {
                return Err(VkError::DeviceNotFound { wanted: w.to_string(), available });
            }
            m
        }
        None => candidates,
    };
    matching.retain(|c| c.info.unusable_because.is_none());
    // Stable sort keeps enumeration order among devices of the same kind.
    matching.sort_by_key(|c| c.info.kind);
    matching
        .into_iter()
        .next()
        .ok_or_else(|| VkError::NoDevice { detail: format!(" (found: {})", available.join(", ")) })
}

/// Creates the logical device with one compute queue and the optional features `caps` says are present.
pub(crate) fn create_logical_device(
    instance: &Instance,
    candidate: &Candidate,
    caps: &Capabilities,
) -> Result<ash::Device> {
    let priorities = [1.0f32];
    let queues =
        [vk::DeviceQueueCreateInfo::default().queue_family_index(candidate.queue_family).queue_priorities(&priorities)];

    let mut extensions = Vec::new();
    let mut atomic_float = vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT::default()
        .shader_buffer_float32_atomics(caps.float32_atomic_buffer)
        .shader_buffer_float32_atomic_add(caps.float32_atomic_add_buffer)
        .shader_shared_float32_atomics(caps.float32_atomic_shared)
        .shader_shared_float32_atomic_add(caps.float32_atomic_add_shared);
    let mut v12 = vk::PhysicalDeviceVulkan12Features::default().scalar_block_layout(caps.scalar_block_layout);
    let features =
        vk::PhysicalDeviceFeatures::default().shader_int64(caps.shader_int64).shader_float64(caps.shader_float64);
    let mut features2 = vk::PhysicalDeviceFeatures2::default().features(features).push_next(&mut v12);
    if caps.atomic_float_extension {
        extensions.push(ext::shader_atomic_float::NAME.as_ptr());
        features2 = features2.push_next(&mut atomic_float);
    }
    let create = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queues)
        .enabled_extension_names(&extensions)
        .push_next(&mut features2);
    // SAFETY: valid physical device; every pointer in `create` borrows locals that outlive the call.
    unsafe { instance.raw.create_device(candidate.physical, &create, None) }.call("vkCreateDevice")
}
