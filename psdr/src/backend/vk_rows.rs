//! Deterministic reduction shared by the Vulkan adjoint kernels that write one row of gradients per invocation
//! (a pixel or an edge sample): invocations run in passes, and every pass's rows are added on the host in
//! invocation order (f64), so the sum depends neither on scheduling nor on the pass size.

use super::vk_backend::backend_error;
use crate::error::Result;
use bytemuck::Pod;
use psdr_vk::{Buffer, Context, Groups, Kernel, StorageBinding};

/// Largest gradient-rows buffer of one pass, bytes (well inside maxStorageBufferRange, 128 MiB on lavapipe).
pub const MAX_ROWS_BYTES: u64 = 64 << 20;

/// Runs `kernel` over invocations 0..n in passes of at most `per_pass` (fewer when the rows would not fit
/// MAX_ROWS_BYTES), binding `inputs`, the rows buffer, then `tail`, with push constants `push(begin, count)`;
/// adds every row (out.len() floats) into `out` in order.
#[allow(clippy::too_many_arguments)]
pub fn rows_in_order<P: Pod>(
    ctx: &Context,
    kernel: &Kernel<P>,
    inputs: &[&dyn StorageBinding],
    tail: &[&dyn StorageBinding],
    push: impl Fn(u32, u32) -> P,
    n: usize,
    per_pass: usize,
    out: &mut [f64],
) -> Result<()> {
    let len = out.len();
    if len == 0 || n == 0 {
        return Ok(());
    }
    let per_pass = per_pass.min((MAX_ROWS_BYTES / (len as u64 * 4)).max(1) as usize).min(n).max(1);
    let rows = Buffer::<f32>::zeroed(ctx, "grad_rows", per_pass * len).map_err(backend_error)?;
    let mut begin = 0;
    while begin < n {
        let count = per_pass.min(n - begin);
        let bindings: Vec<&dyn StorageBinding> =
            inputs.iter().copied().chain([&rows as &dyn StorageBinding]).chain(tail.iter().copied()).collect();
        kernel
            .dispatch(&bindings, &push(begin as u32, count as u32), Groups::folded_2d(count as u64, 64))
            .map_err(backend_error)?;
        let values = rows.download_range(0, count * len).map_err(backend_error)?;
        for row in values.chunks_exact(len) {
            out.iter_mut().zip(row).for_each(|(g, &v)| *g += v as f64);
        }
        begin += count;
    }
    Ok(())
}
