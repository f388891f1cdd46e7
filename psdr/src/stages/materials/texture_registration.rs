//! Where a chosen procedural texture lies on its surface: its rotation, scale and offset found by correlating
//! the texture with the photo's albedo over every pixel the segment shows (not one crop), so the tiles of a
//! floor, the courses of a brick wall and the seams of a plank floor fall on the photo's own.
//!
//! The library search ranks materials by a texture descriptor, which is blind to where a pattern sits (a Gram
//! matrix does not move when the pattern shifts) and sees one crop, where a 45-degree brick wall or tiles at 1.5x
//! their size can score as well as the right ones. The render is compared with the photo pixel by pixel, so a
//! tile grid half a tile off doubles the floor's error there. Here the photo's albedo (photo x albedo / the
//! fitted shading, luminance, in blocks of working pixels) is compared with the texture seen through each
//! block's uv (mip-filtered to the block's footprint) by normalised cross-correlation:
//!
//! 1. every rotation (multiples of `rotation_step`, and the search's) and scale about the found one
//!    (`scale_octaves` either side, `scale_steps` per octave), each at every offset on the texture's texel grid at
//!    once (`offset_correlation`: a cross-correlation by FFT), then quarter scale steps about the best few;
//! 2. the best `keep` refined with the exact (trilinear) lookups: each object's best few offsets on finer
//!    grids, then scale and rotation by halving steps.
//!
//! A surface made of several objects (the walls share one material, each with its own uv origin) gets one
//! rotation and scale and an offset per object: the material takes the largest object's, and every other
//! object's mesh uvs are shifted so that its texture lines up too (`uv_shifts`).

use super::offset_correlation::OffsetCorrelator;
use super::texture_view::Mips;
use crate::render::bvh::trace_closest;
use crate::render::camera::camera_ray;
use crate::render::layout::SHADING_HAS_UVS;
use crate::render::SceneData;
use crate::scene::{Scene, UvTransform};
use glam::{Vec2, Vec3};
use psdr_materials::{PreparedTransform, TextureTransform, TextureView};
use rayon::prelude::*;

#[derive(Clone, Debug)]
pub struct RegistrationOptions {
    /// Blocks compared, at most (each block a square of working pixels).
    pub max_cells: usize,
    /// Scales tried: the found one times 2^(k / scale_steps) for |k| / scale_steps <= scale_octaves. Fine: a
    /// scale 4 % off shifts a brick wall's courses by one a metre and a half from the centre, and the peak is
    /// gone (at 4 steps an octave, room08's wall settled at half its scale).
    pub scale_octaves: f32,
    pub scale_steps: usize,
    /// Rotations tried: the multiples of this (degrees) in 0..360, and the search's own (a diagonal floor).
    pub rotation_step: f32,
    /// (rotation, scale) pairs refined with the exact lookups.
    pub keep: usize,
    /// A registration whose `error_ratio` is not below this is not applied (the procedural material does not
    /// beat the homogeneous one on the photo). Under 1: `texture_surfaces` keeps the closest of several
    /// candidates, and one of them may fall just under 1 by fitting the shading's residue; over the 12 real
    /// rooms the ones kept at 0.52-0.89 lowered the image error or left it, at 0.91-0.93 raised it (room02's
    /// wooden bookcase as stripes: 11.0 -> 15.4 %).
    pub max_error_ratio: f32,
}

impl Default for RegistrationOptions {
    fn default() -> Self {
        RegistrationOptions {
            max_cells: 4000,
            scale_octaves: 1.0,
            scale_steps: 24,
            rotation_step: 90.0,
            keep: 3,
            max_error_ratio: 0.9,
        }
    }
}

/// What the registration found (result.json keeps it per textured segment).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Registration {
    pub rotation_deg: f32,
    pub scale: f32,
    pub offset: [f64; 2],
    /// Normalised cross-correlation of the photo's albedo and the texture over the blocks, at the transform the
    /// search found (offset 0) and at the registered one.
    pub correlation_before: f32,
    pub correlation: f32,
    /// Squared colour error of the registered texture's blocks against the photo's albedo over the flat albedo's
    /// (below 1: closer to the photo pixel by pixel; a pattern out of phase, or none in the photo, is above).
    pub error_ratio: f32,
    /// Whether the transform was applied: `error_ratio` below `max_error_ratio` (else the texture is farther
    /// from the photo than the flat albedo and the caller keeps the flat one).
    pub applied: bool,
    /// Blocks compared (fine pass) and their side in working pixels.
    pub cells: usize,
    pub cell_pixels: usize,
    /// Every other object showing the material, with the uv shift its mesh got.
    pub uv_shifts: Vec<(String, [f64; 2])>,
}

/// The photo's albedo in blocks of `side` working pixels over one material's pixels, each with the uv under its
/// centre, its footprint (uv units across the block) and the object it shows.
pub(crate) struct Cells {
    pub side: usize,
    /// Luminance of the photo's albedo, mean over the block's pixels.
    pub albedo: Vec<f64>,
    /// Its colour (RGB), the same mean.
    pub colour: Vec<[f64; 3]>,
    pub uv: Vec<[f64; 2]>,
    pub footprint: Vec<f64>,
    /// The uv change across the block along the image's x and along its y (a parallelogram on a surface seen
    /// at a slant; `footprint` is the longer side).
    pub axes: Vec<[[f64; 2]; 2]>,
    pub object: Vec<u32>,
}

impl Cells {
    /// Blocks of `side` pixels whose pixels are at least three quarters in `mask` (working size, the camera's)
    /// and whose centre and neighbours' centres hit `material`'s surface with uvs. `albedo_map` is the
    /// photo's albedo per working pixel (RGB).
    pub fn gather(d: &SceneData, material: u32, mask: &[f32], albedo_map: &[f32], side: usize) -> Cells {
        let (w, h) = (d.camera.width as usize, d.camera.height as usize);
        let origin = Vec3::from(d.camera.origin);
        let hit_uv = |x: f32, y: f32| -> Option<([f64; 2], u32)> {
            let hit = trace_closest(&d.nodes, &d.triangles, origin, camera_ray(&d.camera, x, y), f32::INFINITY)?;
            let t = hit.triangle as usize;
            let sh = &d.shading[t];
            if d.triangles[t].material != material || sh.flags & SHADING_HAS_UVS == 0 {
                return None;
            }
            let uv =
                Vec2::from(sh.uv0) * (1.0 - hit.u - hit.v) + Vec2::from(sh.uv1) * hit.u + Vec2::from(sh.uv2) * hit.v;
            Some(([uv.x as f64, uv.y as f64], d.triangles[t].object))
        };
        let mut out = Cells::empty(side);
        for by in 0..h / side {
            for bx in 0..w / side {
                let (mut sum, mut n) = ([0.0f64; 3], 0usize);
                for y in by * side..(by + 1) * side {
                    for x in bx * side..(bx + 1) * side {
                        if mask[y * w + x] > 0.5 {
                            let p = &albedo_map[3 * (y * w + x)..3 * (y * w + x) + 3];
                            (0..3).for_each(|c| sum[c] += p[c] as f64);
                            n += 1;
                        }
                    }
                }
                if 4 * n < 3 * side * side {
                    continue;
                }
                let (cx, cy) = ((bx * side) as f32 + 0.5 * side as f32, (by * side) as f32 + 0.5 * side as f32);
                let Some((uv, object)) = hit_uv(cx, cy) else { continue };
                // The block's footprint: the uv distance to a block's width away, either way along each axis.
                let s = side as f32;
                let step = |dx: f32, dy: f32| {
                    [(dx, dy), (-dx, -dy)]
                        .into_iter()
                        .find_map(|(a, b)| hit_uv(cx + a, cy + b).filter(|(_, o)| *o == object))
                        .map(|(q, _)| [q[0] - uv[0], q[1] - uv[1]])
                };
                let (Some(ax), Some(ay)) = (step(s, 0.0), step(0.0, s)) else { continue };
                out.push(sum.map(|v| v / n as f64), uv, [ax, ay], object);
            }
        }
        out
    }

    /// No blocks yet, each to be `side` pixels.
    pub fn empty(side: usize) -> Cells {
        Cells { side, albedo: vec![], colour: vec![], uv: vec![], footprint: vec![], axes: vec![], object: vec![] }
    }

    /// One more block: its mean colour, the uv under its centre, its axes (see `axes`) and object.
    pub fn push(&mut self, colour: [f64; 3], uv: [f64; 2], axes: [[f64; 2]; 2], object: u32) {
        self.albedo.push(0.2126 * colour[0] + 0.7152 * colour[1] + 0.0722 * colour[2]);
        self.colour.push(colour);
        self.uv.push(uv);
        self.footprint.push(axes[0][0].hypot(axes[0][1]).max(axes[1][0].hypot(axes[1][1])));
        self.axes.push(axes);
        self.object.push(object);
    }

    pub fn len(&self) -> usize {
        self.albedo.len()
    }
}

/// A texture's mip chain (2x2 box averages while the size halves evenly) as the registration samples it: its
/// luminance (`luminance`: the correlations) or its colour (`rgb`: the error against the photo that decides).
pub(crate) struct TexelMips {
    pub channels: usize,
    pub levels: Vec<(usize, usize, Vec<f32>)>,
}

impl TexelMips {
    /// From a square texture's RGB texels, `size` x `size`, row 0 on top: the luminance of each level (`Mips`: a
    /// box average of luminance is the luminance of the box average).
    pub fn luminance(size: usize, rgb: &[f32]) -> TexelMips {
        let lum = |t: &[f32]| t.chunks(3).map(|p| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]).collect();
        TexelMips { channels: 1, levels: Mips::new(size, rgb).levels.iter().map(|(n, t)| (*n, *n, lum(t))).collect() }
    }

    /// The same, every level in RGB.
    pub fn rgb(size: usize, rgb: &[f32]) -> TexelMips {
        TexelMips { channels: 3, levels: Mips::new(size, rgb).levels.into_iter().map(|(n, t)| (n, n, t)).collect() }
    }

    /// Trilinear lookup of the luminance at `uv` through `t`, filtered to a footprint of `footprint` texture
    /// units (the tests' truth; the registration's loops go through `Probe`).
    #[cfg(test)]
    fn sample(&self, t: &PreparedTransform, uv: [f64; 2], footprint: f64) -> f64 {
        let mut v = [0.0];
        self.sample_into(t, uv, footprint, &mut v);
        v[0]
    }

    /// The same lookup of the colour (an `rgb` chain).
    pub(crate) fn sample_rgb(&self, t: &PreparedTransform, uv: [f64; 2], footprint: f64) -> [f64; 3] {
        let mut v = [0.0; 3];
        self.sample_into(t, uv, footprint, &mut v);
        v
    }

    fn sample_into(&self, t: &PreparedTransform, uv: [f64; 2], footprint: f64, out: &mut [f64]) {
        let (level, f) = self.level(footprint * t.scale()[0].abs());
        self.trilinear(t.apply(uv), level, f, out);
    }

    /// The mip level and the blend toward the next for a footprint of `texture_units` (the transform's scale
    /// applied).
    fn level(&self, texture_units: f64) -> (usize, f64) {
        let (w0, h0, _) = &self.levels[0];
        let top = self.levels.len() - 1;
        let lod = (texture_units * (*w0.max(h0)) as f64).max(1.0).log2().min(top as f64);
        let l = (lod.floor() as usize).min(top);
        (l, lod - l as f64)
    }

    /// The lookup at a transformed uv on `level`, blended by `f` with the next.
    fn trilinear(&self, uv: [f64; 2], level: usize, f: f64, out: &mut [f64]) {
        let at = |l: usize, v: &mut [f64]| {
            let (w, h, texels) = &self.levels[l];
            TextureView { width: *w, height: *h, channels: self.channels, texels }.lookup(uv, v);
        };
        at(level, out);
        if f > 0.0 && level < self.levels.len() - 1 {
            let mut next = [0.0; 3];
            let next = &mut next[..out.len()];
            at(level + 1, next);
            out.iter_mut().zip(next.iter()).for_each(|(a, b)| *a = (1.0 - f) * *a + f * b);
        }
    }
}

/// One block's lookup with the offset left out: its uv rotated and scaled, its mip level and blend
/// (`Groups::fit` scores many offsets of one rotation and scale; the same operations as `TexelMips::sample`).
struct Probe {
    uv: [f64; 2],
    level: usize,
    blend: f64,
}

/// One transform's fit: per object its best offset and correlation terms.
#[derive(Clone, Debug)]
pub(crate) struct Fit {
    rotation_deg: f64,
    scale: f64,
    offsets: Vec<[f64; 2]>,
    /// Each object's best few offsets, best first (refinement starts from each: the best grid point can sit in
    /// a pattern's near twin, a brick wall one brick along, while the true one fell between grid points).
    top: Vec<Vec<[f64; 2]>>,
    /// The object each offset is for.
    objects: Vec<u32>,
    correlation: f64,
}

/// The photo's albedo about each object's mean, per object: cell indices, centred values, sum of squares.
struct Groups {
    objects: Vec<u32>,
    members: Vec<Vec<usize>>,
    centred: Vec<f64>,
    photo_ss: Vec<f64>,
    /// Each object's mean uv over all its cells: offsets are searched about it (uv' = s R (uv - centre) + o'),
    /// so that a change of scale does not move the pattern where the object is (its uvs may start metres away).
    centres: Vec<[f64; 2]>,
}

impl Groups {
    fn new(cells: &Cells, pick: &[usize]) -> Groups {
        let mut objects: Vec<u32> = pick.iter().map(|&i| cells.object[i]).collect();
        objects.sort_unstable();
        objects.dedup();
        let members: Vec<Vec<usize>> =
            objects.iter().map(|o| pick.iter().cloned().filter(|&i| cells.object[i] == *o).collect()).collect();
        let mut centred = vec![0.0; cells.len()];
        let mut photo_ss = vec![];
        for m in &members {
            let mean = m.iter().map(|&i| cells.albedo[i]).sum::<f64>() / m.len().max(1) as f64;
            m.iter().for_each(|&i| centred[i] = cells.albedo[i] - mean);
            photo_ss.push(m.iter().map(|&i| centred[i] * centred[i]).sum());
        }
        let centres = objects
            .iter()
            .map(|o| {
                let of: Vec<&[f64; 2]> =
                    (0..cells.len()).filter(|&i| cells.object[i] == *o).map(|i| &cells.uv[i]).collect();
                let n = of.len().max(1) as f64;
                [of.iter().map(|u| u[0]).sum::<f64>() / n, of.iter().map(|u| u[1]).sum::<f64>() / n]
            })
            .collect();
        Groups { objects, members, centred, photo_ss, centres }
    }

    /// s R centre of group `g`: the transform's offset is o' minus this.
    fn centre_term(&self, g: usize, scale: f64, rotation_deg: f64) -> [f64; 2] {
        let (sin, cos) = rotation_deg.to_radians().sin_cos();
        let c = self.centres[g];
        [scale * (cos * c[0] - sin * c[1]), scale * (sin * c[0] + cos * c[1])]
    }

    /// Group `g`'s blocks under rotation and scale `t` (its offset left out), each filtered to at least `blur`
    /// texture units (see `fit`).
    fn probes(&self, g: usize, cells: &Cells, mips: &TexelMips, t: &PreparedTransform, blur: f64) -> Vec<Probe> {
        let least = blur / t.scale()[0].abs().max(1e-9);
        self.members[g]
            .iter()
            .map(|&i| {
                let (level, blend) = mips.level(cells.footprint[i].max(least) * t.scale()[0].abs());
                Probe { uv: t.rotate_scale(cells.uv[i]), level, blend }
            })
            .collect()
    }

    /// (covariance with the photo, the texture's sum of squares about its mean) of object group `g` at
    /// `offset`, its blocks' `probes` made for that group.
    fn terms(&self, g: usize, probes: &[Probe], mips: &TexelMips, offset: [f64; 2]) -> (f64, f64) {
        let m = &self.members[g];
        let (mut cov, mut s, mut ss) = (0.0, 0.0, 0.0);
        for (&i, p) in m.iter().zip(probes) {
            let mut v = [0.0];
            mips.trilinear([p.uv[0] + offset[0], p.uv[1] + offset[1]], p.level, p.blend, &mut v);
            let v = v[0];
            cov += self.centred[i] * v;
            s += v;
            ss += v * v;
        }
        (cov, (ss - s * s / m.len().max(1) as f64).max(0.0))
    }

    /// Each object's best offset among `candidates(g)` and the correlation over all objects at those offsets,
    /// the texture filtered to at least `blur` texture units (a grid of offsets that step can miss a peak as
    /// narrow as a brick wall's mortar; filtered that wide, the peak is as wide as the step and the grid sees
    /// it: coarse to fine).
    fn fit(
        &self,
        cells: &Cells,
        mips: &TexelMips,
        rotation_deg: f64,
        scale: f64,
        candidates: &(dyn Fn(usize) -> Vec<[f64; 2]> + Sync),
        blur: f64,
    ) -> Fit {
        let t = TextureTransform { scale: [scale; 2], rotation_deg, offset: [0.0; 2] }.prepared();
        let ranked: Vec<Vec<([f64; 2], f64, f64)>> = (0..self.members.len())
            .map(|g| {
                let c = self.centre_term(g, scale, rotation_deg);
                let probes = self.probes(g, cells, mips, &t, blur);
                let mut scored: Vec<([f64; 2], f64, f64)> = candidates(g)
                    .into_par_iter()
                    .map(|o| {
                        let (cov, tss) = self.terms(g, &probes, mips, [o[0] - c[0], o[1] - c[1]]);
                        (o, cov, tss)
                    })
                    .collect();
                let score = |c: &([f64; 2], f64, f64)| c.1 / (c.2 * self.photo_ss[g]).sqrt().max(1e-12);
                scored.sort_by(|a, b| score(b).total_cmp(&score(a)));
                scored.truncate(TOP_OFFSETS);
                scored
            })
            .collect();
        let best: Vec<([f64; 2], f64, f64)> = ranked.iter().map(|r| r.first().cloned().unwrap_or_default()).collect();
        let cov: f64 = best.iter().map(|b| b.1).sum();
        let tss: f64 = best.iter().map(|b| b.2).sum();
        let pss: f64 = self.photo_ss.iter().sum();
        Fit {
            rotation_deg,
            scale,
            offsets: best.iter().map(|b| b.0).collect(),
            top: ranked.iter().map(|r| r.iter().map(|c| c.0).collect()).collect(),
            objects: self.objects.clone(),
            correlation: cov / (tss * pss).sqrt().max(1e-12),
        }
    }

    /// As `fit`, every offset on the texture's texel grid scored at once (`OffsetCorrelator`, each block at its
    /// nearest mip level): each object's best few offsets, apart by more than two texels (a peak's shoulders are
    /// not alternatives).
    fn fft_fit(&self, cells: &Cells, corr: &OffsetCorrelator, rotation_deg: f64, scale: f64) -> Fit {
        let n = corr.side();
        let t = TextureTransform { scale: [scale; 2], rotation_deg, offset: [0.0; 2] }.prepared();
        let top_level = corr.level_count() - 1;
        let mut offsets = vec![];
        let mut top = vec![];
        let (mut cov, mut tss) = (0.0, 0.0);
        for (g, m) in self.members.iter().enumerate() {
            let at: Vec<[f64; 2]> = m
                .iter()
                .map(|&i| {
                    let uv = t.apply(cells.uv[i]);
                    [uv[0] * n as f64 - 0.5, (1.0 - uv[1]) * n as f64 - 0.5]
                })
                .collect();
            let level: Vec<usize> = m
                .iter()
                .map(|&i| {
                    let lod = (cells.footprint[i] * scale * n as f64).max(1.0).log2();
                    (lod.round() as usize).min(top_level)
                })
                .collect();
            let p: Vec<f64> = m.iter().map(|&i| self.centred[i]).collect();
            let sums = corr.sums(&at, &p, &level);
            let count = m.len().max(1) as f64;
            let var = |k: usize| (sums.sum_sq[k] - sums.sum[k] * sums.sum[k] / count).max(0.0);
            let scores: Vec<f64> =
                (0..n * n).map(|k| sums.cov[k] / (var(k) * self.photo_ss[g]).sqrt().max(1e-12)).collect();
            let picked = best_apart(&scores, n, TOP_OFFSETS);
            cov += sums.cov[picked[0]];
            tss += var(picked[0]);
            // Offset (dc, dr) texels is uv (dc / n, -dr / n); about the object's centre (see `centres`).
            let c = self.centre_term(g, scale, rotation_deg);
            let centred = |k: usize| [(k % n) as f64 / n as f64 + c[0], -((k / n) as f64) / n as f64 + c[1]];
            offsets.push(centred(picked[0]));
            top.push(picked.iter().map(|&k| centred(k)).collect());
        }
        let pss: f64 = self.photo_ss.iter().sum();
        Fit {
            rotation_deg,
            scale,
            offsets,
            top,
            objects: self.objects.clone(),
            correlation: cov / (tss * pss).sqrt().max(1e-12),
        }
    }
}

/// Offsets per object kept for refinement.
const TOP_OFFSETS: usize = 4;

/// The `count` best of the n x n torus grid's `scores` (descending, ties by index), each more than two cells
/// from every better one kept (a peak's shoulders are not alternatives). Only the best 25 x `count` are
/// ordered: a kept offset rules out at most its 5 x 5 neighbours, so those hold `count` apart, the same ones a
/// sort of the whole grid gives (sorting every offset of every rotation and scale tried was a tenth of the
/// registration's time).
fn best_apart(scores: &[f64], n: usize, count: usize) -> Vec<usize> {
    let order = |a: &usize, b: &usize| scores[*b].total_cmp(&scores[*a]).then(a.cmp(b));
    let near = |a: usize, b: usize| {
        let d = |x: usize, y: usize| x.abs_diff(y).min(n - x.abs_diff(y));
        d(a % n, b % n) <= 2 && d(a / n, b / n) <= 2
    };
    let mut ranked: Vec<usize> = (0..scores.len()).collect();
    let head = 25 * count;
    if head > 0 && head < ranked.len() {
        ranked.select_nth_unstable_by(head - 1, order);
        ranked.truncate(head);
    }
    ranked.sort_unstable_by(order);
    let mut picked: Vec<usize> = vec![];
    for k in ranked {
        if picked.iter().all(|&q| !near(q, k)) {
            picked.push(k);
        }
        if picked.len() == count {
            break;
        }
    }
    picked
}

fn grid(n: usize, centre: [f64; 2], span: f64) -> Vec<[f64; 2]> {
    (0..n * n)
        .map(|k| {
            let (i, j) = ((k % n) as f64, (k / n) as f64);
            let step = span / n as f64;
            [centre[0] - 0.5 * span + (i + 0.5) * step, centre[1] - 0.5 * span + (j + 0.5) * step]
        })
        .collect()
}

/// About `max` of `n` cells, spread without a stride (a stride through row-major blocks picks columns).
fn subsample(n: usize, max: usize) -> Vec<usize> {
    if n <= max {
        return (0..n).collect();
    }
    // Each cell kept when its hash falls below the kept fraction (splitmix64: deterministic, well mixed).
    let keep = max as f64 / n as f64;
    (0..n)
        .filter(|&i| {
            let mut z = (i as u64).wrapping_add(0x9E3779B97F4A7C15);
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
            z ^= z >> 31;
            ((z >> 11) as f64) < keep * (1u64 << 53) as f64
        })
        .collect()
}

/// The transform under which `mips` best correlates with `cells` (see the module), starting from the search's
/// `scale` and `rotation_deg`; None when fewer than 16 blocks, a flat photo, or a texture that is not square.
pub(crate) fn register(
    cells: &Cells,
    mips: &TexelMips,
    scale: f32,
    rotation_deg: f32,
    opts: &RegistrationOptions,
) -> Option<(Fit, f64)> {
    if cells.len() < 16 {
        return None;
    }
    let groups = Groups::new(cells, &subsample(cells.len(), opts.max_cells));
    if groups.photo_ss.iter().sum::<f64>() <= 1e-12 {
        return None;
    }
    let correlator = OffsetCorrelator::new(&mips.levels)?;
    let (scale, rotation_deg) = (scale as f64, rotation_deg as f64);
    let at_start =
        groups.fit(cells, mips, rotation_deg, scale, &|g| vec![groups.centre_term(g, scale, rotation_deg)], 0.0);
    let steps = (opts.scale_octaves * opts.scale_steps as f32).round() as i32;
    let step = 2f64.powf(1.0 / opts.scale_steps.max(1) as f64);
    let scales: Vec<f64> = (-steps..=steps).map(|k| scale * step.powi(k)).collect();
    let mut rotations: Vec<f64> = (0..(360.0 / opts.rotation_step.max(1.0)).round() as usize)
        .map(|k| k as f64 * opts.rotation_step.max(1.0) as f64)
        .collect();
    if !rotations.iter().any(|r| (r - rotation_deg.rem_euclid(360.0)).abs() < 1e-6) {
        rotations.push(rotation_deg.rem_euclid(360.0));
    }
    // Every offset of every (rotation, scale) at once, then quarter scale steps about the best few.
    let pairs: Vec<(f64, f64)> = rotations.iter().flat_map(|&r| scales.iter().map(move |&s| (r, s))).collect();
    let mut tried: Vec<Fit> = pairs.par_iter().map(|&(r, s)| groups.fft_fit(cells, &correlator, r, s)).collect();
    tried.sort_by(|a, b| b.correlation.total_cmp(&a.correlation));
    tried.truncate(opts.keep.max(1));
    let quarters: Vec<(f64, f64)> = tried
        .iter()
        .flat_map(|c| [-2.0, -1.0, 1.0, 2.0].map(|k| (c.rotation_deg, c.scale * step.powf(k / 4.0))))
        .collect();
    tried.extend(quarters.par_iter().map(|&(r, s)| groups.fft_fit(cells, &correlator, r, s)).collect::<Vec<_>>());
    tried.sort_by(|a, b| b.correlation.total_cmp(&a.correlation));
    let n = correlator.side() as f64;
    // Offsets refined about each object's best few with the exact (trilinear) lookups: three rounds, each a
    // 5 x 5 grid over `span`, filtered to a quarter of it, the last unfiltered.
    let refine = |mut f: Fit, mut span: f64| {
        for round in 0..3 {
            let around = f.top.clone();
            let blur = if round < 2 { span / 4.0 } else { 0.0 };
            f = groups.fit(
                cells,
                mips,
                f.rotation_deg,
                f.scale,
                &|g| around[g].iter().flat_map(|o| grid(5, *o, span)).collect(),
                blur,
            );
            span /= 2.5;
        }
        f
    };
    let mut best = tried
        .into_iter()
        .take(opts.keep.max(1))
        .map(|f| refine(f, 2.0 / n))
        .max_by(|a, b| a.correlation.total_cmp(&b.correlation))?;
    // Scale and rotation refined by halving steps (4.4 % of scale misplaces a course by a whole brick a metre
    // and a half from the centre), each try with its offsets refined about the best's.
    let (mut ds, mut dr) = (step.powf(0.125), 2.0);
    for _ in 0..4 {
        for (s, r) in [(ds, 0.0), (1.0 / ds, 0.0), (1.0, dr), (1.0, -dr)] {
            let b = best.clone();
            let around = b.offsets.clone();
            let f = groups.fit(cells, mips, b.rotation_deg + r, b.scale * s, &|g| grid(5, around[g], 2.0 / n), 0.5 / n);
            let f = refine(f, 0.8 / n);
            if f.correlation > b.correlation {
                best = f;
            }
        }
        (ds, dr) = (ds.sqrt(), dr / 2.0);
    }
    if at_start.correlation >= best.correlation {
        best = at_start.clone();
    }
    // Back to the transform's own offsets.
    for (g, o) in best.offsets.iter_mut().enumerate() {
        let c = groups.centre_term(g, best.scale, best.rotation_deg);
        *o = [(o[0] - c[0]).rem_euclid(1.0), (o[1] - c[1]).rem_euclid(1.0)];
    }
    Some((best, at_start.correlation))
}

/// The shift of a mesh's uvs under which the transform (rotation, uniform scale, offset `main`) shows the texture
/// as it would at offset `own`: R S (uv + shift) + main = R S uv + own, the difference of the offsets taken
/// within half a unit square (the texture wraps).
fn uv_shift(own: [f64; 2], main: [f64; 2], rotation_deg: f64, scale: f64) -> [f64; 2] {
    let d = [0, 1].map(|k| {
        let v = own[k] - main[k];
        v - v.round()
    });
    let (sin, cos) = rotation_deg.to_radians().sin_cos();
    [(cos * d[0] + sin * d[1]) / scale, (-sin * d[0] + cos * d[1]) / scale]
}

/// Squared error of the blocks under the registered texture against the photo's albedo, over the same of the
/// flat albedo `flat` the texture replaces, in colour (RGB; `colours`: the texture's `rgb` chain): a texture
/// whose luminance lines up with the photo's but whose colours do not (stripes over real room02's bookcase,
/// its wood frame and pale panels, 0.93 in luminance) is no closer.
fn error_ratio(cells: &Cells, colours: &TexelMips, fit: &Fit, flat: Vec3) -> f32 {
    let (mut textured, mut homogeneous) = (0.0, 0.0);
    for (g, &o) in fit.objects.iter().enumerate() {
        let t = TextureTransform { scale: [fit.scale; 2], rotation_deg: fit.rotation_deg, offset: fit.offsets[g] }
            .prepared();
        for i in (0..cells.len()).filter(|&i| cells.object[i] == o) {
            let texel = colours.sample_rgb(&t, cells.uv[i], cells.footprint[i]);
            for c in 0..3 {
                textured += (cells.colour[i][c] - texel[c]).powi(2);
                homogeneous += (cells.colour[i][c] - flat[c] as f64).powi(2);
            }
        }
    }
    (textured / homogeneous.max(1e-12)) as f32
}

/// Registers material `material`'s procedural texture (already applied, `scene.materials[material]` a texture)
/// on the blocks of `cells` and, when it beats the flat albedo there (`applied`), applies the result: the
/// material's transform, the other objects' uv shifts.
/// `flat` is the homogeneous albedo the texture replaces (for `error_ratio`).
/// None (nothing changed) when the blocks are too few or flat.
pub fn register_texture(
    scene: &mut Scene,
    material: usize,
    flat: Vec3,
    cells: &Cells,
    opts: &RegistrationOptions,
) -> Option<Registration> {
    let crate::scene::Color::Texture(t) = scene.materials[material].albedo else { return None };
    let tex = &scene.textures[t];
    if tex.channels != 3 || tex.width != tex.height {
        return None;
    }
    let mips = TexelMips::luminance(tex.width as usize, &tex.texels);
    let start = scene.materials[material].uv_transform;
    let (fit, before) = register(cells, &mips, start.scale.x, start.rotation_deg, opts)?;
    let error_ratio = error_ratio(cells, &TexelMips::rgb(tex.width as usize, &tex.texels), &fit, flat);
    let applied = error_ratio < opts.max_error_ratio;
    // The largest object's offset is the material's; the others' meshes shift by (R S)^-1 (their offset - it),
    // the difference taken within half a unit square (the texture wraps).
    let count = |o: u32| cells.object.iter().filter(|&&c| c == o).count();
    let main = (0..fit.objects.len()).max_by_key(|&g| (count(fit.objects[g]), std::cmp::Reverse(g)))?;
    let offset = fit.offsets[main];
    let mut shifts = vec![];
    for (g, &o) in fit.objects.iter().enumerate().filter(|(g, _)| applied && *g != main) {
        let shift = uv_shift(fit.offsets[g], offset, fit.rotation_deg, fit.scale);
        let object = &mut scene.objects[o as usize];
        for part in object.parts.iter_mut().filter(|p| p.material == material) {
            if let Some(uvs) = part.uvs.as_mut() {
                uvs.iter_mut().for_each(|uv| *uv += Vec2::new(shift[0] as f32, shift[1] as f32));
            }
        }
        shifts.push((object.name.clone(), shift));
    }
    if applied {
        scene.materials[material].uv_transform = UvTransform {
            scale: Vec2::splat(fit.scale as f32),
            rotation_deg: fit.rotation_deg as f32,
            offset: Vec2::new(offset[0] as f32, offset[1] as f32),
        };
    }
    Some(Registration {
        error_ratio,
        applied,
        rotation_deg: fit.rotation_deg as f32,
        scale: fit.scale as f32,
        offset,
        correlation_before: before as f32,
        correlation: fit.correlation as f32,
        cells: cells.len().min(opts.max_cells),
        cell_pixels: cells.side,
        uv_shifts: shifts,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use psdr_materials::{library, Evaluator};

    fn library_texture(name: &str, size: usize) -> Vec<f32> {
        let g = library::load(name).expect("in the library").expect("loads");
        Evaluator::new(g.clone(), size).forward(&g.default_params()).albedo_linear.clone()
    }

    /// The partial ordering picks exactly what ordering every offset picks: on scores with ties, around one
    /// broad peak whose shoulders crowd the best ones, and on grids smaller than the part ordered.
    #[test]
    fn the_best_offsets_apart_equal_those_of_a_full_sort() {
        let full = |scores: &[f64], n: usize, count: usize| {
            let mut order: Vec<usize> = (0..scores.len()).collect();
            order.sort_by(|&a, &b| scores[b].total_cmp(&scores[a]));
            let mut picked: Vec<usize> = vec![];
            for k in order {
                let d = |x: usize, y: usize| x.abs_diff(y).min(n - x.abs_diff(y));
                if picked.iter().all(|&q| !(d(q % n, k % n) <= 2 && d(q / n, k / n) <= 2)) {
                    picked.push(k);
                }
                if picked.len() == count {
                    break;
                }
            }
            picked
        };
        let mut state = 0x9E37u32;
        for (n, levels) in [(4usize, 3u32), (16, 5), (64, 1000), (128, 7)] {
            let mut scores: Vec<f64> = (0..n * n)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 17;
                    state ^= state << 5;
                    (state % levels) as f64
                })
                .collect();
            assert_eq!(best_apart(&scores, n, 4), full(&scores, n, 4), "{n}x{n}, {levels} levels");
            // One broad peak: its 5 x 5 shoulders fill the head.
            for (k, score) in scores.iter_mut().enumerate() {
                let (x, y) = ((k % n) as f64 - n as f64 / 2.0, (k / n) as f64 - n as f64 / 2.0);
                *score = 1e3 - (x * x + y * y) + 0.01 * *score;
            }
            for count in [1, 4, 9] {
                assert_eq!(best_apart(&scores, n, count), full(&scores, n, count), "{n}x{n}, one peak, {count}");
            }
        }
    }

    /// Two walls seen head on, 3 cm blocks, each with its own uv origin metres away (as the room stage's walls
    /// have), showing a brick wall at a known transform and offset each, under a smooth shading residue and
    /// noise. Started where a descriptor search can leave it (40 % too large, rotated 45 degrees), the
    /// registration finds the scale within 3 %, the courses horizontal, and reproduces the photo's blocks.
    #[test]
    fn a_brick_wall_is_found_where_the_photo_shows_it() {
        let size = 128;
        let texels = library_texture("brick_wall", size);
        let mips = TexelMips::luminance(size, &texels);
        let (scale, rotation) = (0.83, 0.0);
        let truth = [[0.21, 0.64], [0.57, 0.12]];
        let origins = [[-8.97, -7.6], [3.3, -7.6]];
        let block = 0.03;
        let mut cells = Cells::empty(4);
        let mut noise = 0x2545F491u32;
        for (o, origin) in origins.iter().enumerate() {
            let t = TextureTransform { scale: [scale; 2], rotation_deg: rotation, offset: truth[o] }.prepared();
            for j in 0..60 {
                for i in 0..(if o == 0 { 90 } else { 40 }) {
                    let uv = [origin[0] + 6.0 + i as f64 * block, origin[1] + 0.3 + j as f64 * block];
                    noise ^= noise << 13;
                    noise ^= noise >> 17;
                    noise ^= noise << 5;
                    let shading = 1.0 + 0.1 * (i as f64 / 90.0) - 0.05 * (j as f64 / 60.0);
                    let n = 0.02 * ((noise % 1000) as f64 / 1000.0 - 0.5);
                    let v = mips.sample(&t, uv, block) * shading + n;
                    cells.push([v; 3], uv, [[block, 0.0], [0.0, block]], o as u32);
                }
            }
        }
        let (fit, before) = register(&cells, &mips, 1.4 * scale as f32, 45.0, &RegistrationOptions::default())
            .expect("enough textured blocks");
        assert!((fit.scale / scale - 1.0).abs() < 0.03, "scale {} against {scale}", fit.scale);
        assert!(fit.rotation_deg.rem_euclid(180.0) < 1e-6, "rotation {}", fit.rotation_deg);
        // The correlation the true transform reaches under this shading and noise (the most there is to find).
        let all = Groups::new(&cells, &(0..cells.len()).collect::<Vec<_>>());
        let at_truth = all.fit(
            &cells,
            &mips,
            rotation,
            scale,
            &|g| {
                let c = all.centre_term(g, scale, rotation);
                vec![[truth[g][0] + c[0], truth[g][1] + c[1]]]
            },
            0.0,
        );
        assert!(
            fit.correlation > at_truth.correlation - 0.02 && before < 0.3,
            "correlation {before} -> {}, {} at the truth",
            fit.correlation,
            at_truth.correlation
        );
        // Each wall's own offset reproduces its blocks (the texture wraps: offsets compared through the view).
        for (g, o) in fit.objects.iter().enumerate() {
            let t = TextureTransform { scale: [fit.scale; 2], rotation_deg: fit.rotation_deg, offset: fit.offsets[g] }
                .prepared();
            let (mut se, mut ss, mut n) = (0.0, 0.0, 0.0);
            let members: Vec<usize> = (0..cells.len()).filter(|&i| cells.object[i] == *o).collect();
            let mean = members.iter().map(|&i| cells.albedo[i]).sum::<f64>() / members.len() as f64;
            for &i in &members {
                let truth = TextureTransform { scale: [scale; 2], rotation_deg: rotation, offset: truth[*o as usize] }
                    .prepared();
                let want = mips.sample(&truth, cells.uv[i], block);
                se += (mips.sample(&t, cells.uv[i], block) - want).powi(2);
                ss += (cells.albedo[i] - mean).powi(2);
                n += 1.0;
            }
            assert!(
                se / n < 0.05 * ss / n,
                "wall {o}: squared error {} against the photo's variance {}",
                se / n,
                ss / n
            );
        }
    }

    /// Registered where the photo shows it, the brick wall is closer to the photo's blocks than their mean; a
    /// wall of stucco (another pattern, no course to register on) is farther, and would be taken back.
    #[test]
    fn a_texture_the_photo_does_not_show_is_farther_than_the_flat_albedo() {
        let size = 64;
        let bricks = library_texture("brick_wall", size);
        let mips = TexelMips::luminance(size, &bricks);
        let mean = |t: &[f32]| {
            Vec3::from_array(std::array::from_fn(|c| t.iter().skip(c).step_by(3).sum::<f32>() / (size * size) as f32))
        };
        for (photo, want_below) in [("brick_wall", true), ("stucco", false)] {
            let shown = library_texture(photo, size);
            let truth = TexelMips::rgb(size, &shown);
            let t = TextureTransform { scale: [1.0; 2], rotation_deg: 0.0, offset: [0.3, 0.6] }.prepared();
            let mut cells = Cells::empty(4);
            for j in 0..50 {
                for i in 0..50 {
                    let uv = [i as f64 * 0.02, j as f64 * 0.02];
                    cells.push(truth.sample_rgb(&t, uv, 0.02), uv, [[0.02, 0.0], [0.0, 0.02]], 0);
                }
            }
            let (fit, _) = register(&cells, &mips, 1.0, 0.0, &RegistrationOptions::default()).unwrap();
            let ratio = error_ratio(&cells, &TexelMips::rgb(size, &bricks), &fit, mean(&shown));
            assert_eq!(ratio < 1.0, want_below, "{photo}: error ratio {ratio}");
        }
    }

    /// A uv shift stands in for a second offset: R S (uv + shift) + main = R S uv + own.
    #[test]
    fn a_mesh_shift_stands_in_for_an_offset() {
        let (rotation, scale, main, own) = (30.0, 0.7, [0.1, 0.9], [0.8, 0.3]);
        let shift = uv_shift(own, main, rotation, scale);
        let uv = [2.5, -4.0];
        let with = |o: [f64; 2]| TextureTransform { scale: [scale; 2], rotation_deg: rotation, offset: o };
        let a = with(main).apply([uv[0] + shift[0], uv[1] + shift[1]]);
        let b = with(own).apply(uv);
        for k in 0..2 {
            let d = a[k] - b[k];
            assert!((d - d.round()).abs() < 1e-9, "{a:?} against {b:?}");
        }
    }

    /// A photo without texture, or too few blocks, registers nothing.
    #[test]
    fn flat_or_tiny_segments_are_left_alone() {
        let mips = TexelMips::luminance(64, &library_texture("brick_wall", 64));
        let flat = Cells {
            side: 4,
            albedo: vec![0.4; 400],
            colour: vec![[0.4; 3]; 400],
            uv: (0..400).map(|i| [(i % 20) as f64 * 0.05, (i / 20) as f64 * 0.05]).collect(),
            footprint: vec![0.05; 400],
            axes: vec![[[0.05, 0.0], [0.0, 0.05]]; 400],
            object: vec![0; 400],
        };
        assert!(register(&flat, &mips, 1.0, 0.0, &RegistrationOptions::default()).is_none());
        let tiny = Cells {
            side: 4,
            albedo: vec![0.1, 0.5],
            colour: vec![[0.1; 3], [0.5; 3]],
            uv: vec![[0.0; 2]; 2],
            footprint: vec![0.05; 2],
            axes: vec![[[0.05, 0.0], [0.0, 0.05]]; 2],
            object: vec![0; 2],
        };
        assert!(register(&tiny, &mips, 1.0, 0.0, &RegistrationOptions::default()).is_none());
    }
}
