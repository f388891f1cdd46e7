//! GPU timestamps around each command of a submission, converted to milliseconds.

use ash::vk;

use crate::capabilities::Capabilities;
use crate::error::{Result, VkResultExt};

/// Time of one command of a submission.
#[derive(Clone, Debug)]
pub struct CommandTiming {
    /// Kernel name, or `fill <buffer>` / `copy <src> -> <dst>`.
    pub label: String,
    /// Device time in ms; `None` when the queue cannot write timestamps.
    pub gpu_ms: Option<f64>,
}

/// Times of one submission.
#[derive(Clone, Debug, Default)]
pub struct Timings {
    pub commands: Vec<CommandTiming>,
    /// Device time from the first command's start to the last command's end; `None` without timestamps.
    pub gpu_ms: Option<f64>,
    /// Host time for recording, submitting and waiting.
    pub wall_ms: f64,
}

/// A query pool with two timestamps per command; absent when the device has no timestamps.
pub(crate) struct TimestampPool<'d> {
    device: &'d ash::Device,
    pool: vk::QueryPool,
    count: u32,
    valid_mask: u64,
    period_ns: f64,
}

impl<'d> TimestampPool<'d> {
    /// `None` when the queue cannot write timestamps (`timestampValidBits == 0`).
    pub(crate) fn new(device: &'d ash::Device, caps: &Capabilities, commands: usize) -> Result<Option<Self>> {
        if !caps.timestamps || commands == 0 {
            return Ok(None);
        }
        let count = 2 * commands as u32;
        let info = vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(count);
        // SAFETY: valid device and create info.
        let pool = unsafe { device.create_query_pool(&info, None) }.call("vkCreateQueryPool")?;
        let bits = caps.timestamp_valid_bits;
        Ok(Some(Self {
            device,
            pool,
            count,
            valid_mask: if bits >= 64 { u64::MAX } else { (1u64 << bits) - 1 },
            period_ns: f64::from(caps.timestamp_period_ns),
        }))
    }

    /// Records the reset; must precede the first write in the same command buffer.
    pub(crate) fn record_reset(&self, cmd: vk::CommandBuffer) {
        // SAFETY: recording state, outside a render pass, queries in range.
        unsafe { self.device.cmd_reset_query_pool(cmd, self.pool, 0, self.count) };
    }

    /// Timestamp taken when all earlier commands have finished (bottom of pipe), so that with the barriers
    /// between commands, `[2i, 2i+1]` brackets command `i`.
    pub(crate) fn record_write(&self, cmd: vk::CommandBuffer, query: u32) {
        // SAFETY: recording state; `query < count` and was reset in this command buffer.
        unsafe { self.device.cmd_write_timestamp(cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, self.pool, query) };
    }

    /// After the submission completed: per-command ms and total ms.
    pub(crate) fn read_ms(&self) -> Result<(Vec<f64>, f64)> {
        let mut ticks = vec![0u64; self.count as usize];
        // SAFETY: the submission that wrote every query has been waited for.
        unsafe {
            self.device.get_query_pool_results(
                self.pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .call("vkGetQueryPoolResults")?;
        let ms = |a: u64, b: u64| (b.wrapping_sub(a) & self.valid_mask) as f64 * self.period_ns * 1e-6;
        let per = ticks.chunks_exact(2).map(|p| ms(p[0], p[1])).collect();
        Ok((per, ms(ticks[0], ticks[ticks.len() - 1])))
    }
}

impl Drop for TimestampPool<'_> {
    fn drop(&mut self) {
        // SAFETY: the submission using the pool has completed (or never happened).
        unsafe { self.device.destroy_query_pool(self.pool, None) };
    }
}
