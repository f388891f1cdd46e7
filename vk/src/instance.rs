//! The Vulkan loader and instance, with the validation layer and its messenger when asked for.

use std::ffi::CStr;
use std::sync::{Arc, Mutex};

use ash::{ext, vk};

use crate::error::{Result, VkError, VkResultExt};
use crate::validation::{messenger_info, MessageLog, ValidationMessage, ValidationMode, VALIDATION_LAYER};

/// Lowest Vulkan version we use: kernels are compiled with `--target-env vulkan1.2` (SPIR-V 1.5).
pub(crate) const API_VERSION: u32 = vk::API_VERSION_1_2;

/// A loaded Vulkan library plus one instance. Dropped last by `Context` (after the device).
pub(crate) struct Instance {
    pub(crate) raw: ash::Instance,
    messenger: Option<(ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    pub(crate) log: MessageLog,
    /// Keeps libvulkan loaded while the instance lives (dropped after `Drop` destroyed the instance).
    _entry: ash::Entry,
}

impl Instance {
    pub(crate) fn new(mode: ValidationMode) -> Result<Self> {
        // SAFETY: loading libvulkan runs its initialisers; the Vulkan loader is designed to be loaded this way.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| VkError::LoaderMissing { reason: e.to_string() })?;

        // SAFETY: plain global query on a loaded entry.
        let loader_version = unsafe { entry.try_enumerate_instance_version() }
            .call("vkEnumerateInstanceVersion")?
            .unwrap_or(vk::API_VERSION_1_0);
        if loader_version < API_VERSION {
            return Err(VkError::NoDevice {
                detail: format!(
                    " (the Vulkan loader supports only {}.{}, psdr needs 1.2)",
                    vk::api_version_major(loader_version),
                    vk::api_version_minor(loader_version)
                ),
            });
        }

        let validation = match mode {
            ValidationMode::Off => false,
            ValidationMode::IfAvailable | ValidationMode::Required => {
                let present = layer_present(&entry, VALIDATION_LAYER)?;
                if !present && mode == ValidationMode::Required {
                    return Err(VkError::ValidationLayerMissing);
                }
                present
            }
        };
        // debug-utils comes from the loader or from the validation layer itself.
        let debug_utils = validation
            && (extension_present(&entry, None, ext::debug_utils::NAME)?
                || extension_present(&entry, Some(VALIDATION_LAYER), ext::debug_utils::NAME)?);

        // Synchronization validation catches missing barriers between passes; cheap for compute-only work.
        let validation_features =
            validation && extension_present(&entry, Some(VALIDATION_LAYER), ext::validation_features::NAME)?;

        let layers: Vec<*const std::ffi::c_char> = if validation { vec![VALIDATION_LAYER.as_ptr()] } else { vec![] };
        let mut extensions: Vec<*const std::ffi::c_char> = Vec::new();
        if debug_utils {
            extensions.push(ext::debug_utils::NAME.as_ptr());
        }
        if validation_features {
            extensions.push(ext::validation_features::NAME.as_ptr());
        }

        let log: MessageLog = Arc::new(Mutex::new(Vec::new()));
        let app =
            vk::ApplicationInfo::default().application_name(c"psdr").engine_name(c"psdr-vk").api_version(API_VERSION);
        // Chaining the messenger info also reports problems inside vkCreateInstance/vkDestroyInstance.
        let mut chained_messenger = messenger_info(&log);
        let mut create = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if debug_utils {
            create = create.push_next(&mut chained_messenger);
        }
        let enabled_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_features);
        if validation_features {
            create = create.push_next(&mut features);
        }
        // SAFETY: every pointer in `create` borrows locals that outlive the call; `log` outlives the instance.
        let raw = unsafe { entry.create_instance(&create, None) }.map_err(|result| match result {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => {
                VkError::NoDevice { detail: " (no Vulkan driver (ICD) is installed)".into() }
            }
            result => VkError::Vulkan { call: "vkCreateInstance", result },
        })?;

        let messenger = if debug_utils {
            let loader = ext::debug_utils::Instance::new(&entry, &raw);
            // SAFETY: valid instance with debug-utils enabled; `log` is kept alive by `self`.
            match unsafe { loader.create_debug_utils_messenger(&messenger_info(&log), None) } {
                Ok(m) => Some((loader, m)),
                Err(result) => {
                    // SAFETY: nothing else was created from this instance yet.
                    unsafe { raw.destroy_instance(None) };
                    return Err(VkError::Vulkan { call: "vkCreateDebugUtilsMessengerEXT", result });
                }
            }
        } else {
            None
        };

        Ok(Self { raw, messenger, log, _entry: entry })
    }

    /// True when the validation layer's messages are being collected.
    pub(crate) fn validating(&self) -> bool {
        self.messenger.is_some()
    }

    /// Sends a message through debug-utils as a layer would (used to prove the collection works).
    pub(crate) fn submit_message(&self, severity: vk::DebugUtilsMessageSeverityFlagsEXT, text: &CStr) {
        if let Some((loader, _)) = &self.messenger {
            let data =
                vk::DebugUtilsMessengerCallbackDataEXT::default().message_id_name(c"psdr-vk-self-test").message(text);
            // SAFETY: valid instance and messenger; `data` borrows locals that outlive the call.
            unsafe {
                loader.submit_debug_utils_message(severity, vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION, &data)
            };
        }
    }

    pub(crate) fn messages(&self) -> Vec<ValidationMessage> {
        self.log.lock().map(|l| l.clone()).unwrap_or_default()
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // SAFETY: the Context destroys the device (and everything made from it) before dropping the Instance.
        unsafe {
            if let Some((loader, messenger)) = self.messenger.take() {
                loader.destroy_debug_utils_messenger(messenger, None);
            }
            self.raw.destroy_instance(None);
        }
    }
}

fn layer_present(entry: &ash::Entry, name: &CStr) -> Result<bool> {
    // SAFETY: plain global query on a loaded entry.
    let layers = unsafe { entry.enumerate_instance_layer_properties() }.call("vkEnumerateInstanceLayerProperties")?;
    Ok(layers.iter().any(|l| l.layer_name_as_c_str() == Ok(name)))
}

fn extension_present(entry: &ash::Entry, layer: Option<&CStr>, name: &CStr) -> Result<bool> {
    // SAFETY: plain global query on a loaded entry; `layer` is NUL-terminated.
    let exts = unsafe { entry.enumerate_instance_extension_properties(layer) }
        .call("vkEnumerateInstanceExtensionProperties")?;
    Ok(exts.iter().any(|e| e.extension_name_as_c_str() == Ok(name)))
}
