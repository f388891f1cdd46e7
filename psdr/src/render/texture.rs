//! Texture lookup: bilinear filtering with wrap. GLSL twin: shaders/render/texture.glsl.
//! uv (0,0) is the bottom-left of the image (OBJ convention); texel row 0 is the top row.

use super::layout::TextureGpu;
use glam::{Vec2, Vec3};

/// i mod n in [0, n). The common in-range case skips the two integer divisions (tens of cycles each, and a
/// footprint wraps four indices): the value is the same either way.
#[inline(always)]
fn wrap(i: i32, n: i32) -> i32 {
    if (i as u32) < (n as u32) {
        i
    } else {
        ((i % n) + n) % n
    }
}

/// A floored texel coordinate as an index, held within 2^24 texels (where an f32 has no fraction left): a
/// model file's corrupt uv (3.4e9 in two Sweet Home 3D models) then names some texel of the wrap instead of
/// overflowing the index and its neighbour. Ordinary coordinates pass unchanged.
#[inline(always)]
pub fn texel_index(x0: f32) -> i32 {
    x0.clamp(-16_777_216.0, 16_777_216.0) as i32
}

/// The 2x2 texels around a uv (texel indices, row-major, before the channel) and the bilinear weights.
/// Computed once per lookup and shared by its channels (the integer wraps are the costly part).
#[derive(Clone, Copy)]
pub struct Footprint {
    pub texel: [u32; 4],
    pub fx: f32,
    pub fy: f32,
}

#[inline(always)]
pub fn texture_footprint(t: &TextureGpu, uv: Vec2) -> Footprint {
    let x = uv.x * t.width as f32 - 0.5;
    let y = (1.0 - uv.y) * t.height as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (ix, iy) = (texel_index(x0), texel_index(y0));
    let (w, h) = (t.width as i32, t.height as i32);
    let (xa, xb) = (wrap(ix, w), wrap(ix + 1, w));
    let (ya, yb) = (wrap(iy, h) * w, wrap(iy + 1, h) * w);
    Footprint { texel: [(ya + xa) as u32, (ya + xb) as u32, (yb + xa) as u32, (yb + xb) as u32], fx, fy }
}

/// Bilinear blend of channel `c` (clamped to the texture's channel count) over a footprint.
#[inline(always)]
pub fn texture_blend(texels: &[f32], t: &TextureGpu, f: &Footprint, c: u32) -> f32 {
    let c = c.min(t.channels - 1);
    let at = |i: usize| texels[(t.offset + f.texel[i] * t.channels + c) as usize];
    let (a, b, d, e) = (at(0), at(1), at(2), at(3));
    let (fx, fy) = (f.fx, f.fy);
    (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (d * (1.0 - fx) + e * fx) * fy
}

/// Bilinear sample of channel `c` (clamped to the texture's channel count) at uv.
#[inline(always)]
pub fn texture_sample(texels: &[f32], t: &TextureGpu, uv: Vec2, c: u32) -> f32 {
    texture_blend(texels, t, &texture_footprint(t, uv), c)
}

#[inline(always)]
pub fn texture_sample_rgb(texels: &[f32], t: &TextureGpu, uv: Vec2) -> Vec3 {
    let f = texture_footprint(t, uv);
    Vec3::new(texture_blend(texels, t, &f, 0), texture_blend(texels, t, &f, 1), texture_blend(texels, t, &f, 2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_corrupt_uv_samples_a_texel_of_the_texture() {
        let t = TextureGpu { offset: 0, width: 4, height: 2, channels: 1 };
        let texels: Vec<f32> = (0..8).map(|k| k as f32).collect();
        for uv in [Vec2::new(3.443871e9, 0.3), Vec2::new(-3.443871e9, 1e30), Vec2::new(0.3, -1e30)] {
            let f = texture_footprint(&t, uv);
            assert!(f.texel.iter().all(|&k| k < 8), "{uv}: {:?}", f.texel);
            assert!(texture_sample(&texels, &t, uv, 0).is_finite(), "{uv}");
        }
        // In range, the index is the plain floor.
        assert_eq!(texel_index(-3.0), -3);
        assert_eq!(texel_index(1234567.0), 1234567);
    }

    #[test]
    fn fast_wrap_equals_the_definition() {
        for n in [1, 2, 3, 7, 1024] {
            for i in -3000..3000 {
                assert_eq!(wrap(i, n), ((i % n) + n) % n, "wrap({i}, {n})");
            }
            for i in [i32::MIN, i32::MIN + 1, i32::MAX - 1, i32::MAX] {
                assert_eq!(wrap(i, n), ((i % n) + n) % n, "wrap({i}, {n})");
            }
        }
    }
}
