//! Vulkan compute plumbing for psdr: device choice, storage buffers, compute kernels, batched dispatch,
//! GPU timing and validation. It knows nothing of rendering; psdr's kernels are built on top of it.
//!
//! Runs on any Vulkan 1.2 device, including Mesa's lavapipe on the CPU (CI). Environment:
//! - `PSDR_VK_DEVICE=<substring>` picks a device by name (else: discrete > integrated > virtual > CPU).
//! - `PSDR_VK_VALIDATION=0/1` forces the Khronos validation layer off/on (default: on in debug builds
//!   when installed). With it, synchronization validation is on too; messages are collected in
//!   [`Context::validation_messages`].
//!
//! Kernels are GLSL compiled by the using crate's build.rs with
//! `glslangValidator -V --target-env vulkan1.2 -o $OUT_DIR/<name>.spv <name>.comp` (see this crate's build.rs)
//! and loaded with [`include_spirv!`], or compiled at run time from a folder of GLSL with [`compile_glsl_file`]
//! (shaderc). Binding `i` of set 0 is `buffers[i]`; push constants are one
//! `#[repr(C)]` Pod struct (at most `maxPushConstantsSize`, 128 bytes on lavapipe). Every submission is
//! waited for, so downloads right after a dispatch see its results.
//!
//! ```no_run
//! use psdr_vk::{Buffer, Context, Groups, Kernel};
//!
//! #[repr(C)]
//! #[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
//! struct Push { a: f32, n: u32 }
//!
//! # fn main() -> psdr_vk::Result<()> {
//! let ctx = Context::new()?; // or Context::with_options(&ContextOptions { device: Some("llvmpipe".into()), .. })
//! let words = psdr_vk::include_spirv!("saxpy")?; // compiled to $OUT_DIR/saxpy.spv by build.rs
//! let saxpy: Kernel<Push> = Kernel::new(&ctx, "saxpy", &words, 2)?;
//!
//! let n = 1 << 20;
//! let x = Buffer::from_slice(&ctx, "x", &vec![1.0f32; n])?;
//! let y = Buffer::from_slice(&ctx, "y", &vec![2.0f32; n])?;
//! let push = Push { a: 3.0, n: n as u32 };
//! let timings = saxpy.dispatch(&[&x, &y], &push, Groups::folded_2d(n as u64, 256))?;
//! println!("saxpy took {:?} ms on the GPU", timings.gpu_ms);
//! assert_eq!(y.download()?[0], 5.0);
//!
//! // Several passes in one submission, with barriers between them:
//! let mut pass = ctx.batch();
//! pass.fill_zero(&y)?
//!     .dispatch(&saxpy, &[&x, &y], &push, Groups::folded_2d(n as u64, 256))?
//!     .dispatch(&saxpy, &[&x, &y], &push, Groups::folded_2d(n as u64, 256))?;
//! let t = pass.submit()?;
//! # let _ = t; Ok(()) }
//! ```

mod batch;
mod buffer;
mod capabilities;
mod context;
mod device;
mod error;
mod groups;
mod instance;
mod kernel;
mod runtime_shaders;
mod spirv;
mod timing;
mod validation;

pub use ash;
pub use batch::Batch;
pub use buffer::{Buffer, BufferBinding, StorageBinding};
pub use capabilities::Capabilities;
pub use context::{Context, ContextOptions};
pub use device::{list_devices, DeviceInfo, DeviceKind, DEVICE_ENV};
pub use error::{Result, VkError, INSTALL_HINT};
pub use groups::{Groups, GUARANTEED_MAX_GROUPS};
pub use kernel::Kernel;
pub use runtime_shaders::{compile_glsl_file, decorate_no_contraction};
pub use spirv::{spirv_from_bytes, SPIRV_MAGIC};
pub use timing::{CommandTiming, Timings};
pub use validation::{Severity, ValidationMessage, ValidationMode};

// Shared across threads by the renderer (rayon CPU side next to GPU submissions).
#[allow(dead_code)]
fn assert_thread_safe() {
    fn both<T: Send + Sync>() {}
    both::<Context>();
    both::<Buffer<f32>>();
    both::<Kernel<()>>();
}
