//! A rendered frame: radiance and the AOVs, all averaged over the pixel's samples except the id AOV.

use crate::error::{Error, Result};
use glam::Vec3;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub object_count: u32,
    /// Linear RGB, interleaved, row-major from the top.
    pub radiance: Vec<f32>,
    /// Camera-space z of the primary hit, 0 where the pixel sees nothing; anti-aliased (pixel mean).
    pub depth: Vec<f32>,
    /// World-space shading normal facing the camera, pixel mean (not renormalized).
    pub normal: Vec<f32>,
    /// Diffuse albedo of the primary hit, pixel mean.
    pub albedo: Vec<f32>,
    /// Object seen through the pixel centre, u32::MAX for none.
    pub object_id: Vec<u32>,
    /// Fraction of each pixel covered by each object: `coverage[pixel * object_count + object]`.
    pub coverage: Vec<f32>,
    /// Rays traced (closest-hit and shadow), for Mrays/s.
    pub rays: u64,
}

impl Frame {
    pub fn pixel_count(&self) -> usize {
        (self.width * self.height) as usize
    }

    pub fn radiance_at(&self, x: u32, y: u32) -> Vec3 {
        let i = (y * self.width + x) as usize * 3;
        Vec3::new(self.radiance[i], self.radiance[i + 1], self.radiance[i + 2])
    }

    /// The anti-aliased coverage mask of one object as an image.
    pub fn mask(&self, object: usize) -> Vec<f32> {
        let n = self.object_count as usize;
        (0..self.pixel_count()).map(|p| self.coverage[p * n + object]).collect()
    }

    /// True when every value is finite (the renderer's contract: never a NaN image).
    pub fn is_finite(&self) -> bool {
        [&self.radiance, &self.depth, &self.normal, &self.albedo, &self.coverage]
            .iter()
            .all(|v| v.iter().all(|x| x.is_finite()))
    }
}

/// Bytes a frame of this size takes: radiance, normal and albedo (3 floats), depth and id (1 each) and one
/// coverage float per object, per pixel.
pub fn frame_bytes(width: u32, height: u32, objects: usize) -> u128 {
    width as u128 * height as u128 * (11 + objects as u128) * 4
}

/// Refuses a frame that cannot fit in memory before anything is allocated (a 100000 x 100000 camera would
/// otherwise abort the process on a failed allocation). The budget is the memory the system reports
/// available, with room for the renderer's per-thread buffers and a loss's copies of the image.
pub fn check_frame_memory(width: u32, height: u32, objects: usize) -> Result<()> {
    let need = frame_bytes(width, height, objects) * 3;
    let available = available_memory().unwrap_or(16 << 30) as u128;
    if need > available {
        return Err(Error::Invalid(format!(
            "a {width}x{height} frame with {objects} objects needs about {:.1} GiB (frame, loss and gradient \
             buffers); {:.1} GiB is available: lower the camera's resolution",
            need as f64 / (1u64 << 30) as f64,
            available as f64 / (1u64 << 30) as f64
        )));
    }
    Ok(())
}

/// MemAvailable from /proc/meminfo (Linux), in bytes.
fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
