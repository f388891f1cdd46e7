//! The crate's error type: every failure is a typed value with a message that says what to do.

use ash::vk;

/// How to get a Vulkan implementation on a machine without a GPU (Debian/Ubuntu).
pub const INSTALL_HINT: &str =
    "install a Vulkan driver, e.g. `apt-get install mesa-vulkan-drivers libvulkan1` (lavapipe runs on the CPU)";

/// Everything that can go wrong in `psdr-vk`.
#[derive(Debug, thiserror::Error)]
pub enum VkError {
    /// `libvulkan.so.1` (the Vulkan loader) could not be opened.
    #[error("Vulkan loader (libvulkan.so.1) not found: {reason}; {INSTALL_HINT}")]
    LoaderMissing { reason: String },

    /// The loader works but reports no usable physical device (or no driver at all).
    #[error("no usable Vulkan device{detail}; {INSTALL_HINT}")]
    NoDevice { detail: String },

    /// A device was requested by name (`PSDR_VK_DEVICE` or the API) and none matched.
    #[error("no Vulkan device name contains {wanted:?}; available devices: [{}]", available.join(", "))]
    DeviceNotFound { wanted: String, available: Vec<String> },

    /// Validation was explicitly required (`PSDR_VK_VALIDATION=1`) but the layer is not installed.
    #[error("validation requested but VK_LAYER_KHRONOS_validation is not installed; `apt-get install vulkan-validationlayers`, or set PSDR_VK_VALIDATION=0")]
    ValidationLayerMissing,

    /// A Vulkan call returned an error code.
    #[error("{call} failed: {result}")]
    Vulkan { call: &'static str, result: vk::Result },

    /// gpu-allocator could not provide memory.
    #[error("memory allocation for {name:?} failed: {source}")]
    Allocation {
        name: String,
        #[source]
        source: gpu_allocator::AllocationError,
    },

    /// A buffer larger than one storage-buffer binding may address.
    #[error("buffer {name:?} needs {bytes} bytes but this device's maxStorageBufferRange is {max} bytes; split the data over several buffers")]
    BufferTooLarge { name: String, bytes: u64, max: u64 },

    /// Host data and buffer disagree in length.
    #[error("buffer {name:?}: {what}: expected {expected} elements, got {got}")]
    LengthMismatch { name: String, what: &'static str, expected: usize, got: usize },

    /// The SPIR-V given to a kernel is not SPIR-V.
    #[error("kernel {name:?}: invalid SPIR-V: {reason}")]
    InvalidSpirv { name: String, reason: String },

    /// A GLSL kernel compiled at run time (`compile_glsl_file`) failed; `message` has the compiler's
    /// `file:line: error: ...` lines.
    #[error("shader {file}: {message}")]
    ShaderCompile { file: String, message: String },

    /// Dispatch arguments that do not fit the kernel or the device.
    #[error("kernel {name:?}: {reason}")]
    BadDispatch { name: String, reason: String },

    /// A buffer or kernel from one `Context` was used with another.
    #[error("{what} {name:?} belongs to a different Context")]
    ForeignObject { what: &'static str, name: String },
}

/// Result with [`VkError`].
pub type Result<T, E = VkError> = std::result::Result<T, E>;

/// Maps a raw `vk::Result` to [`VkError::Vulkan`] naming the call.
pub(crate) trait VkResultExt<T> {
    fn call(self, call: &'static str) -> Result<T>;
}

impl<T> VkResultExt<T> for std::result::Result<T, vk::Result> {
    fn call(self, call: &'static str) -> Result<T> {
        self.map_err(|result| VkError::Vulkan { call, result })
    }
}
