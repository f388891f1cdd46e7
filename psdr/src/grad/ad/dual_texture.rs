//! Texture lookups in dual numbers: `render::texture`'s bilinear lookup and its derivative along a uv direction
//! (what a geometric replay needs where a moving surface slides a texture under a fixed ray, and what the
//! normal-map adjoint reads).

use super::dual::D;
use crate::render::layout::TextureGpu;
use crate::render::texture::texture_sample;
use crate::render::SceneData;
use glam::Vec2;

/// Channel `c` of the bilinear lookup at uv and its derivative along duv (render/texture.rs's lookup,
/// differentiated inside the texel cell; the four texels are read back through the lookup at their centres).
pub(crate) fn dual_texture(d: &SceneData, t: &TextureGpu, uv: Vec2, duv: Vec2, c: u32) -> D {
    let x = uv.x * t.width as f32 - 0.5;
    let y = (1.0 - uv.y) * t.height as f32 - 0.5;
    let (fx, fy) = (x - x.floor(), y - y.floor());
    let at = |dx: f32, dy: f32| {
        let uv = Vec2::new((x.floor() + dx + 0.5) / t.width as f32, 1.0 - (y.floor() + dy + 0.5) / t.height as f32);
        texture_sample(&d.texels, t, uv, c)
    };
    let (a, b, e, f) = (at(0.0, 0.0), at(1.0, 0.0), at(0.0, 1.0), at(1.0, 1.0));
    let d_x = (1.0 - fy) * (b - a) + fy * (f - e);
    let d_y = (1.0 - fx) * (e - a) + fx * (f - b);
    D { v: texture_sample(&d.texels, t, uv, c), d: d_x * duv.x * t.width as f32 - d_y * duv.y * t.height as f32 }
}
