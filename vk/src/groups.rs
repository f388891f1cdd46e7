//! Workgroup counts for a dispatch, and helpers that keep them under maxComputeWorkGroupCount
//! (65535 per dimension on most devices: 16M items / 256 per group is already one group too many).

/// Number of workgroups in x, y, z.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Groups {
    pub x: u32,
    pub y: u32,
    pub z: u32,
}

/// The smallest per-dimension maximum the Vulkan spec allows; every device supports at least this.
pub const GUARANTEED_MAX_GROUPS: u32 = 65535;

impl Groups {
    pub const fn new(x: u32, y: u32, z: u32) -> Self {
        Self { x, y, z }
    }

    /// `x` groups in one dimension.
    pub const fn linear(x: u32) -> Self {
        Self { x, y: 1, z: 1 }
    }

    /// One invocation per pixel of a `width` x `height` image with `local_size_x/y = local`;
    /// the kernel must skip `gl_GlobalInvocationID.xy` outside the image.
    pub fn covering_image(width: u32, height: u32, local: [u32; 2]) -> Self {
        Self::new(width.div_ceil(local[0].max(1)), height.div_ceil(local[1].max(1)), 1)
    }

    /// For a grid-stride loop over `n` items: enough groups of `local` invocations to give each item its own
    /// invocation, but at most `max_groups` (the kernel loops with stride `gl_NumWorkGroups.x * local`).
    pub fn grid_stride(n: u64, local: u32, max_groups: u32) -> Self {
        let wanted = n.div_ceil(u64::from(local.max(1)));
        Self::linear(wanted.clamp(1, u64::from(max_groups.max(1))) as u32)
    }

    /// One invocation per item for `n` items, folded into 2-D so that no dimension exceeds
    /// [`GUARANTEED_MAX_GROUPS`]. The kernel computes
    /// `i = gl_GlobalInvocationID.y * (gl_NumWorkGroups.x * local) + gl_GlobalInvocationID.x` and skips `i >= n`.
    pub fn folded_2d(n: u64, local: u32) -> Self {
        let groups = n.div_ceil(u64::from(local.max(1))).max(1);
        let x = groups.min(u64::from(GUARANTEED_MAX_GROUPS));
        let y = groups.div_ceil(x);
        Self::new(x as u32, y.min(u64::from(u32::MAX)) as u32, 1)
    }

    /// Total number of workgroups.
    pub fn count(&self) -> u64 {
        u64::from(self.x) * u64::from(self.y) * u64::from(self.z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folded_covers_and_stays_in_limits() {
        for n in [1u64, 255, 256, 257, 16 << 20, (16 << 20) + 1, 1 << 32] {
            let g = Groups::folded_2d(n, 256);
            assert!(g.x <= GUARANTEED_MAX_GROUPS && g.y <= GUARANTEED_MAX_GROUPS, "{n}: {g:?}");
            assert!(g.count() * 256 >= n, "{n}: {g:?}");
        }
        assert_eq!(Groups::covering_image(17, 9, [8, 8]), Groups::new(3, 2, 1));
        assert_eq!(Groups::grid_stride(1 << 30, 256, 4096), Groups::linear(4096));
        assert_eq!(Groups::grid_stride(0, 256, 4096), Groups::linear(1));
    }
}
