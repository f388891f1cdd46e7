//! How a material's texture looks through a photo crop's pixels, and the way back: the surface's uv under each
//! crop pixel (`UvGrid`, a few samples per pixel), a uv transform, and a mip-mapped lookup. The mip level
//! follows each pixel's footprint (texels per sample from the grid's uv differences between neighbouring
//! pixels), blended between two levels (trilinear), so a texture much finer than the pixels is averaged the way a
//! camera (or a path tracer at many samples per pixel) averages it instead of aliasing: aliased views change
//! completely under a 2 % change of scale, which no texture comparison or search can work with.

use crate::base::Image;
use psdr_materials::{TextureTransform, TextureView, TransformGrad};

/// The surface's uv under each pixel of a crop (`samples` per pixel, averaged: a pixel's footprint), as the
/// camera sees it: perspective and all.
#[derive(Clone, Debug)]
pub struct UvGrid {
    pub width: usize,
    pub height: usize,
    /// Row-major pixels, each with its samples' uvs.
    pub uvs: Vec<Vec<[f64; 2]>>,
}

impl UvGrid {
    /// A `size` x `size` crop of a surface facing the camera, uv 0..1 across it (v up the image).
    pub fn unit_square(size: usize) -> UvGrid {
        let uvs = (0..size * size)
            .map(|p| vec![[((p % size) as f64 + 0.5) / size as f64, 1.0 - ((p / size) as f64 + 0.5) / size as f64]])
            .collect();
        UvGrid { width: size, height: size, uvs }
    }

    /// The largest extent of the uvs along u or v: how much surface the crop shows (from the pixels' mean uvs,
    /// widened by half a pixel at each end: a unit square's span is 1).
    pub fn span(&self) -> f64 {
        let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
        for p in (0..self.uvs.len()).filter_map(|p| self.mean(p)) {
            for k in 0..2 {
                (lo[k], hi[k]) = (lo[k].min(p[k]), hi[k].max(p[k]));
            }
        }
        let pixels = self.width.max(self.height).max(2) as f64;
        ((hi[0] - lo[0]).max(hi[1] - lo[1]) * pixels / (pixels - 1.0)).max(1e-9)
    }

    fn mean(&self, p: usize) -> Option<[f64; 2]> {
        let s = &self.uvs[p];
        (!s.is_empty()).then(|| {
            let n = s.len() as f64;
            [s.iter().map(|uv| uv[0]).sum::<f64>() / n, s.iter().map(|uv| uv[1]).sum::<f64>() / n]
        })
    }

    /// Each pixel's footprint in uv units per sample: the larger of the uv steps to its right and lower
    /// neighbours (or left and upper ones at the border), over the samples per side.
    fn footprints(&self) -> Vec<f64> {
        let (w, h) = (self.width, self.height);
        let dist = |a: Option<[f64; 2]>, b: Option<[f64; 2]>| match (a, b) {
            (Some(a), Some(b)) => Some(((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()),
            _ => None,
        };
        (0..w * h)
            .map(|p| {
                let (x, y) = (p % w, p / w);
                let nx = if x + 1 < w { p + 1 } else { p.saturating_sub(1) };
                let ny = if y + 1 < h { p + w } else { p.saturating_sub(w) };
                let d = [dist(self.mean(p), self.mean(nx)), dist(self.mean(p), self.mean(ny))];
                let step = d.iter().flatten().cloned().fold(0.0, f64::max);
                step / (self.uvs[p].len().max(1) as f64).sqrt()
            })
            .collect()
    }
}

/// A square RGB texture's mip chain: level 0 as given, each next one a 2x2 box average, while the size halves
/// evenly.
pub struct Mips {
    pub levels: Vec<(usize, Vec<f32>)>,
}

impl Mips {
    pub fn new(size: usize, texels: &[f32]) -> Mips {
        let mut levels = vec![(size, texels.to_vec())];
        while let Some((s, t)) = levels.last().filter(|(s, _)| *s >= 2 && s % 2 == 0) {
            let (n, prev) = (s / 2, t);
            let mut next = vec![0.0f32; n * n * 3];
            for y in 0..n {
                for x in 0..n {
                    for c in 0..3 {
                        let at = |dx: usize, dy: usize| prev[((2 * y + dy) * s + 2 * x + dx) * 3 + c];
                        next[(y * n + x) * 3 + c] = 0.25 * (at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1));
                    }
                }
            }
            levels.push((n, next));
        }
        Mips { levels }
    }

    /// The two levels a lookup filtered to `texture_units` (a footprint in texture repeats) blends, and the
    /// weight of the coarser one.
    pub(crate) fn levels_for(&self, texture_units: f64) -> (usize, usize, f64) {
        let top = self.levels.len() - 1;
        let lod = (texture_units * self.levels[0].0 as f64).max(1.0).log2().min(top as f64);
        let l = (lod.floor() as usize).min(top);
        (l, (l + 1).min(top), lod - l as f64)
    }

    pub(crate) fn view(&self, l: usize) -> TextureView<'_> {
        let (s, t) = &self.levels[l];
        TextureView { width: *s, height: *s, channels: 3, texels: t }
    }

    /// dL/d(level-0 texels) from dL/d(every level's texels): each level's gradient spread evenly over the 2x2
    /// texels below it, finest last.
    pub fn backward(&self, mut d_levels: Vec<Vec<f64>>) -> Vec<f64> {
        for l in (1..self.levels.len()).rev() {
            let (n, s) = (self.levels[l].0, self.levels[l - 1].0);
            let d = std::mem::take(&mut d_levels[l]);
            for y in 0..n {
                for x in 0..n {
                    for c in 0..3 {
                        let g = 0.25 * d[(y * n + x) * 3 + c];
                        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                            d_levels[l - 1][((2 * y + dy) * s + 2 * x + dx) * 3 + c] += g;
                        }
                    }
                }
            }
        }
        d_levels.swap_remove(0)
    }
}

/// Each pixel's two mip levels and the weight of the coarser one.
fn lods(mips: &Mips, grid: &UvGrid, scale: f32) -> Vec<(usize, usize, f64)> {
    grid.footprints().into_iter().map(|f| mips.levels_for(f * scale.abs() as f64)).collect()
}

/// The texture (linear RGB, `size` x `size`) as the crop's pixels would show it through the transform.
pub fn texture_view(size: usize, texels: &[f32], scale: f32, rotation_deg: f32, grid: &UvGrid) -> Image {
    texture_view_mips(&Mips::new(size, texels), scale, rotation_deg, grid)
}

fn transform(scale: f32, rotation_deg: f32) -> TextureTransform {
    TextureTransform { scale: [scale as f64; 2], rotation_deg: rotation_deg as f64, offset: [0.0, 0.0] }
}

pub fn texture_view_mips(mips: &Mips, scale: f32, rotation_deg: f32, grid: &UvGrid) -> Image {
    let t = transform(scale, rotation_deg).prepared();
    let lods = lods(mips, grid, scale);
    let mut data = Vec::with_capacity(grid.width * grid.height * 3);
    let (mut a, mut b) = ([0.0f64; 3], [0.0f64; 3]);
    for (samples, &(l0, l1, f)) in grid.uvs.iter().zip(&lods) {
        let (v0, v1) = (mips.view(l0), mips.view(l1));
        let mut sum = [0.0f64; 3];
        for uv in samples {
            t.lookup(&v0, *uv, &mut a);
            t.lookup(&v1, *uv, &mut b);
            (0..3).for_each(|c| sum[c] += (1.0 - f) * a[c] + f * b[c]);
        }
        let n = samples.len().max(1) as f64;
        data.extend(sum.iter().map(|v| (*v / n) as f32));
    }
    Image { width: grid.width, height: grid.height, channels: 3, data }
}

/// dL/d(level-0 texels) and dL/d(transform) from dL/d(view) (3 per pixel) of `texture_view_mips` (the mip
/// levels held fixed per pixel: the filter width is a choice, not a parameter).
pub fn texture_view_backward(
    mips: &Mips,
    scale: f32,
    rotation_deg: f32,
    grid: &UvGrid,
    d_view: &[f64],
) -> (Vec<f64>, TransformGrad) {
    let t = transform(scale, rotation_deg);
    let lods = lods(mips, grid, scale);
    let mut d_levels: Vec<Vec<f64>> = mips.levels.iter().map(|(_, t)| vec![0.0; t.len()]).collect();
    let mut g = TransformGrad::default();
    for (px, (samples, &(l0, l1, f))) in grid.uvs.iter().zip(&lods).enumerate() {
        let k = 1.0 / samples.len().max(1) as f64;
        let d = [d_view[3 * px] * k, d_view[3 * px + 1] * k, d_view[3 * px + 2] * k];
        for (l, w) in [(l0, 1.0 - f), (l1, f)] {
            if w == 0.0 {
                continue;
            }
            let view = mips.view(l);
            let dw = d.map(|x| x * w);
            for uv in samples {
                t.lookup_backward(&view, *uv, &dw, Some(&mut d_levels[l]), &mut g);
            }
        }
    }
    (mips.backward(d_levels), g)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The view's backward is the transpose of its forward (a linear map of the texels): <d, V t> = <V^T d, t>.
    #[test]
    fn backward_is_the_adjoint_of_the_view() {
        let size = 16;
        let texels: Vec<f32> = (0..size * size * 3).map(|i| ((i * 37 % 101) as f32) / 101.0).collect();
        // 8 x 8 pixels over 3 repeats: about 6 texels per pixel, so coarser levels are used.
        let grid = UvGrid::unit_square(8);
        let mips = Mips::new(size, &texels);
        let view = texture_view_mips(&mips, 3.0, 20.0, &grid);
        let d: Vec<f64> = (0..view.data.len()).map(|i| ((i * 13 % 7) as f64) - 3.0).collect();
        let (d_texels, _) = texture_view_backward(&mips, 3.0, 20.0, &grid, &d);
        let lhs: f64 = d.iter().zip(&view.data).map(|(a, &b)| a * b as f64).sum();
        let rhs: f64 = d_texels.iter().zip(&texels).map(|(a, &b)| a * b as f64).sum();
        assert!((lhs - rhs).abs() < 1e-4 * lhs.abs().max(1.0), "{lhs} vs {rhs}");
        assert!(mips.levels.len() == 5 && lods(&mips, &grid, 3.0).iter().any(|l| l.0 > 0));
    }

    /// A fine checker seen through far too few pixels averages to its mean instead of aliasing.
    #[test]
    fn fine_textures_are_averaged_not_aliased() {
        let size = 64;
        let texels: Vec<f32> = (0..size * size).flat_map(|i| [((i % size + i / size) % 2) as f32; 3]).collect();
        let view = texture_view(size, &texels, 4.0, 0.0, &UvGrid::unit_square(16));
        for v in &view.data {
            assert!((v - 0.5).abs() < 0.02, "{v}");
        }
    }
}
