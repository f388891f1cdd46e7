//! The texture transform applied at lookup time (scale, rotation, offset of uv; bilinear with wrap), with its
//! reverse-mode derivative with respect to the transform and to the texels.
//!
//! The convention is the renderer's (psdr `UvTransform` and `render/texture.rs`): `uv' = R(θ)·diag(s)·uv + o`,
//! uv (0, 0) is the bottom-left of the image, texel row 0 is the top row, texel centres sit at half-integers.
//! A tiling material keeps its look at any scale because every lookup wraps.

/// Scales a library material is designed for (the paper's search range).
pub const SCALE_RANGE: (f64, f64) = (0.5, 8.0);

/// uv' = R(rotation) · diag(scale) · uv + offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureTransform {
    pub scale: [f64; 2],
    pub rotation_deg: f64,
    pub offset: [f64; 2],
}

impl Default for TextureTransform {
    fn default() -> Self {
        TextureTransform { scale: [1.0, 1.0], rotation_deg: 0.0, offset: [0.0, 0.0] }
    }
}

/// dL/d(transform), same fields as [`TextureTransform`] (rotation per degree).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TransformGrad {
    pub scale: [f64; 2],
    pub rotation_deg: f64,
    pub offset: [f64; 2],
}

/// A texture as the renderer holds it: `width x height` texels of `channels` floats, row 0 = top.
#[derive(Clone, Copy, Debug)]
pub struct TextureView<'a> {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub texels: &'a [f32],
}

/// The four texels and weights of one bilinear lookup, and where the lookup sits between them.
struct Footprint {
    /// Texel indices (times channels) of (x0,y0), (x1,y0), (x0,y1), (x1,y1).
    idx: [usize; 4],
    fx: f64,
    fy: f64,
}

impl Footprint {
    fn weights(&self) -> [f64; 4] {
        let (fx, fy) = (self.fx, self.fy);
        [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy]
    }
}

impl TextureView<'_> {
    fn footprint(&self, uv: [f64; 2]) -> Footprint {
        let x = uv[0] * self.width as f64 - 0.5;
        let y = (1.0 - uv[1]) * self.height as f64 - 0.5;
        let (x0, y0) = (floor(x), floor(y));
        let (xi, yi) = (x0 as i64, y0 as i64);
        let ([xa, xb], [ya, yb]) = (wrapped_pair(xi, self.width), wrapped_pair(yi, self.height));
        let at = |x: usize, y: usize| (y * self.width + x) * self.channels;
        Footprint { idx: [at(xa, ya), at(xb, ya), at(xa, yb), at(xb, yb)], fx: x - x0, fy: y - y0 }
    }
}

/// `v.floor()`, inline: in a build for baseline x86-64 (no SSE4.1) the f64 floor is a libm call, a thirtieth
/// of the texture registration's time. Exact wherever an i64 holds the value.
#[inline(always)]
fn floor(v: f64) -> f64 {
    if v.abs() < 4.0e18 {
        let i = v as i64 as f64;
        if i > v {
            i - 1.0
        } else {
            i
        }
    } else {
        v.floor()
    }
}

/// Texel `i` and its right (or lower) neighbour wrapped into 0..n: a mask where n is a power of two (the
/// library's textures and every mip level of them), else one integer remainder. A 64-bit remainder per
/// coordinate was a seventh of the texture registration's time (and f64 `rem_euclid`, a software fmod, a tenth
/// of the texture search's before that).
#[inline(always)]
fn wrapped_pair(i: i64, n: usize) -> [usize; 2] {
    if n.is_power_of_two() {
        let mask = n as i64 - 1;
        [(i & mask) as usize, ((i + 1) & mask) as usize]
    } else {
        let a = i.rem_euclid(n as i64) as usize;
        [a, if a + 1 == n { 0 } else { a + 1 }]
    }
}

/// A [`TextureTransform`] with its rotation's sine and cosine computed once, for loops of lookups through one
/// transform (per lookup they were a fifteenth of the texture search's time).
#[derive(Clone, Copy, Debug)]
pub struct PreparedTransform {
    scale: [f64; 2],
    sin: f64,
    cos: f64,
    offset: [f64; 2],
}

impl PreparedTransform {
    pub fn scale(&self) -> [f64; 2] {
        self.scale
    }

    /// The transformed uv.
    pub fn apply(&self, uv: [f64; 2]) -> [f64; 2] {
        let r = self.rotate_scale(uv);
        [r[0] + self.offset[0], r[1] + self.offset[1]]
    }

    /// The transformed uv before its offset: `apply` is this plus the offset, to the bit (loops over offsets
    /// for fixed uvs compute it once).
    pub fn rotate_scale(&self, uv: [f64; 2]) -> [f64; 2] {
        let (s, c) = (self.sin, self.cos);
        let (a, b) = (self.scale[0] * uv[0], self.scale[1] * uv[1]);
        [c * a - s * b, s * a + c * b]
    }

    /// Bilinear lookup of every channel at the transformed `uv` into `out` (len = channels).
    pub fn lookup(&self, tex: &TextureView, uv: [f64; 2], out: &mut [f64]) {
        tex.lookup(self.apply(uv), out)
    }
}

impl TextureView<'_> {
    /// Bilinear lookup of every channel at an already transformed uv into `out` (len = channels).
    pub fn lookup(&self, uv: [f64; 2], out: &mut [f64]) {
        let fp = self.footprint(uv);
        let w = fp.weights();
        for (ch, o) in out.iter_mut().enumerate().take(self.channels) {
            *o = (0..4).map(|k| w[k] * self.texels[fp.idx[k] + ch] as f64).sum();
        }
    }
}

impl TextureTransform {
    fn rotation(&self) -> (f64, f64) {
        self.rotation_deg.to_radians().sin_cos()
    }

    /// The same transform with its rotation's sine and cosine computed.
    pub fn prepared(&self) -> PreparedTransform {
        let (sin, cos) = self.rotation();
        PreparedTransform { scale: self.scale, sin, cos, offset: self.offset }
    }

    /// The transformed uv.
    pub fn apply(&self, uv: [f64; 2]) -> [f64; 2] {
        self.prepared().apply(uv)
    }

    /// Bilinear lookup of every channel at the transformed `uv` into `out` (len = channels).
    pub fn lookup(&self, tex: &TextureView, uv: [f64; 2], out: &mut [f64]) {
        self.prepared().lookup(tex, uv, out)
    }

    /// Adds dL/d(texels) into `d_texels` (same layout as `tex.texels`; `None` skips them) and dL/d(transform)
    /// into `grad`, given
    /// dL/d(out) of one [`lookup`](Self::lookup) at `uv`. Exact inside a texel cell; bilinear filtering makes the
    /// uv derivative jump where the lookup crosses texel centres.
    pub fn lookup_backward(
        &self,
        tex: &TextureView,
        uv: [f64; 2],
        d_out: &[f64],
        mut d_texels: Option<&mut [f64]>,
        grad: &mut TransformGrad,
    ) {
        let fp = tex.footprint(self.apply(uv));
        let w = fp.weights();
        let (mut d_x, mut d_y) = (0.0, 0.0);
        for (ch, &d) in d_out.iter().enumerate().take(tex.channels) {
            let t = |k: usize| tex.texels[fp.idx[k] + ch] as f64;
            if let Some(dt) = d_texels.as_deref_mut() {
                for k in 0..4 {
                    dt[fp.idx[k] + ch] += w[k] * d;
                }
            }
            d_x += d * ((1.0 - fp.fy) * (t(1) - t(0)) + fp.fy * (t(3) - t(2)));
            d_y += d * ((1.0 - fp.fx) * (t(2) - t(0)) + fp.fx * (t(3) - t(1)));
        }
        // x = u' W - 1/2, y = (1 - v') H - 1/2.
        let d_u = d_x * tex.width as f64;
        let d_v = -d_y * tex.height as f64;
        let (s, c) = self.rotation();
        let (a, b) = (self.scale[0] * uv[0], self.scale[1] * uv[1]);
        grad.offset[0] += d_u;
        grad.offset[1] += d_v;
        grad.scale[0] += (d_u * c + d_v * s) * uv[0];
        grad.scale[1] += (-d_u * s + d_v * c) * uv[1];
        grad.rotation_deg += (d_u * (-s * a - c * b) + d_v * (c * a - s * b)) * 1f64.to_radians();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn smooth_texture(w: usize, h: usize, channels: usize) -> Vec<f32> {
        (0..w * h * channels)
            .map(|i| {
                let (p, ch) = (i / channels, i % channels);
                let (x, y) = ((p % w) as f32, (p / w) as f32);
                0.5 + 0.4 * (0.7 * x + 1.3 * ch as f32).sin() * (0.45 * y).cos()
            })
            .collect()
    }

    /// A transform perturbed by ε along one field.
    type Perturb<'a> = Box<dyn Fn(f64) -> TextureTransform + 'a>;

    /// Central differences of the lookup agree with the analytic derivative wherever the ±h lookups stay inside
    /// one texel cell (where the lookup is a polynomial, so FD error is O(h²) ≈ 1e-12).
    #[test]
    fn transform_and_texel_gradients_match_finite_differences() {
        let (w, h, ch) = (13, 9, 3);
        let texels = smooth_texture(w, h, ch);
        let tex = TextureView { width: w, height: h, channels: ch, texels: &texels };
        let d_out = [0.3, -1.1, 0.7];
        let loss = |t: &TextureTransform, texels: &[f32], uv: [f64; 2]| {
            let tex = TextureView { texels, ..tex };
            let mut out = [0.0; 3];
            t.lookup(&tex, uv, &mut out);
            out.iter().zip(d_out).map(|(o, d)| o * d).sum::<f64>()
        };
        let mut checked = 0;
        for k in 0..200 {
            let r = |m: u32| ((k * 7919 + m * 104729) % 1000) as f64 / 1000.0;
            let t = TextureTransform {
                scale: [0.5 + 7.5 * r(1), 0.5 + 7.5 * r(2)],
                rotation_deg: 360.0 * r(3) - 180.0,
                offset: [r(4) - 0.5, r(5) - 0.5],
            };
            let uv = [r(6) * 2.0 - 0.5, r(7) * 2.0 - 0.5];
            let mut g = TransformGrad::default();
            let mut d_tex = vec![0.0; texels.len()];
            t.lookup_backward(&tex, uv, &d_out, Some(&mut d_tex), &mut g);
            let eps = 1e-7;
            let cell = |t: &TextureTransform| {
                let p = t.apply(uv);
                ((p[0] * w as f64 - 0.5).floor(), ((1.0 - p[1]) * h as f64 - 0.5).floor())
            };
            let fd = |f: &dyn Fn(f64) -> TextureTransform| {
                let (tp, tm) = (f(eps), f(-eps));
                (cell(&tp) == cell(&tm)).then(|| (loss(&tp, &texels, uv) - loss(&tm, &texels, uv)) / (2.0 * eps))
            };
            let cases: [(f64, Perturb); 5] = [
                (g.scale[0], Box::new(|e| TextureTransform { scale: [t.scale[0] + e, t.scale[1]], ..t })),
                (g.scale[1], Box::new(|e| TextureTransform { scale: [t.scale[0], t.scale[1] + e], ..t })),
                (g.rotation_deg, Box::new(|e| TextureTransform { rotation_deg: t.rotation_deg + e, ..t })),
                (g.offset[0], Box::new(|e| TextureTransform { offset: [t.offset[0] + e, t.offset[1]], ..t })),
                (g.offset[1], Box::new(|e| TextureTransform { offset: [t.offset[0], t.offset[1] + e], ..t })),
            ];
            for (ad, f) in cases.iter() {
                if let Some(fd) = fd(f.as_ref()) {
                    assert!((ad - fd).abs() <= 1e-5 * (1.0 + fd.abs()), "case {k}: AD {ad} vs FD {fd}");
                    checked += 1;
                }
            }
            // The lookup is linear in the texels, so a texel's FD is exact up to rounding.
            let i = d_tex.iter().position(|&d| d != 0.0).expect("lookup touches texels");
            let mut tp = texels.clone();
            tp[i] += 1e-2;
            let fd = (loss(&t, &tp, uv) - loss(&t, &texels, uv)) / (tp[i] - texels[i]) as f64;
            assert!((d_tex[i] - fd).abs() < 1e-4 * (1.0 + fd.abs()), "texel {i}: AD {} vs FD {fd}", d_tex[i]);
        }
        assert!(checked > 900, "only {checked} of 1000 FD checks stayed inside a texel cell");
    }

    /// Wrap: shifting the transformed uv by whole texture periods gives the same value (identity transform).
    #[test]
    fn lookup_wraps_by_whole_periods() {
        let texels = smooth_texture(8, 8, 1);
        let tex = TextureView { width: 8, height: 8, channels: 1, texels: &texels };
        let t = TextureTransform::default();
        for uv in [[0.01, 0.02], [0.37, 0.91], [0.999, 0.5]] {
            let (mut a, mut b) = ([0.0], [0.0]);
            t.lookup(&tex, uv, &mut a);
            t.lookup(&tex, [uv[0] + 3.0, uv[1] - 2.0], &mut b);
            assert!((a[0] - b[0]).abs() < 1e-12, "{uv:?}: {} vs {}", a[0], b[0]);
        }
    }

    /// The inline floor and the wrapped neighbours equal `f64::floor` and `rem_euclid`, either side of zero,
    /// at integers and for sizes that are and are not powers of two.
    #[test]
    fn floor_and_wrap_equal_their_definitions() {
        for k in -4000..4000 {
            let v = k as f64 * 0.37 - 0.5;
            for v in [v, v.round(), -0.0, 1e300, -1e300, 4.5e18] {
                assert_eq!(floor(v), v.floor(), "floor({v})");
            }
            for n in [1usize, 2, 5, 6, 8, 64, 100, 256] {
                let i = k as i64;
                let want = [i.rem_euclid(n as i64) as usize, (i + 1).rem_euclid(n as i64) as usize];
                assert_eq!(wrapped_pair(i, n), want, "texel {i} of {n}");
            }
        }
        assert!(floor(f64::NAN).is_nan());
    }

    /// At a texel centre the lookup returns that texel exactly: uv (0,0) is bottom-left, row 0 is the top row.
    #[test]
    fn texel_centres_follow_the_renderer_convention() {
        let texels: Vec<f32> = (0..12).map(|i| i as f32).collect();
        let tex = TextureView { width: 4, height: 3, channels: 1, texels: &texels };
        let t = TextureTransform::default();
        for (x, y) in [(0usize, 0usize), (3, 0), (1, 2), (2, 1)] {
            let uv = [(x as f64 + 0.5) / 4.0, 1.0 - (y as f64 + 0.5) / 3.0];
            let mut out = [0.0];
            t.lookup(&tex, uv, &mut out);
            assert!((out[0] - (y * 4 + x) as f64).abs() < 1e-9, "texel ({x},{y}) read {}", out[0]);
        }
    }
}
