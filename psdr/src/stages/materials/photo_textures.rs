//! Photo textures: the photo's own pattern on a plane whose texture no library material reproduces (a
//! photographed plank floor: no procedural wood registers onto its planks better than a flat colour, so the
//! texture search leaves it homogeneous, and the planks' bands are most of the image error there).
//!
//! For each given segment whose material is one plane with an affine uv map and no lights on it (a room's
//! floor; a material spread over several planes, like the walls' one, is left as it is, and so is a ceiling
//! its lights hang on: near them the photo's light is the lights' near field, not albedo, and the outlines of
//! those the photo shows are refitted at its size after this stage; real room00's ceiling took their halos
//! as dark rings and its image error rose 11.3 -> 13.0 %):
//! 1. the photo's albedo relative to the fitted constant: the (detail) photo over the fitted scene's render (at
//!    `spp`, blurred as the texture search blurs it: its noise is not texture);
//! 2. a texture over the plane's part the photo shows (the uv box of its pixels), texels as fine as the
//!    finest tenth of its pixels (at most `max_size` a side): each texel's centre projected into the photo
//!    takes that albedo there (bilinear over the segment's pixels) where an eroded segment pixel shows the
//!    plane;
//! 3. only its pattern is kept: each seen texel over the mean of the seen texels in a box `window` wide around
//!    it (metres on a room's planes: what varies slower, a light a little off or a fall-off the fit missed,
//!    stays with the lights and the constant), clamped to 1/`max_ratio`..`max_ratio`, times the fitted
//!    constant; the texels the photo does not show keep the constant (the renderer's wrap repeats the texture
//!    beyond the box, where the camera does not look);
//! 4. the material's albedo becomes that texture, its uv transform mapping the box onto it.
//!
//! Applied last in the material stage, after the joint pass and the lights' last fit: the lights are fitted
//! to the constants, which are the textures' local means.

use super::albedo_division::{Segment, ALBEDO_RANGE};
use super::surface_textures::{blurred, detail_or_working};
use crate::backend::Backend;
use crate::base::erode;
use crate::error::{Error, Result};
use crate::grad::boundary::primary::project;
use crate::loss::Image;
use crate::render::camera::camera_ray;
use crate::render::layout::{NONE, SHADING_HAS_UVS};
use crate::render::SceneData;
use crate::scene::{Color, Scene, Texture, UvTransform};
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct PhotoTextureOptions {
    /// Samples per pixel of the fitted scene's render the photo is divided by.
    pub spp: u32,
    /// Side of the box (the plane's uv units: metres on a room's planes) the pattern is taken relative to.
    pub window: f32,
    /// The pattern's ratio to its local mean is clamped to 1/max_ratio..max_ratio.
    pub max_ratio: f32,
    /// Longest side of a texture (texels).
    pub max_size: usize,
    /// Working pixels taken off the segment's edge (a silhouette a pixel off would paint the furniture on).
    pub erode: usize,
}

impl Default for PhotoTextureOptions {
    fn default() -> Self {
        PhotoTextureOptions { spp: 64, window: 1.0, max_ratio: 3.0, max_size: 1024, erode: 1 }
    }
}

/// What was done for one segment (result.json's `photo_textures`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct PhotoTexture {
    pub material: String,
    pub applied: bool,
    pub decision: String,
    /// Texels, width and height.
    pub size: [u32; 2],
    /// The texel's side in the surface's uv units (metres for a room's planes).
    pub texel: f32,
    /// Share of the texels the photo shows (the rest keep the constant).
    pub seen: f32,
    /// RMS of the pattern's ratio to 1 over the seen texels, luminance: how much texture it carries.
    pub pattern_rms: f32,
}

/// A plane's affine uv map: the point at uv (u, v) is `origin + u du + v dv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneMap {
    pub origin: Vec3,
    pub du: Vec3,
    pub dv: Vec3,
}

impl PlaneMap {
    pub fn point(&self, uv: Vec2) -> Vec3 {
        self.origin + uv.x * self.du + uv.y * self.dv
    }

    fn normal(&self) -> Vec3 {
        self.du.cross(self.dv).normalize_or_zero()
    }

    /// The uv where the ray (o, dir) meets the plane, if in front of it.
    pub fn uv_on_ray(&self, o: Vec3, dir: Vec3) -> Option<Vec2> {
        let n = self.normal();
        let denom = dir.dot(n);
        if denom.abs() < 1e-8 {
            return None;
        }
        let t = (self.origin - o).dot(n) / denom;
        (t > 0.0).then(|| self.uv_of(o + t * dir))
    }

    /// The uv of a point on the plane (least squares over du, dv).
    fn uv_of(&self, p: Vec3) -> Vec2 {
        let r = p - self.origin;
        let (a, b, c) = (self.du.dot(self.du), self.du.dot(self.dv), self.dv.dot(self.dv));
        let (x, y) = (r.dot(self.du), r.dot(self.dv));
        let det = a * c - b * b;
        Vec2::new((c * x - b * y) / det, (a * y - b * x) / det)
    }
}

/// The affine uv map shared by every triangle of `material`, when they lie in one plane with one affine uv
/// map (to 1e-4 of the plane's size); None otherwise (no triangles, no uvs, several planes or a curved map).
pub fn plane_map(d: &SceneData, material: u32) -> Option<PlaneMap> {
    let mut map: Option<PlaneMap> = None;
    // (an emitter of the material, a ceiling light on the ceiling's, is drawn by its emission, not its albedo)
    for (t, tri) in d.triangles.iter().enumerate().filter(|(_, t)| t.material == material && t.light == NONE) {
        let sh = &d.shading[t];
        if sh.flags & SHADING_HAS_UVS == 0 {
            return None;
        }
        let (uv0, uv1, uv2) = (Vec2::from(sh.uv0), Vec2::from(sh.uv1), Vec2::from(sh.uv2));
        let (a, b) = (uv1 - uv0, uv2 - uv0);
        let det = a.x * b.y - a.y * b.x;
        if det.abs() < 1e-12 {
            continue; // a degenerate uv map says nothing
        }
        // [e1 e2] = [du dv] [a b]: [du dv] = [e1 e2] [a b]^-1.
        let (e1, e2) = (Vec3::from(tri.e1), Vec3::from(tri.e2));
        let du = (e1 * b.y - e2 * a.y) / det;
        let dv = (e2 * a.x - e1 * b.x) / det;
        let here = PlaneMap { origin: Vec3::from(tri.v0) - uv0.x * du - uv0.y * dv, du, dv };
        match &map {
            None => map = Some(here),
            Some(m) => {
                let size = m.du.length().max(m.dv.length()).max(1e-6);
                let close = |x: Vec3, y: Vec3| (x - y).length() <= 1e-4 * size.max(x.length());
                // The same map: the same steps, and this triangle's first vertex where the map puts its uv.
                if !close(m.du, du) || !close(m.dv, dv) || !close(m.point(uv0), Vec3::from(tri.v0)) {
                    return None;
                }
            }
        }
    }
    map
}

/// Whether an emitter lies on the plane (every vertex within `LIGHT_ON_PLANE` of it): a ceiling light.
fn lights_on(d: &SceneData, plane: &PlaneMap) -> bool {
    let n = plane.normal();
    let off = |p: Vec3| (p - plane.origin).dot(n).abs();
    d.triangles.iter().filter(|t| t.light != NONE).any(|t| {
        let v0 = Vec3::from(t.v0);
        [v0, v0 + Vec3::from(t.e1), v0 + Vec3::from(t.e2)].into_iter().all(|p| off(p) < LIGHT_ON_PLANE)
    })
}

/// Metres from a plane within which an emitter counts as on it (the pipeline hangs ceiling lights 1 cm below).
const LIGHT_ON_PLANE: f32 = 0.05;

/// Sums over axis-aligned boxes in O(1) (a summed-area table of one channel).
struct BoxSums {
    w: usize,
    h: usize,
    table: Vec<f64>,
}

impl BoxSums {
    fn new(values: &[f32], w: usize, h: usize) -> BoxSums {
        let mut table = vec![0.0f64; (w + 1) * (h + 1)];
        for y in 0..h {
            let mut row = 0.0;
            for x in 0..w {
                row += values[y * w + x] as f64;
                table[(y + 1) * (w + 1) + x + 1] = table[y * (w + 1) + x + 1] + row;
            }
        }
        BoxSums { w, h, table }
    }

    /// The sum over the box of radius r around (x, y), cut by the image.
    fn around(&self, x: usize, y: usize, r: usize) -> f64 {
        let (x0, y0) = (x.saturating_sub(r), y.saturating_sub(r));
        let (x1, y1) = ((x + r + 1).min(self.w), (y + r + 1).min(self.h));
        let at = |x: usize, y: usize| self.table[y * (self.w + 1) + x];
        at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0)
    }
}

/// The photo's albedo relative to the fitted constant over the segment at the detail size (the detail photo
/// over the blurred working render, resampled bilinearly: the shading is smooth on a plane) and the mask it
/// is defined on (1 where the working pixel under it is the segment's).
fn relative_albedo(
    detail: &Image,
    render: &[f32],
    mask: &[bool],
    (w, h): (usize, usize),
    k: f32,
) -> (Vec<f32>, Vec<f32>) {
    let (dw, dh) = (detail.width, detail.height);
    let working = |i: usize, n: usize| (((i as f32 + 0.5) / k) as usize).min(n - 1);
    let taps = |i: usize, n: usize| {
        let u = ((i as f32 + 0.5) / k - 0.5).clamp(0.0, (n - 1) as f32);
        let a = u.floor() as usize;
        (a, (a + 1).min(n - 1), u - a as f32)
    };
    let mut inside = vec![0.0f32; dw * dh];
    let mut albedo = vec![0.0f32; dw * dh * 3];
    for y in 0..dh {
        let (y0, y1, fy) = taps(y, h);
        for x in 0..dw {
            if !mask[working(y, h) * w + working(x, w)] {
                continue;
            }
            let (x0, x1, fx) = taps(x, w);
            let p = y * dw + x;
            inside[p] = 1.0;
            for c in 0..3 {
                let at = |yy: usize, xx: usize| render[3 * (yy * w + xx) + c];
                let s = (at(y0, x0) * (1.0 - fx) + at(y0, x1) * fx) * (1.0 - fy)
                    + (at(y1, x0) * (1.0 - fx) + at(y1, x1) * fx) * fy;
                albedo[3 * p + c] = detail.data[3 * p + c] / s.max(1e-4);
            }
        }
    }
    (albedo, inside)
}

/// Per texel (`tw` x `th`, RGB) and channel the relative albedo over its mean over the seen texels in the box of
/// radius `r` texels around it, clamped to 1/max_ratio..max_ratio; 1 where unseen.
fn pattern(raw: &[f32], seen: &[f32], (tw, th): (usize, usize), r: usize, max_ratio: f32) -> Vec<f32> {
    let count = BoxSums::new(seen, tw, th);
    let mut ratio = vec![1.0f32; tw * th * 3];
    for c in 0..3 {
        let channel: Vec<f32> = (0..tw * th).map(|p| raw[3 * p + c] * seen[p]).collect();
        let sums = BoxSums::new(&channel, tw, th);
        for y in 0..th {
            for x in 0..tw {
                let p = y * tw + x;
                if seen[p] == 0.0 {
                    continue;
                }
                let mean = sums.around(x, y, r) / count.around(x, y, r).max(1.0);
                let v = if mean > 1e-6 { (raw[3 * p + c] as f64 / mean) as f32 } else { 1.0 };
                ratio[3 * p + c] = v.clamp(1.0 / max_ratio, max_ratio);
            }
        }
    }
    ratio
}

/// Bilinear sample of the relative albedo at detail position (x, y) (continuous, pixel centres at +0.5) over the
/// segment's pixels only; None where none of the four is the segment's.
fn sample(albedo: &[f32], inside: &[f32], (dw, dh): (usize, usize), x: f32, y: f32) -> Option<Vec3> {
    let (u, v) = ((x - 0.5).clamp(0.0, (dw - 1) as f32), (y - 0.5).clamp(0.0, (dh - 1) as f32));
    let (x0, y0) = (u.floor() as usize, v.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(dw - 1), (y0 + 1).min(dh - 1));
    let (fx, fy) = (u - x0 as f32, v - y0 as f32);
    let (mut sum, mut weight) = (Vec3::ZERO, 0.0f32);
    for (xx, yy, wgt) in
        [(x0, y0, (1.0 - fx) * (1.0 - fy)), (x1, y0, fx * (1.0 - fy)), (x0, y1, (1.0 - fx) * fy), (x1, y1, fx * fy)]
    {
        let p = yy * dw + xx;
        if inside[p] > 0.0 && wgt > 0.0 {
            sum += wgt * Vec3::new(albedo[3 * p], albedo[3 * p + 1], albedo[3 * p + 2]);
            weight += wgt;
        }
    }
    (weight > 1e-6).then(|| sum / weight)
}

/// Steps 1-4 of the module on every segment; in place. `detail` as in `texture_surfaces` (the photo over the
/// working view at more pixels; the working photo when None).
pub fn apply_photo_textures(
    backend: &mut dyn Backend,
    scene: &mut Scene,
    photo: &[f32],
    detail: Option<&Image>,
    segments: &[Segment],
    opts: &PhotoTextureOptions,
) -> Result<Vec<PhotoTexture>> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let detail = detail_or_working("photo_textures", photo, detail, (w, h))?;
    let detail = detail.as_ref();
    let k = detail.width as f32 / w as f32;
    if segments.is_empty() {
        return Ok(vec![]);
    }
    let progress = crate::progress::activity(
        format!("photo textures: the fitted scene at {} spp, then the pattern onto each plane", opts.spp.max(1)),
        Some(segments.len()),
    );
    let data = SceneData::build(scene)?;
    let mut settings = scene.settings.clone();
    settings.spp = opts.spp.max(1);
    // Rendered at the first segment that qualifies (none may: a textured sofa part is not a plane).
    let mut render: Option<Vec<f32>> = None;
    let mut out = vec![];
    for seg in segments {
        progress.advance();
        let material = scene
            .materials
            .get(seg.material)
            .ok_or_else(|| Error::Invalid(format!("photo_textures: no material {}", seg.material)))?;
        if seg.mask.len() != w * h {
            return Err(Error::Invalid(format!("photo_textures: the mask of '{}' is not {w}x{h}", material.name)));
        }
        let mut entry = PhotoTexture {
            material: material.name.clone(),
            applied: false,
            decision: String::new(),
            size: [0, 0],
            texel: 0.0,
            seen: 0.0,
            pattern_rms: 0.0,
        };
        let Color::Constant(albedo) = material.albedo else {
            entry.decision = "already textured".into();
            out.push(entry);
            continue;
        };
        let Some(plane) = plane_map(&data, seg.material as u32) else {
            entry.decision = "not one plane with an affine uv map: homogeneous".into();
            out.push(entry);
            continue;
        };
        if lights_on(&data, &plane) {
            entry.decision = "lights lie on this plane (their near field on it is shading, not albedo, and the \
                              outlines of those the photo shows are refitted later): homogeneous"
                .into();
            out.push(entry);
            continue;
        }
        let mask = erode(&seg.mask.iter().map(|&m| m > 0.5).collect::<Vec<_>>(), w, h, opts.erode);
        // The uv under every segment pixel's centre, and its footprint (the larger step to the next pixel).
        let origin = Vec3::from(data.camera.origin);
        let uv_at = |x: f32, y: f32| plane.uv_on_ray(origin, camera_ray(&data.camera, x, y));
        let mut lo = Vec2::splat(f32::INFINITY);
        let mut hi = Vec2::splat(f32::NEG_INFINITY);
        let mut steps = vec![];
        for p in (0..w * h).filter(|&p| mask[p]) {
            let (x, y) = ((p % w) as f32 + 0.5, (p / w) as f32 + 0.5);
            let (Some(uv), Some(ux), Some(uy)) = (uv_at(x, y), uv_at(x + 1.0, y), uv_at(x, y + 1.0)) else {
                continue;
            };
            (lo, hi) = (lo.min(uv), hi.max(uv));
            steps.push((ux - uv).length().max((uy - uv).length()));
        }
        if steps.is_empty() {
            entry.decision = "no pixel of the segment shows the plane: homogeneous".into();
            out.push(entry);
            continue;
        }
        // Texels as fine as the finest tenth of the pixels (over the detail's k pixels each), within max_size.
        steps.sort_by(f32::total_cmp);
        let extent = hi - lo;
        let mut texel = (steps[steps.len() / 10] / k).max(1e-6);
        let longest = extent.x.max(extent.y) / texel + 4.0;
        if longest > opts.max_size as f32 {
            texel *= longest / opts.max_size as f32;
        }
        lo -= Vec2::splat(2.0 * texel);
        let (tw, th) =
            (((extent.x / texel).ceil() as usize + 4).max(2), ((extent.y / texel).ceil() as usize + 4).max(2));
        if render.is_none() {
            render = Some(blurred(&backend.render(&data, &settings, &|_, _| {})?.radiance, w, h));
        }
        let render = render.as_deref().expect("rendered above");
        let (relative, inside) = relative_albedo(detail, render, &mask, (w, h), k);
        let (dw, dh) = (detail.width, detail.height);
        let (mut raw, mut seen) = (vec![0.0f32; tw * th * 3], vec![0.0f32; tw * th]);
        for j in 0..th {
            for i in 0..tw {
                // Texel row 0 is the top (uv' y = 1): see render::texture.
                let uv = lo + Vec2::new((i as f32 + 0.5) * texel, (th as f32 - j as f32 - 0.5) * texel);
                let shown = project(&data.camera, plane.point(uv))
                    .filter(|&[x, y]| x >= 0.0 && y >= 0.0 && (x as usize) < w && (y as usize) < h)
                    .filter(|&[x, y]| mask[y as usize * w + x as usize])
                    .and_then(|[x, y]| sample(&relative, &inside, (dw, dh), x * k, y * k));
                if let Some(a) = shown {
                    let t = j * tw + i;
                    raw[3 * t..3 * t + 3].copy_from_slice(&a.to_array());
                    seen[t] = 1.0;
                }
            }
        }
        let r = (opts.window / (2.0 * texel)).round().max(1.0) as usize;
        let ratio = pattern(&raw, &seen, (tw, th), r, opts.max_ratio);
        let texels: Vec<f32> = ratio
            .chunks(3)
            .flat_map(|q| {
                let a = albedo * Vec3::from_slice(q);
                a.clamp(Vec3::splat(ALBEDO_RANGE.0), Vec3::splat(ALBEDO_RANGE.1)).to_array()
            })
            .collect();
        let lum = |t: usize| 0.2126 * ratio[3 * t] + 0.7152 * ratio[3 * t + 1] + 0.0722 * ratio[3 * t + 2] - 1.0;
        let shown: Vec<f32> = (0..tw * th).filter(|&t| seen[t] > 0.0).map(lum).collect();
        entry.pattern_rms = (shown.iter().map(|v| v * v).sum::<f32>() / shown.len().max(1) as f32).sqrt();
        let seen = shown.len();
        (entry.size, entry.texel, entry.seen) = ([tw as u32, th as u32], texel, seen as f32 / (tw * th) as f32);
        scene.textures.push(Texture { path: None, width: tw as u32, height: th as u32, channels: 3, texels });
        let extent = Vec2::new(tw as f32, th as f32) * texel;
        let material = &mut scene.materials[seg.material];
        material.albedo = Color::Texture(scene.textures.len() - 1);
        material.procedural = None;
        material.model_look = None;
        // uv' = (uv - lo) / extent: the box onto the texture.
        material.uv_transform = UvTransform { scale: Vec2::ONE / extent, rotation_deg: 0.0, offset: -lo / extent };
        entry.applied = true;
        entry.decision = format!(
            "the photo's pattern on {tw}x{th} texels of {:.1} mm (uv units x 1000), {:.0} % of them seen; its \
             ratio to the local mean {:.3} RMS",
            texel * 1000.0,
            100.0 * entry.seen,
            entry.pattern_rms
        );
        out.push(entry);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{rectangle_mesh, Camera, Material, Object, Pose, RenderSettings};
    use glam::{Mat4, Quat};

    fn rectangle(name: &str, material: usize, t: Vec3, rotation: Quat, uv_scale: f32) -> Object {
        let mut part = rectangle_mesh(2.0, 3.0);
        part.material = material;
        part.uvs.iter_mut().flatten().for_each(|uv| *uv *= uv_scale);
        Object {
            name: name.into(),
            parts: vec![part],
            pose: Pose { translation: t, rotation, scale: Vec3::ONE },
            emitter: None,
        }
    }

    #[test]
    fn a_plane_has_one_affine_uv_map_and_two_planes_have_none() {
        let turn = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2) * Quat::from_rotation_z(0.3);
        let floor = rectangle("floor", 0, Vec3::new(0.5, 0.0, -3.0), turn, 4.0);
        let scene = Scene {
            camera: Camera::from_matrix(Mat4::from_translation(Vec3::new(0.0, 1.5, 0.0)), 50.0, 32, 24),
            settings: RenderSettings { spp: 1, max_depth: 2, rr_depth: 2, seed: 0 },
            materials: vec![Material::diffuse("floor", Vec3::splat(0.5)), Material::diffuse("wall", Vec3::splat(0.5))],
            textures: vec![],
            objects: vec![
                floor.clone(),
                rectangle("wall_a", 1, Vec3::new(0.0, 1.0, -5.0), Quat::IDENTITY, 1.0),
                rectangle("wall_b", 1, Vec3::new(-2.0, 1.0, -3.0), Quat::from_rotation_y(1.0), 1.0),
            ],
            source: None,
            requires_grad: vec![],
        };
        let d = SceneData::build(&scene).unwrap();
        let map = plane_map(&d, 0).expect("the floor is one plane");
        // Every corner of the floor where the map puts its uv (the pose applied to the mesh's own corners).
        let part = &floor.parts[0];
        let to_world = Mat4::from_rotation_translation(floor.pose.rotation, floor.pose.translation);
        for (p, uv) in part.positions.iter().zip(part.uvs.as_ref().unwrap()) {
            let want = to_world.transform_point3(*p);
            let got = map.point(*uv);
            assert!((got - want).length() < 1e-4, "corner {want} mapped to {got}");
        }
        // And back: a ray through the plane meets it at the uv of the point it hits.
        let uv = Vec2::new(1.3, 5.1);
        let o = Vec3::new(0.2, 1.5, 0.1);
        let hit = map.uv_on_ray(o, (map.point(uv) - o).normalize()).unwrap();
        assert!((hit - uv).length() < 1e-4, "{hit} for {uv}");
        assert!(map.uv_on_ray(o, -(map.point(uv) - o).normalize()).is_none(), "behind the ray");
        assert_eq!(plane_map(&d, 1), None, "the walls' material is on two planes");
    }

    #[test]
    fn box_sums_equal_the_direct_sums() {
        let (w, h) = (7, 5);
        let v: Vec<f32> = (0..w * h).map(|i| ((i * 37) % 11) as f32).collect();
        let s = BoxSums::new(&v, w, h);
        for (x, y, r) in [(0usize, 0usize, 1usize), (3, 2, 2), (6, 4, 3), (2, 1, 0)] {
            let mut direct = 0.0;
            for yy in y.saturating_sub(r)..(y + r + 1).min(h) {
                for xx in x.saturating_sub(r)..(x + r + 1).min(w) {
                    direct += v[yy * w + xx] as f64;
                }
            }
            assert!((s.around(x, y, r) - direct).abs() < 1e-9, "({x}, {y}, {r})");
        }
    }
}
