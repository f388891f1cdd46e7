//! Primary rays of the pinhole camera. GLSL twin: shaders/render/camera.glsl.

use super::layout::CameraGpu;
use glam::Vec3;

/// Unit direction through image position (x, y) in pixels (continuous; y down, (0,0) the top-left corner).
#[inline(always)]
pub fn camera_ray(c: &CameraGpu, x: f32, y: f32) -> Vec3 {
    let ndc_x = 2.0 * x / c.width as f32 - 1.0;
    let ndc_y = 1.0 - 2.0 * y / c.height as f32;
    let d = Vec3::from(c.forward)
        + Vec3::from(c.right) * (ndc_x * c.tan_half_fov * c.aspect)
        + Vec3::from(c.up) * (ndc_y * c.tan_half_fov);
    d.normalize()
}
