//! The material library's differentiable texture lookup (psdr_materials::TextureTransform) and the renderer's
//! (UvTransform rows + render::texture::texture_sample) are one function: the gradient code differentiates
//! exactly what the renderer shades with. Bound: both are bilinear; the renderer works in f32, so values agree
//! to f32 rounding of the texel coordinate (|uv'| <= ~20 texture periods of 16 texels: ~3e-5 texel, times the
//! largest texel step of 1.0 gives ~1e-4 absolute; we allow 1e-3).

use glam::Vec2;
use psdr::render::layout::TextureGpu;
use psdr::render::texture::texture_sample;
use psdr::scene::UvTransform;
use psdr_materials::{TextureTransform, TextureView};

#[test]
fn renderer_and_library_lookups_agree() {
    let (w, h) = (16u32, 12u32);
    let texels: Vec<f32> = (0..w * h * 3).map(|i| (i.wrapping_mul(2654435761) >> 8) as f32 / 16777216.0).collect();
    let gpu = TextureGpu { offset: 0, width: w, height: h, channels: 3 };
    let view = TextureView { width: w as usize, height: h as usize, channels: 3, texels: &texels };
    let mut worst = 0.0f64;
    for k in 0..500u32 {
        let r = |m: u32| (k.wrapping_mul(7919).wrapping_add(m.wrapping_mul(104729)) % 1000) as f32 / 1000.0;
        let uvt = UvTransform {
            scale: Vec2::new(0.5 + 7.5 * r(1), 0.5 + 7.5 * r(2)),
            rotation_deg: 360.0 * r(3) - 180.0,
            offset: Vec2::new(r(4) - 0.5, r(5) - 0.5),
        };
        let uv = Vec2::new(r(6) * 2.0 - 0.5, r(7) * 2.0 - 0.5);
        let rows = uvt.rows();
        let p = Vec2::new(
            rows[0][0] * uv.x + rows[0][1] * uv.y + rows[0][2],
            rows[1][0] * uv.x + rows[1][1] * uv.y + rows[1][2],
        );
        let t = TextureTransform {
            scale: [uvt.scale.x as f64, uvt.scale.y as f64],
            rotation_deg: uvt.rotation_deg as f64,
            offset: [uvt.offset.x as f64, uvt.offset.y as f64],
        };
        let mut lib = [0.0; 3];
        t.lookup(&view, [uv.x as f64, uv.y as f64], &mut lib);
        for (c, l) in lib.iter().enumerate() {
            let ren = texture_sample(&texels, &gpu, p, c as u32) as f64;
            worst = worst.max((ren - l).abs());
        }
    }
    eprintln!("max |renderer - library| = {worst:.2e}");
    assert!(worst < 1e-3, "renderer and library lookups differ by {worst}");
}
