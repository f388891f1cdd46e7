//! Texture lookup: bilinear filtering with wrap. GLSL twin: shaders/texture.glsl.
//! uv (0,0) is the bottom-left of the image (OBJ convention); texel row 0 is the top row.

use super::layout::TextureGpu;
use glam::{Vec2, Vec3};

#[inline(always)]
fn wrap(i: i32, n: i32) -> i32 {
    ((i % n) + n) % n
}

#[inline(always)]
fn texel(texels: &[f32], t: &TextureGpu, x: i32, y: i32, c: u32) -> f32 {
    let (w, h) = (t.width as i32, t.height as i32);
    let idx = (wrap(y, h) * w + wrap(x, w)) as u32 * t.channels + c.min(t.channels - 1);
    texels[(t.offset + idx) as usize]
}

/// Bilinear sample of channel `c` (clamped to the texture's channel count) at uv.
#[inline(always)]
pub fn texture_sample(texels: &[f32], t: &TextureGpu, uv: Vec2, c: u32) -> f32 {
    let x = uv.x * t.width as f32 - 0.5;
    let y = (1.0 - uv.y) * t.height as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (ix, iy) = (x0 as i32, y0 as i32);
    let a = texel(texels, t, ix, iy, c);
    let b = texel(texels, t, ix + 1, iy, c);
    let d = texel(texels, t, ix, iy + 1, c);
    let e = texel(texels, t, ix + 1, iy + 1, c);
    (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (d * (1.0 - fx) + e * fx) * fy
}

#[inline(always)]
pub fn texture_sample_rgb(texels: &[f32], t: &TextureGpu, uv: Vec2) -> Vec3 {
    Vec3::new(texture_sample(texels, t, uv, 0), texture_sample(texels, t, uv, 1), texture_sample(texels, t, uv, 2))
}
