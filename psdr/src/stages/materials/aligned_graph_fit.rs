//! The chosen procedural material's graph fitted once more where the registration put it: block by block
//! against the photo's albedo over the whole segment.
//!
//! The first fit (`graph_fit`) matches a crop's texture descriptor, which cannot see where the pattern lies and
//! trades a grout line's width against its darkness and the tiles' contrast. Once the texture is registered,
//! every pixel of the segment says which texels it shows, and the registration's own measure (the squared
//! colour error of the texture against the photo's albedo over the flat albedo's, `error_ratio`) fits the
//! widths and colours themselves: real room00's floor tiles came out of the descriptor fit with grout 0.013 of
//! a repeat wide for the photo's 0.02, paler, the tiles darker, a grid of errors over the whole floor. The
//! graph's parameters and tint, and the uv transform (two scales, the rotation, the offset about the blocks'
//! centre, from the registration's), move by Adam (`graph_fit::fit_graph`), the tint is brought back to the
//! fitted albedo after (the lights' fit holds), and the caller keeps the fit only where it lowers the error
//! ratio. Each block's texture is the mean of lookups spread over the block's parallelogram on the surface
//! (`block_samples`): one lookup filtered to the block's longer side blurs a slanted floor's grout threefold,
//! and scored room00's true tiles 0.51 against the fitted ones' 0.48 (spread: 0.18 against 0.20).

use super::graph_fit::{fit_graph, tint_to_mean, GraphFitOptions, GraphObjective};
use super::texture_registration::Cells;
use super::texture_view::Mips;
use crate::error::{Error, Result};
use crate::scene::{Procedural, UvTransform};
use glam::Vec3;
use psdr_materials::{TextureTransform, TransformGrad};

/// What the aligned fit did (result.json keeps it per textured segment).
#[derive(Clone, Debug, serde::Serialize)]
pub struct AlignedFit {
    /// The registered texture's squared colour error over the flat albedo's on `cells` blocks, before and
    /// after (the tint brought back to the fitted albedo in both).
    pub error_before: f32,
    pub error_after: f32,
    pub cells: usize,
    pub cell_pixels: usize,
    /// Whether the fitted graph replaced the registered one (`error_after` below `error_before`).
    pub applied: bool,
}

/// Fits `p`'s graph parameters and tint, and the uv transform about the blocks' centre, to `cells` seen through
/// `transform` (the material's, its surfaces' uvs as the cells hold them), its mean held at `flat`. Returns the
/// errors before and after and the fitted transform; `p` is left at the fit.
pub fn fit_graph_on_cells(
    p: &mut Procedural,
    transform: UvTransform,
    cells: &Cells,
    flat: Vec3,
    opts: &GraphFitOptions,
) -> Result<(f32, f32, UvTransform)> {
    if cells.len() == 0 {
        return Err(Error::Invalid("fit_graph_on_cells: no blocks to fit".into()));
    }
    // The uvs about their centre, so that a change of scale or rotation turns the pattern where the surface
    // is, not about a uv origin metres away (the registration's offsets are searched so too).
    let n = cells.len() as f64;
    let centre = [0, 1].map(|k| cells.uv.iter().map(|uv| uv[k]).sum::<f64>() / n);
    let centred: Vec<[f64; 2]> = cells.uv.iter().map(|uv| [uv[0] - centre[0], uv[1] - centre[1]]).collect();
    let homogeneous: f64 = (0..cells.len())
        .map(|i| (0..3).map(|c| (cells.colour[i][c] - flat[c] as f64).powi(2)).sum::<f64>())
        .sum::<f64>()
        .max(1e-12);
    let start = transform.texture_transform();
    let about_centre = start.prepared().apply(centre);
    let mut extra = [
        start.scale[0].ln() * SCALE_UNITS,
        start.scale[1].ln() * SCALE_UNITS,
        start.rotation_deg * ROTATION_UNITS,
        about_centre[0] * OFFSET_UNITS,
        about_centre[1] * OFFSET_UNITS,
    ];
    let mut objective = |mips: &Mips, x: &[f64], with_gradient: bool| -> Result<(f32, Vec<f64>, Vec<f64>)> {
        let t = centred_transform(x);
        let (loss, d_texels, g) = cells_error(mips, &t, &centred, cells, homogeneous, with_gradient);
        let d_extra = vec![
            g.scale[0] * t.scale[0] / SCALE_UNITS,
            g.scale[1] * t.scale[1] / SCALE_UNITS,
            g.rotation_deg / ROTATION_UNITS,
            g.offset[0] / OFFSET_UNITS,
            g.offset[1] / OFFSET_UNITS,
        ];
        Ok((loss, d_texels, d_extra))
    };
    let before = error_of(p, flat, &mut objective, &extra)?;
    fit_graph(p, &mut extra, opts, &mut objective)?;
    let after = error_of(p, flat, &mut objective, &extra)?;
    // Back to the material's transform: offset o = o' - R S centre.
    let t = centred_transform(&extra);
    let turned = TextureTransform { offset: [0.0; 2], ..t }.prepared().apply(centre);
    let fitted = UvTransform {
        scale: glam::Vec2::new(t.scale[0] as f32, t.scale[1] as f32),
        rotation_deg: t.rotation_deg as f32,
        offset: glam::Vec2::new(
            (t.offset[0] - turned[0]).rem_euclid(1.0) as f32,
            (t.offset[1] - turned[1]).rem_euclid(1.0) as f32,
        ),
    };
    Ok((before, after, fitted))
}

/// Adam's coordinates for the transform (its step is the same in every coordinate, about the rate, 0.03 at
/// first): ln(scale) in tenths (0.3 % a step: across 5 m of floor a tile grid's lines move by a fifth of a
/// grout's width), the rotation in degrees, the offset in tenths of a repeat.
const SCALE_UNITS: f64 = 10.0;
const ROTATION_UNITS: f64 = 1.0;
const OFFSET_UNITS: f64 = 10.0;

/// The transform of the centred uvs that the coordinates `x` (see the units) describe.
fn centred_transform(x: &[f64]) -> TextureTransform {
    TextureTransform {
        scale: [(x[0] / SCALE_UNITS).exp(), (x[1] / SCALE_UNITS).exp()],
        rotation_deg: x[2] / ROTATION_UNITS,
        offset: [x[3] / OFFSET_UNITS, x[4] / OFFSET_UNITS],
    }
}

/// `p` tinted so its baked mean is `flat` (`tint_to_mean`), and its error under `objective` at `extra`.
fn error_of(p: &mut Procedural, flat: Vec3, objective: &mut GraphObjective, extra: &[f64]) -> Result<f32> {
    tint_to_mean(p, flat)?;
    let baked = p.bake()?;
    Ok(objective(&Mips::new(p.size as usize, &baked.texels), extra, false)?.0)
}

/// Σ over the blocks and channels of (texture − photo's albedo)², over `homogeneous` (the flat albedo's), each
/// block's texture the mean of a grid of lookups over its parallelogram (`block_samples`) through `t` about its
/// `uvs` entry; with `with_gradient`, dL/d(level-0 texels) and dL/d(transform).
fn cells_error(
    mips: &Mips,
    t: &TextureTransform,
    uvs: &[[f64; 2]],
    cells: &Cells,
    homogeneous: f64,
    with_gradient: bool,
) -> (f32, Vec<f64>, TransformGrad) {
    let prepared = t.prepared();
    let mut d_levels: Vec<Vec<f64>> = match with_gradient {
        true => mips.levels.iter().map(|(_, texels)| vec![0.0; texels.len()]).collect(),
        false => vec![],
    };
    let mut grad = TransformGrad::default();
    let mut sum = 0.0;
    let mut samples = vec![];
    for (i, &uv) in uvs.iter().enumerate() {
        let (l0, l1, f) = block_samples(mips, t, uv, cells.axes[i], &mut samples);
        let w = 1.0 / samples.len() as f64;
        let mut v = [0.0f64; 3];
        let (mut a, mut b) = ([0.0f64; 3], [0.0f64; 3]);
        for &s in &samples {
            prepared.lookup(&mips.view(l0), s, &mut a);
            prepared.lookup(&mips.view(l1), s, &mut b);
            (0..3).for_each(|c| v[c] += w * ((1.0 - f) * a[c] + f * b[c]));
        }
        let r: [f64; 3] = std::array::from_fn(|c| v[c] - cells.colour[i][c]);
        sum += r.iter().map(|x| x * x).sum::<f64>();
        if with_gradient {
            for (l, lw) in [(l0, 1.0 - f), (l1, f)] {
                if lw > 0.0 {
                    let d = r.map(|x| 2.0 * x * lw * w / homogeneous);
                    for &s in &samples {
                        t.lookup_backward(&mips.view(l), s, &d, Some(&mut d_levels[l]), &mut grad);
                    }
                }
            }
        }
    }
    let d_texels = if with_gradient { mips.backward(d_levels) } else { vec![] };
    ((sum / homogeneous) as f32, d_texels, grad)
}

/// The uvs of a grid of lookups over a block (centre `uv`, its `axes`: the uv change across it along the
/// image's x and y) into `out`, and the two mip levels they read and the coarser one's weight: up to
/// `MAX_BLOCK_SAMPLES` a side, about one a texel, each filtered to the spacing left. A block is a box in the
/// photo; one lookup filtered to its longer side (the registration's) blurs a floor's grout lines across the
/// short side, three times over at a slant, and the fit then thinned the grout it could not darken.
fn block_samples(
    mips: &Mips,
    t: &TextureTransform,
    uv: [f64; 2],
    axes: [[f64; 2]; 2],
    out: &mut Vec<[f64; 2]>,
) -> (usize, usize, f64) {
    let texels = mips.levels[0].0 as f64 * t.scale[0].abs().max(t.scale[1].abs());
    let length = axes.map(|a| a[0].hypot(a[1]) * texels);
    let count = length.map(|l| (l.ceil() as usize).clamp(1, MAX_BLOCK_SAMPLES));
    let spacing = (length[0] / count[0] as f64).max(length[1] / count[1] as f64);
    out.clear();
    for j in 0..count[1] {
        let b = (j as f64 + 0.5) / count[1] as f64 - 0.5;
        for i in 0..count[0] {
            let a = (i as f64 + 0.5) / count[0] as f64 - 0.5;
            out.push([uv[0] + a * axes[0][0] + b * axes[1][0], uv[1] + a * axes[0][1] + b * axes[1][1]]);
        }
    }
    mips.levels_for(spacing / mips.levels[0].0 as f64)
}

/// Lookups a side of a block, at most.
const MAX_BLOCK_SAMPLES: usize = 6;

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks of square tiles whose grout is twice the library's width and darker, seen at a slant through a
    /// known transform, a texel or two per block: the fit starting from the library's parameters and a transform a
    /// little off brings the error ratio below a fifth, the mortar width most of the way to the truth's and
    /// the grid back onto the blocks' (the descriptor fit cannot: it does not see where the lines are).
    #[test]
    fn the_grout_of_registered_tiles_is_fitted_to_the_photo() {
        let mut truth = Procedural::new("square_tiles", 64).unwrap();
        let graph = truth.load_graph().unwrap();
        let mortar = graph.param("mortar").cloned().unwrap().offset;
        let grout = graph.param("grout").cloned().unwrap().offset;
        let start_mortar = truth.params.floats[mortar];
        truth.params.floats[mortar] = 2.0 * start_mortar;
        (0..3).for_each(|c| truth.params.floats[grout + c] *= 0.6);
        let transform =
            UvTransform { scale: glam::Vec2::splat(0.8), rotation_deg: 90.0, offset: glam::Vec2::new(0.3, 0.1) };
        let t = TextureTransform { scale: [0.8; 2], rotation_deg: 90.0, offset: [0.3, 0.1] };
        let baked = truth.bake().unwrap();
        let mips = Mips::new(64, &baked.texels);
        // A 2.5 x 2.5 uv square seen at a slant: 80 x 27 blocks, each 1.6 texels across and three times that
        // along v, its colour the mean of 8 x 8 bilinear lookups over it (the photo's box).
        let (nx, ny) = (80, 27);
        let axes = [[2.5 / nx as f64, 0.0], [0.0, 2.5 / ny as f64]];
        let mut cells = Cells::empty(1);
        for k in 0..nx * ny {
            let uv = [((k % nx) as f64 + 0.5) * axes[0][0], ((k / nx) as f64 + 0.5) * axes[1][1]];
            let mut colour = [0.0; 3];
            for q in 0..64 {
                let (a, b) = (((q % 8) as f64 + 0.5) / 8.0 - 0.5, ((q / 8) as f64 + 0.5) / 8.0 - 0.5);
                let mut v = [0.0; 3];
                t.prepared().lookup(&mips.view(0), [uv[0] + a * axes[0][0], uv[1] + b * axes[1][1]], &mut v);
                (0..3).for_each(|c| colour[c] += v[c] / 64.0);
            }
            cells.push(colour, uv, axes, 0);
        }
        let flat = {
            let m = |c: usize| (cells.colour.iter().map(|v| v[c]).sum::<f64>() / cells.len() as f64) as f32;
            Vec3::new(m(0), m(1), m(2))
        };
        // The truth itself scores near nothing through the blocks' lookups (one lookup filtered to a block's
        // longer side scored real room00's true floor tiles 0.51, the fitted ones 0.48).
        let mut own = truth.clone();
        let own_gf = GraphFitOptions { iters: 0, ..GraphFitOptions::default() };
        let (own_error, _, _) = fit_graph_on_cells(&mut own, transform, &cells, flat, &own_gf).unwrap();
        assert!(own_error < 0.01, "the truth's own error ratio {own_error}");
        // The registration a little off: 0.6 % in scale (the grid drifts by a grout's width across the
        // square), 0.3 degrees, a fifth of a grout's width in offset.
        let start = UvTransform {
            scale: transform.scale * 1.006,
            rotation_deg: 90.3,
            offset: transform.offset + glam::Vec2::new(0.004, -0.004),
        };
        let mut p = Procedural::new("square_tiles", 64).unwrap();
        let opts = GraphFitOptions { iters: 80, ..GraphFitOptions::default() };
        let (before, after, fitted) = fit_graph_on_cells(&mut p, start, &cells, flat, &opts).unwrap();
        let m = p.params.floats[mortar];
        eprintln!("error {before} -> {after}; mortar {start_mortar} -> {m} (truth {}); {fitted:?}", 2.0 * start_mortar);
        assert!(after < 0.2 * before, "error {before} -> {after}");
        assert!((m - 2.0 * start_mortar).abs() < 0.5 * start_mortar, "mortar {m}");
        // The transform back where the blocks were made: the scale within 0.2 %, the pattern's place within a
        // quarter of the grout (0.01 of a repeat) at the square's corners.
        assert!((fitted.scale / transform.scale - 1.0).abs().max_element() < 0.002, "{fitted:?}");
        let at = |u: &UvTransform, uv: [f64; 2]| {
            TextureTransform {
                scale: [u.scale.x as f64, u.scale.y as f64],
                rotation_deg: u.rotation_deg as f64,
                offset: [u.offset.x as f64, u.offset.y as f64],
            }
            .apply(uv)
        };
        for corner in [[0.0, 0.0], [2.5, 0.0], [0.0, 2.5], [2.5, 2.5]] {
            let (a, b) = (at(&fitted, corner), at(&transform, corner));
            let d = [0, 1].map(|k| (a[k] - b[k]) - (a[k] - b[k]).round());
            assert!(d[0].hypot(d[1]) < 0.01, "corner {corner:?}: {d:?}");
        }
    }
}
