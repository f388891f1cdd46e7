//! Where the lights are and how large (after `fit_lights` kept the ones the photo needs): candidates sit on a
//! grid, the real lights do not, and a light 40 cm off throws its shading on the wrong wall, which the albedos
//! then absorb. A pattern search moves each light in its own plane (its local x and y: along the ceiling for a
//! ceiling light, along the wall for a window) and grows or shrinks it, keeping a move when the non-negative
//! least-squares fit of all lights' unit renders to the photo (`light_fit`) gets better; the step halves when no
//! move helps, down to `min_step`. Before that, two lights side by side may become one (`merge_neighbours`).
//! Rendering is linear in radiance, so each trial costs one unit render of the moved light; trials share one
//! seed, so their noise is common and cancels in the comparison. Lights stay
//! inside the room's box and within `size_range` of their start. A window the photo shows stays where its
//! pixels put it (`is_visible_window`): its own pixels are clipped and left out of the fit, so nothing held it
//! (real room01's moved 10 cm up, its render a band of white over the wall above it). A ceiling light the frame
//! cuts (`is_edge_ceiling_light`) moves only out of view: besides the moves above, each of its sides may move
//! out or in by the step, and a move is kept only where its part in view still covers the photo's light pixels
//! and no others (`light_view`). A window the photo shows that the frame cuts moves so too, its part in view
//! kept on the photo's window pixels: it lights the room through all of itself, and held to the sliver in view
//! (real room06's 1.2 x 1.0 m window as 0.24 x 0.61 m at three times its radiance, with the true materials
//! given) it lit the wall beside it and left the far walls dark.

use super::ceiling_panels::light_pixels;
use super::light_fit::{nnls_fit, unit_render, unit_renders, FitTarget, LightFitOptions};
use super::light_view::{keeps_view, local_bounds, pixels_covered};
use super::{is_edge_ceiling_light, is_visible_light, is_visible_window};
use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::render::scene_data::luminance;
use crate::scene::Scene;
use glam::Vec3;

const MAX_PASSES: usize = 3;

/// Two lights are neighbours (`merge_neighbours`) when their centres lie within this many times the sum of
/// their half-diagonals: the grid's side-by-side candidates (1.5 m apart, half-diagonals 0.8 m) are, diagonal
/// ones (2.0 m apart) are not.
const NEIGHBOUR_REACH: f32 = 1.2;

/// A light the frame cuts may cover this fraction of its light pixels more wrongly than where its move started
/// (pixels on its sides' boundary).
const VIEW_TOLERANCE: f32 = 0.02;

#[derive(Clone, Debug)]
pub struct LightPlacementOptions {
    /// First step (metres) and the step below which the search ends.
    pub step: f32,
    pub min_step: f32,
    /// Each size move scales the light by this factor (or its inverse) in its plane...
    pub size_factor: f32,
    /// ...within this range of its start (a light shrunk to a point lights the ceiling next to it with
    /// fireflies; one grown past its cell is two lights).
    pub size_range: (f32, f32),
    /// Two lights side by side in one plane become one at their power-weighted centre when that raises the
    /// fit's relative error by less than this (`merge_neighbours`; 0: never).
    pub merge_threshold: f32,
    /// A light the frame cuts grows out of view up to this side (metres; its start is its part in view, which
    /// `size_range` does not bound)...
    pub edge_max_side: f32,
    /// ...a window up to this one, its part in view kept on the photo's window pixels where given (the
    /// camera's size; else on the pixels it covered at the start, which the frame's edge may cut short).
    pub window_max_side: f32,
    pub window_pixels: Vec<bool>,
    /// The unit renders: samples per pixel, downsampling, path length. They are made at the size the fit
    /// compares (`light_fit::unit_render`: `spp` per reduced pixel, not per photo pixel).
    pub render: LightFitOptions,
}

impl Default for LightPlacementOptions {
    fn default() -> Self {
        LightPlacementOptions {
            step: 0.4,
            min_step: 0.1,
            size_factor: 1.25,
            size_range: (0.5, 2.0),
            merge_threshold: 0.0,
            edge_max_side: 1.2,
            window_max_side: 2.0,
            window_pixels: vec![],
            render: LightFitOptions { spp: 64, ..Default::default() },
        }
    }
}

/// The room's box (`scene::room_box`) widened by 2 cm, when the scene has the room surfaces.
pub(super) fn room_box(scene: &Scene) -> Option<(Vec3, Vec3)> {
    crate::scene::room_box(scene).map(|(lo, hi)| (lo - 0.02, hi + 0.02))
}

/// Whether every vertex of object `i` lies inside the room (always, without a room): a light moved through
/// a wall lights the world behind it, or leaks through the seam.
fn inside(scene: &Scene, i: usize, room: Option<(Vec3, Vec3)>) -> bool {
    let Some((lo, hi)) = room else { return true };
    crate::scene::object_bounds(scene, i).is_none_or(|(a, b)| a.cmpge(lo).all() && b.cmple(hi).all())
}

/// A move of one light and the fit it gives: its unit render, every light's radiance, the squared error.
struct Trial {
    translation: Vec3,
    scale: Vec3,
    image: Vec<f32>,
    radiance: Vec<[f32; 3]>,
    err: f64,
}

/// What the search did.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LightPlacement {
    pub names: Vec<String>,
    /// Per light, how far it moved (metres) and its size over the start's.
    pub moved_m: Vec<f32>,
    pub size_ratio: Vec<f32>,
    /// The fit's relative RMS error before and after.
    pub relative_rms_before: f32,
    pub relative_rms_after: f32,
    pub unit_renders: usize,
    /// Lights merged into another (removed, kept) and the relative error with both and after the merge.
    pub merged: Vec<Merge>,
}

/// One light merged into its neighbour.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Merge {
    pub removed: String,
    pub into: String,
    pub relative_rms_before: f32,
    pub relative_rms_after: f32,
}

/// Moves and sizes every emitter of `scene` (see the module) and sets their radiances to the final fit; with
/// `segments` (surface masks, may be empty) each surface's albedo is free in that fit (`light_fit`).
pub fn refine_light_placement(
    backend: &mut dyn Backend,
    scene: &mut Scene,
    photo: &[f32],
    segments: &[Vec<f32>],
    opts: &LightPlacementOptions,
) -> Result<LightPlacement> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    if photo.len() != w * h * 3 {
        return Err(Error::Invalid(format!("light placement: the photo is not the camera's {w}x{h} RGB")));
    }
    let (lo, hi) = opts.size_range;
    if !(opts.step > 0.0 && opts.min_step > 0.0 && opts.size_factor > 1.0 && lo > 0.0 && lo <= 1.0 && hi >= 1.0) {
        return Err(Error::Invalid(
            "light placement: step and min_step must be positive, size_factor above 1, min_size in (0, 1] and \
             max_size at least 1"
                .into(),
        ));
    }
    let lights: Vec<usize> = (0..scene.objects.len()).filter(|&i| scene.objects[i].emitter.is_some()).collect();
    let room = room_box(scene);
    let start: Vec<(Vec3, Vec3)> =
        lights.iter().map(|&i| (scene.objects[i].pose.translation, scene.objects[i].pose.scale)).collect();
    let ro = &opts.render;
    let target = FitTarget::new(photo, w, h, ro.downsample)
        .with_segments(segments, w, h, ro.downsample)
        .with_agreement(&ro.agreement, w, h, ro.downsample)
        .white_lights(ro.white)
        .tint_prior(ro.tint_prior);
    let norm = target.norm();
    let rel = |err: f64| (err / norm).sqrt() as f32;
    let progress = crate::progress::activity(format!("placing {} lights, step {:.2} m", lights.len(), opts.step), None);
    let basis = unit_renders(backend, scene, &lights, ro, || {})?;
    let mut render = |scene: &Scene, li: usize| unit_render(backend, scene, li, ro);
    let active: Vec<usize> = (0..lights.len()).collect();
    let (rad, err) = nnls_fit(&basis, &target, &active);
    let mut fit = Fit { basis, rad, err, active };
    let mut renders = lights.len();
    let before = rel(err);
    let mut merged = vec![];
    if opts.merge_threshold > 0.0 {
        let trials;
        (merged, trials) =
            merge_neighbours(scene, &lights, &mut fit, &mut render, &target, &rel, opts.merge_threshold)?;
        renders += trials;
    }
    // The lights the frame cuts, with the pixels each covered at the start, and what says where they show: for
    // a ceiling light the photo's light pixels, for a window (whose pixels need not be white) the photo's
    // window pixels, or without them those it covered.
    let bright = light_pixels(photo);
    let views: Vec<Option<Vec<bool>>> = lights
        .iter()
        .map(|&i| {
            let o = &scene.objects[i];
            let edge = is_edge_ceiling_light(&o.name);
            (edge || is_visible_window(&o.name))
                .then(|| pixels_covered(scene, o))
                .filter(|covered| edge || touches_frame(covered, w, h))
        })
        .collect();
    let cut_window = |k: usize| views[k].is_some() && is_visible_window(&scene.objects[lights[k]].name);
    let cut_windows: Vec<bool> = (0..lights.len()).map(cut_window).collect();
    let (mut step, mut passes) = (opts.step, 0);
    while step >= opts.min_step && !lights.is_empty() {
        let mut improved = false;
        passes += 1;
        for (k, &li) in lights.iter().enumerate() {
            // A light the photo shows stays where it is, unless the frame cuts it.
            let held = is_visible_light(&scene.objects[li].name) && views[k].is_none();
            if held || !fit.active.contains(&k) {
                continue;
            }
            let pose = scene.objects[li].pose;
            let (ax, ay) = (pose.rotation * Vec3::X, pose.rotation * Vec3::Y);
            let in_plane = |f: f32| Vec3::new(f, f, 1.0);
            let mut trials = vec![
                (pose.translation + step * ax, pose.scale),
                (pose.translation - step * ax, pose.scale),
                (pose.translation + step * ay, pose.scale),
                (pose.translation - step * ay, pose.scale),
                (pose.translation, pose.scale * in_plane(opts.size_factor)),
                (pose.translation, pose.scale * in_plane(1.0 / opts.size_factor)),
            ];
            let extent = local_extent(&scene.objects[li]);
            if views[k].is_some() {
                trials.extend(side_moves(pose.translation, pose.scale, (ax, ay), extent, step));
            }
            let mut best: Option<Trial> = None;
            let size_ok = |s: Vec3| match views[k] {
                // Sides from 5 cm (a patch's least) to the most it may grow out of view.
                Some(_) => (0..2).all(|a| {
                    let side = extent[a] * s[a];
                    let most = if cut_windows[k] { opts.window_max_side } else { opts.edge_max_side };
                    side >= 0.05 - 1e-4 && side <= most.max(extent[a] * start[k].1[a]) + 1e-4
                }),
                None => {
                    let r = s.x / start[k].1.x;
                    r >= opts.size_range.0 - 1e-4 && r <= opts.size_range.1 + 1e-4
                }
            };
            for (t, s) in trials.into_iter().filter(|(_, s)| size_ok(*s)) {
                scene.objects[li].pose.translation = t;
                scene.objects[li].pose.scale = s;
                if !inside(scene, li, room) {
                    continue;
                }
                if let Some(view) = &views[k] {
                    let windows = (opts.window_pixels.len() == w * h).then_some(&opts.window_pixels);
                    let shows = if cut_windows[k] { windows.unwrap_or(view) } else { &bright };
                    if !keeps_view(view, &pixels_covered(scene, &scene.objects[li]), shows, VIEW_TOLERANCE) {
                        continue;
                    }
                }
                let img = render(scene, li)?;
                renders += 1;
                progress.set(renders, Some(format!("unit renders, step {step:.2} m")));
                let mut b = fit.basis.clone();
                b[k] = img;
                let (r, e) = nnls_fit(&b, &target, &fit.active);
                if e < best.as_ref().map_or(fit.err, |x| x.err) {
                    best = Some(Trial { translation: t, scale: s, image: b.swap_remove(k), radiance: r, err: e });
                }
            }
            match best {
                Some(b) => {
                    (scene.objects[li].pose.translation, scene.objects[li].pose.scale) = (b.translation, b.scale);
                    (fit.basis[k], fit.rad, fit.err) = (b.image, b.radiance, b.err);
                    improved = true;
                }
                None => scene.objects[li].pose = pose,
            }
        }
        // At most MAX_PASSES passes at one step: a light still drifting by then follows noise.
        if !improved || passes >= MAX_PASSES {
            (step, passes) = (step / 2.0, 0);
        }
    }
    for &k in &fit.active {
        if let Some(e) = scene.objects[lights[k]].emitter.as_mut() {
            e.radiance = Vec3::from(fit.rad[k]).max(Vec3::splat(1e-6));
        }
    }
    let kept = &fit.active;
    let result = LightPlacement {
        names: kept.iter().map(|&k| scene.objects[lights[k]].name.clone()).collect(),
        moved_m: kept.iter().map(|&k| (scene.objects[lights[k]].pose.translation - start[k].0).length()).collect(),
        size_ratio: kept.iter().map(|&k| scene.objects[lights[k]].pose.scale.x / start[k].1.x).collect(),
        relative_rms_before: before,
        relative_rms_after: rel(fit.err),
        unit_renders: renders,
        merged,
    };
    let gone: Vec<String> = result.merged.iter().map(|m| m.removed.clone()).collect();
    scene.objects.retain(|o| !gone.contains(&o.name));
    Ok(result)
}

/// Whether any of the pixels `covered` (a `w` x `h` image) lies on the image's border: the frame cuts the light.
fn touches_frame(covered: &[bool], w: usize, h: usize) -> bool {
    (0..w * h).any(|p| covered[p] && (p % w == 0 || p % w == w - 1 || p / w == 0 || p / w == h - 1))
}

/// An object's size along its local x and y (before its pose's scale).
fn local_extent(o: &crate::scene::Object) -> [f32; 2] {
    let (lo, hi) = local_bounds(o);
    [(hi.x - lo.x).max(0.0), (hi.y - lo.y).max(0.0)]
}

/// Each side of a rectangle light (centred on its origin, `extent` before `scale`, local axes `axes` in the
/// world) moved out by `step` and in by `step`, the opposite side staying: (translation, scale) per move.
fn side_moves(translation: Vec3, scale: Vec3, axes: (Vec3, Vec3), extent: [f32; 2], step: f32) -> Vec<(Vec3, Vec3)> {
    let mut moves = vec![];
    for (a, axis) in [axes.0, axes.1].into_iter().enumerate() {
        let side = extent[a] * scale[a];
        if side <= 0.0 {
            continue;
        }
        for sign in [1.0f32, -1.0] {
            for delta in [step, -step] {
                let mut s = scale;
                s[a] = scale[a] * (side + delta) / side;
                moves.push((translation + axis * (sign * delta / 2.0), s));
            }
        }
    }
    moves
}

/// The lights' unit renders, the radiances of the fit and its squared error, over the lights still in it.
struct Fit {
    basis: Vec<Vec<f32>>,
    rad: Vec<[f32; 3]>,
    err: f64,
    active: Vec<usize>,
}

/// A merge tried: light `drop` removed, light `keep` moved to `centre` (its unit render `image` there), and the
/// fit that gives.
struct MergeTrial {
    keep: usize,
    drop: usize,
    centre: Vec3,
    image: Vec<f32>,
    radiance: Vec<[f32; 3]>,
    err: f64,
}

/// The area of an object's triangles in the world.
fn world_area(o: &crate::scene::Object) -> f32 {
    let m = o.pose.matrix();
    let mut area = 0.0;
    for p in &o.parts {
        for t in &p.indices {
            let [a, b, c] = t.map(|i| m.transform_point3(p.positions[i as usize]));
            area += 0.5 * (b - a).cross(c - a).length();
        }
    }
    area
}

/// The largest distance of an object's vertices from its origin, in the world.
fn reach(o: &crate::scene::Object) -> f32 {
    let m = o.pose.matrix();
    o.parts
        .iter()
        .flat_map(|p| &p.positions)
        .map(|v| (m.transform_point3(*v) - o.pose.translation).length())
        .fold(0.0, f32::max)
}

/// A real light between two grid cells is fitted as two candidates, one on each side (the known-geometry
/// test's brighter light, 0.6 m wide, as two panels 1 m apart straddling it), and the pattern search moves
/// each a step at a time without bringing them together. So two lights in one plane whose panels (nearly)
/// touch are tried as one: the brighter moved to their centre weighted by power (radiance times area), the
/// other removed; kept when the fit's relative error rises by less than `threshold` (the form of
/// `fit_lights`' removal rule, with a threshold of its own: a merge that costs as much as a removal joins two
/// real lights). The best such merge first, until none is kept. Returns the merges and the unit renders they
/// took.
fn merge_neighbours<R, E>(
    scene: &mut Scene,
    lights: &[usize],
    fit: &mut Fit,
    render: &mut R,
    target: &FitTarget,
    rel: &E,
    threshold: f32,
) -> Result<(Vec<Merge>, usize)>
where
    R: FnMut(&Scene, usize) -> Result<Vec<f32>>,
    E: Fn(f64) -> f32,
{
    let (mut merges, mut renders) = (vec![], 0);
    loop {
        // A light the photo shows, or shows in part, stays on its pixels.
        let movable: Vec<usize> = fit
            .active
            .iter()
            .copied()
            .filter(|&k| {
                let name = &scene.objects[lights[k]].name;
                !is_visible_light(name) && !is_edge_ceiling_light(name)
            })
            .collect();
        let power: Vec<f32> = (0..lights.len())
            .map(|k| {
                let r = fit.rad[k];
                world_area(&scene.objects[lights[k]]) * luminance(Vec3::from(r)).max(0.0)
            })
            .collect();
        let mut best: Option<MergeTrial> = None;
        for (x, &a) in movable.iter().enumerate() {
            for &b in &movable[x + 1..] {
                let (oa, ob) = (&scene.objects[lights[a]], &scene.objects[lights[b]]);
                let normal = oa.pose.rotation * Vec3::Z;
                let (ta, tb) = (oa.pose.translation, ob.pose.translation);
                let same_plane =
                    oa.pose.rotation.dot(ob.pose.rotation).abs() > 0.9999 && (tb - ta).dot(normal).abs() < 0.01;
                if !same_plane || (tb - ta).length() > NEIGHBOUR_REACH * (reach(oa) + reach(ob)) {
                    continue;
                }
                let (pa, pb) = (power[a], power[b]);
                if pa + pb <= 0.0 {
                    continue;
                }
                // The brighter one stays, at the centre.
                let (keep, drop) = if pa >= pb { (a, b) } else { (b, a) };
                let centre = (ta * pa + tb * pb) / (pa + pb);
                let was = scene.objects[lights[keep]].pose.translation;
                scene.objects[lights[keep]].pose.translation = centre;
                let img = render(scene, lights[keep]);
                renders += 1;
                scene.objects[lights[keep]].pose.translation = was;
                let mut basis = fit.basis.clone();
                basis[keep] = img?;
                let rest: Vec<usize> = fit.active.iter().copied().filter(|&k| k != drop).collect();
                let (r, e) = nnls_fit(&basis, target, &rest);
                if rel(e) - rel(fit.err) < threshold && best.as_ref().is_none_or(|b| e < b.err) {
                    best = Some(MergeTrial { keep, drop, centre, image: basis.swap_remove(keep), radiance: r, err: e });
                }
            }
        }
        let Some(MergeTrial { keep, drop, centre, image, radiance: r, err: e }) = best else { break };
        merges.push(Merge {
            removed: scene.objects[lights[drop]].name.clone(),
            into: scene.objects[lights[keep]].name.clone(),
            relative_rms_before: rel(fit.err),
            relative_rms_after: rel(e),
        });
        scene.objects[lights[keep]].pose.translation = centre;
        fit.basis[keep] = image;
        (fit.rad, fit.err) = (r, e);
        fit.active.retain(|&k| k != drop);
    }
    Ok((merges, renders))
}
