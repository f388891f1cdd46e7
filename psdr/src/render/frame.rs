//! A rendered frame: radiance and the AOVs, all averaged over the pixel's samples except the id AOV.

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
