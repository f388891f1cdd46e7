//! Khronos validation layer: when to enable it, and the debug-utils messenger that collects its messages.

use std::ffi::{c_void, CStr};
use std::sync::{Arc, Mutex};

use ash::vk;

/// Name of the Khronos validation layer.
pub const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Whether to load the validation layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ValidationMode {
    /// Never.
    Off,
    /// When the layer is installed; silently without it.
    IfAvailable,
    /// Always; a missing layer is [`crate::VkError::ValidationLayerMissing`].
    Required,
}

impl ValidationMode {
    /// `PSDR_VK_VALIDATION=0/1` wins; otherwise on (if installed) in debug builds, off in release builds.
    pub fn from_env() -> Self {
        match std::env::var("PSDR_VK_VALIDATION").as_deref() {
            Ok("0") | Ok("false") | Ok("off") => Self::Off,
            Ok("1") | Ok("true") | Ok("on") => Self::Required,
            _ if cfg!(debug_assertions) => Self::IfAvailable,
            _ => Self::Off,
        }
    }
}

/// How bad a collected message is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Severity {
    Warning,
    Error,
}

/// One message from the validation layer (or any layer speaking debug-utils).
#[derive(Clone, Debug)]
pub struct ValidationMessage {
    pub severity: Severity,
    /// e.g. `VUID-vkCmdDispatch-None-02697`.
    pub id: String,
    pub text: String,
}

impl std::fmt::Display for ValidationMessage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "[{:?}] {}: {}", self.severity, self.id, self.text)
    }
}

/// Shared list the messenger callback appends to; the `Arc` keeps it alive while Vulkan holds its pointer.
pub(crate) type MessageLog = Arc<Mutex<Vec<ValidationMessage>>>;

/// Create info for a messenger that appends warnings and errors to `log`.
/// The caller must keep `log` alive for as long as the messenger (or instance using this chain) exists.
pub(crate) fn messenger_info(log: &MessageLog) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(collect_message))
        .user_data(Arc::as_ptr(log) as *mut c_void)
}

/// Debug-utils callback: copies the message into the `MessageLog` behind `user_data`; errors also go to stderr
/// so a failing run shows them even if nobody inspects the log.
unsafe extern "system" fn collect_message(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    if data.is_null() || user_data.is_null() {
        return vk::FALSE;
    }
    // SAFETY: the layer passes a valid callback-data pointer for the duration of the call (checked non-null).
    let data = unsafe { &*data };
    // SAFETY: the strings are NUL-terminated and valid during the call, as the spec guarantees.
    let (id, text) = unsafe { (data.message_id_name_as_c_str(), data.message_as_c_str()) };
    let to_string = |s: Option<&CStr>| s.map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let message = ValidationMessage {
        severity: if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
            Severity::Error
        } else {
            Severity::Warning
        },
        id: to_string(id),
        text: to_string(text),
    };
    if message.severity == Severity::Error {
        eprintln!("psdr-vk validation: {message}");
    }
    // SAFETY: user_data is Arc::as_ptr of a MessageLog that the Instance keeps alive until the messenger is gone.
    let log = unsafe { &*(user_data as *const Mutex<Vec<ValidationMessage>>) };
    if let Ok(mut log) = log.lock() {
        log.push(message);
    }
    vk::FALSE
}
