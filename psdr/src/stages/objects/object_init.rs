//! The object stage's initialisation and weight-free retrieval (PSDR-Room, "Object stage"): every furniture
//! instance big enough to matter gets a model and a pose. Split pieces of one object are merged first
//! (`instance_merge`). The instance's eroded mask is back-projected with the depth; its centre on the floor is
//! the median of the points, its height the top of the points, and what it stands on is decided against the
//! other instances (`object_support`). The class's models closest in real size and outline (and appearance,
//! with an image encoder: `AppearanceCue`) are rendered at that place over a yaw sweep and scored by mask IoU
//! against the instance (pixels of other instances, possible occluders, left out) less the depth misfit; the
//! leaders are searched again finer (`pose_search`), near-ties broken by the wall prior. The best wins and the
//! runners-up are kept so a user can swap. A class without models gets a box of the observed size, and says so.

use super::instance_merge::merge_split_instances;
use super::object_support::{
    back, back_to_the_wall, base_height, half_depth, hides_bottom, wall_behind, wall_below, walls_of, Extent, FoundPose,
};
use super::pose_search::{
    align, distinct_yaws, footprint_size, percentile, pose_at, score, sweep_target, PoseRenderer, PoseSearch,
};
use crate::base::Image;
use crate::base::{erode, surface_points, Intrinsics};
use crate::db::{best_view_iou, ModelEntry, ModelSet, Silhouette};
use crate::scene::{box_mesh, MeshPart, Object, Scene};
use crate::vision::{cosine, embed, load_photo, ClassKind, Instances, OnnxModel};
use glam::Vec3;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Knobs of the initialisation.
#[derive(Clone, Debug)]
pub struct ObjectInitOptions {
    /// Instances with fewer pixels are skipped (model no more than the photo shows).
    pub min_pixels: usize,
    /// An instance whose class the database lacks becomes a box of its observed size (else it is skipped;
    /// `missing_classes` lets a run stop before any work instead).
    pub placeholders: bool,
    pub erode: usize,
    /// Yaw angles tried per model (evenly spaced over 360 degrees).
    pub yaws: usize,
    /// Width of the sweep's mask renders (the photo is compared at this size).
    pub sweep_width: u32,
    /// Alternatives kept per instance.
    pub top_k: usize,
    /// Weight of the relative depth misfit against the IoU in the sweep's score.
    pub depth_weight: f32,
    /// Models of the class rendered in the sweep, the closest in real size first.
    pub max_candidates: usize,
    /// Weight of |ln scale| (how far a model must be scaled to the observed height) in the score.
    pub scale_weight: f32,
    /// Leaders of the sweep compared again at twice its resolution.
    pub finalists: usize,
    /// The finalists' search moves the scale by this factor first (1 +- it; 0: the scale stays as the visible
    /// points' height set it).
    pub scale_step: f32,
    /// Weight of the outline mismatch (1 - silhouette IoU) against the size misfit when a class has more
    /// than `max_candidates` models.
    pub silhouette_weight: f32,
    /// Split pieces of one object are merged when this many rows or columns cross from one to the other
    /// through a single nearer instance (0: never merge; `instance_merge`).
    pub merge_bridges: usize,
    /// ... and the depths on both sides of the occluder agree within this fraction.
    pub merge_depth_tolerance: f32,
    /// ...and span at least this share of the smaller piece across them.
    pub merge_min_span: f32,
    /// Poses scoring within this of the best are told apart by the wall prior: an object standing against a
    /// wall turns its back to it (a cabinet turned round looks the same but for a handle under a pixel).
    pub wall_tie: f32,
    /// The whole mask's top over the top of the shrunk mask's points by more than this factor: the models are
    /// ranked and tried at both heights (a thin top the shrinking loses; infinite: the points' top alone).
    pub thin_top: f32,
    /// How much nearer the camera (metres of depth) an instance right below another's bottom pixels must be
    /// to hide that bottom rather than hold it up (`object_support::hides_bottom`): a table's top a pixel
    /// below a lamp's base is 1-3 cm nearer at 3 m (looking down at it), an armchair in front of a shelf 0.3 m
    /// or more.
    pub occluder_depth: f32,
}

impl Default for ObjectInitOptions {
    fn default() -> Self {
        ObjectInitOptions {
            min_pixels: 100,
            placeholders: false,
            erode: 1,
            yaws: 16,
            sweep_width: 128,
            top_k: 5,
            depth_weight: 1.0,
            max_candidates: 8,
            scale_weight: 1.0,
            finalists: 5,
            scale_step: 0.08,
            silhouette_weight: 1.0,
            merge_bridges: 3,
            merge_depth_tolerance: 0.1,
            merge_min_span: 0.25,
            wall_tie: 0.02,
            occluder_depth: 0.1,
            thin_top: 1.1,
        }
    }
}

/// A model and how well it fitted.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Candidate {
    pub model: String,
    pub path: Option<PathBuf>,
    pub licence: String,
    pub yaw_deg: f32,
    pub iou: f32,
    pub score: f32,
    /// The best IoU of the instance's outline with the model's silhouette views, where outlines ranked the
    /// class.
    pub outline_iou: Option<f32>,
    /// Cosine similarity of the instance's crop and the model's thumbnail under the appearance encoder.
    pub embedding_similarity: Option<f32>,
}

/// One instance's placement: the scene object's name, its pose, the chosen model and the alternatives.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ObjectPlacement {
    pub instance: u16,
    pub class: String,
    pub name: String,
    pub translation: [f32; 3],
    pub yaw_deg: f32,
    pub scale: f32,
    pub chosen: Candidate,
    pub alternatives: Vec<Candidate>,
    pub points: usize,
    /// "floor", or "raised" (its lowest points are above the floor: on another object, a wall, hanging).
    pub support: String,
    /// Instances merged into this one (split pieces of the object); its mask is theirs and `instance`'s.
    pub merged: Vec<u16>,
    /// The wall it stands with its back to (within 50 cm), if any.
    pub against_wall: Option<String>,
}

/// An instance that got no object, and why.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SkippedInstance {
    pub instance: u16,
    pub class: String,
    pub reason: String,
}

/// The length of a side from the coordinates of the points seen along it: their 10-90 % span (robust to
/// stray depth at the outline), over the 0.8 of the side that span covers when the points spread evenly along
/// it. The span alone put real room00's 2.07 m sofa at 1.58 m, which ranked its true model tenth by size
/// and out of the sweep's eight.
fn side_from_points(values: &mut [f32]) -> f32 {
    (percentile(values, 0.9) - percentile(values, 0.1)) / 0.8
}

/// The fraction of instance `id`'s outline pixels that border another furniture or object instance nearer
/// the camera: how much of its silhouette others may hide.
fn hidden_outline(inst: &Instances, depth: &[f32], id: u16) -> f32 {
    let (w, h) = (inst.width, inst.height);
    let furniture = |v: u16| inst.instances.iter().any(|i| i.id == v && i.kind != ClassKind::Structure);
    let (mut outline, mut hidden) = (0usize, 0usize);
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            if inst.ids[p] != id {
                continue;
            }
            let neighbours = [
                (x > 0).then(|| p - 1),
                (x + 1 < w).then(|| p + 1),
                (y > 0).then(|| p - w),
                (y + 1 < h).then(|| p + w),
            ];
            let outside: Vec<usize> = neighbours.into_iter().flatten().filter(|&q| inst.ids[q] != id).collect();
            if outside.is_empty() {
                continue;
            }
            outline += 1;
            let nearer = |q: usize| depth[q] > 0.0 && depth[q] < depth[p] && furniture(inst.ids[q]);
            hidden += outside.into_iter().any(nearer) as usize;
        }
    }
    if outline == 0 {
        0.0
    } else {
        hidden as f32 / outline as f32
    }
}

/// Whether instance `id` reaches the image's edge (so part of it may be out of frame).
fn touches_border(inst: &Instances, id: u16) -> bool {
    let (w, h) = (inst.width, inst.height);
    (0..w).any(|x| inst.ids[x] == id || inst.ids[(h - 1) * w + x] == id)
        || (0..h).any(|y| inst.ids[y * w] == id || inst.ids[y * w + w - 1] == id)
}

/// Places every furniture instance of `inst` in `scene` (whose camera is the photo's and whose `floor`
/// object, if any, gives the floor height). Returns the objects to add with their placements, and the skipped
/// instances with reasons.
pub fn init_objects(
    scene: &Scene,
    depth: &[f32],
    inst: &Instances,
    models: &ModelSet,
    opts: &ObjectInitOptions,
) -> (Vec<(ObjectPlacement, Object)>, Vec<SkippedInstance>) {
    init_objects_with(scene, depth, inst, models, opts, None)
}

/// The classes of `inst`'s furniture instances (of at least `min_pixels`) that `models` has no model of, each
/// with its instances' ids: the object stage could place nothing real for them.
pub fn missing_classes(inst: &Instances, models: &ModelSet, min_pixels: usize) -> BTreeMap<String, Vec<u16>> {
    let mut out: BTreeMap<String, Vec<u16>> = BTreeMap::new();
    for i in inst.instances.iter().filter(|i| i.kind == ClassKind::Furniture && i.pixels >= min_pixels) {
        if models.of_class(&i.class).is_empty() {
            out.entry(i.class.clone()).or_default().push(i.id);
        }
    }
    out
}

/// An image encoder (a CLIP-style embedding model) that compares each instance's crop of the photo with the
/// candidates' thumbnails, as PSDR-Room retrieves with CLIP: `weight` x cosine similarity is added to a
/// candidate's rank before the sweep.
pub struct AppearanceCue<'a> {
    /// The photo, linear RGB, at the instances' size.
    pub photo: &'a Image,
    pub model: &'a mut OnnxModel,
    pub weight: f32,
}

/// The instance's pixels of `photo`, cropped to their bounds, everything else white (as a thumbnail's
/// ground).
fn instance_crop(photo: &Image, inst: &Instances, id: u16) -> Option<Image> {
    let (w, h) = (inst.width, inst.height);
    if photo.width != w || photo.height != h || photo.channels != 3 {
        return None;
    }
    let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
    for p in (0..w * h).filter(|&p| inst.ids[p] == id) {
        (x0, y0, x1, y1) = (x0.min(p % w), y0.min(p / w), x1.max(p % w), y1.max(p / w));
    }
    if x0 > x1 {
        return None;
    }
    let (cw, ch) = (x1 - x0 + 1, y1 - y0 + 1);
    let data = (0..cw * ch)
        .flat_map(|q| {
            let p = (y0 + q / cw) * w + x0 + q % cw;
            let inside = inst.ids[p] == id;
            [0, 1, 2].map(|c| if inside { photo.data[p * 3 + c] } else { 1.0 })
        })
        .collect();
    Image::new(cw, ch, 3, data).ok()
}

/// `init_objects`, with the candidates of each instance also ranked by `appearance` when given.
pub fn init_objects_with(
    scene: &Scene,
    depth: &[f32],
    inst: &Instances,
    models: &ModelSet,
    opts: &ObjectInitOptions,
    mut appearance: Option<AppearanceCue>,
) -> (Vec<(ObjectPlacement, Object)>, Vec<SkippedInstance>) {
    // Split pieces first: one object, one model.
    let (merged_inst, merges) = if opts.merge_bridges > 0 {
        merge_split_instances(inst, depth, opts.merge_bridges, opts.merge_depth_tolerance, opts.merge_min_span)
    } else {
        (inst.clone(), vec![])
    };
    let inst = &merged_inst;
    let walls = walls_of(scene);
    // Thumbnail embeddings, computed once per model.
    let mut thumbnail_embeddings: std::collections::HashMap<PathBuf, Option<Vec<f32>>> = Default::default();
    let cam = &scene.camera;
    let (w, h) = (inst.width, inst.height);
    let k = Intrinsics::new(w, h, cam.fov_y_deg);
    let (right, up, fwd) = (cam.right(), cam.up, cam.forward);
    let to_world = |p: Vec3| cam.origin + right * p.x + up * p.y + fwd * p.z;
    let floor_y = scene.objects.iter().find(|o| o.name == "floor").map_or(0.0, |o| o.pose.translation.y);
    let sw = opts.sweep_width.min(w as u32).max(8);
    let sh = ((sw as usize * h) / w).max(6) as u32;
    let mut placed = vec![];
    let mut skipped: Vec<SkippedInstance> = merges
        .iter()
        .map(|m| SkippedInstance {
            instance: m.merged,
            class: m.class.clone(),
            reason: format!(
                "merged into instance {}: split pieces of one object ({} rows or columns cross instance {} in front \
                 of both)",
                m.into, m.bridges, m.occluder
            ),
        })
        .collect();
    // Every furniture instance's points first: support is decided between instances.
    let points_of = |id: u16| -> Vec<Vec3> {
        let mask: Vec<bool> = inst.ids.iter().map(|&v| v == id).collect();
        surface_points(depth, &erode(&mask, w, h, opts.erode), &k).into_iter().map(|s| to_world(s.p)).collect()
    };
    let extent = |pts: &[Vec3]| -> Extent {
        let (mut xs, mut ys, mut zs): (Vec<f32>, Vec<f32>, Vec<f32>) =
            (pts.iter().map(|p| p.x).collect(), pts.iter().map(|p| p.y).collect(), pts.iter().map(|p| p.z).collect());
        Extent {
            lo: Vec3::new(percentile(&mut xs, 0.1), 0.0, percentile(&mut zs, 0.1)),
            hi: Vec3::new(percentile(&mut xs, 0.9), 0.0, percentile(&mut zs, 0.9)),
            bottom: percentile(&mut ys, 0.02),
            top: percentile(&mut ys, 0.99),
        }
    };
    let furniture: Vec<(u16, Extent)> = inst
        .instances
        .iter()
        .filter(|i| i.kind == ClassKind::Furniture)
        .filter_map(|i| {
            let pts = points_of(i.id);
            (pts.len() >= 10).then(|| (i.id, extent(&pts)))
        })
        .collect();
    let objects: Vec<&crate::vision::Instance> =
        inst.instances.iter().filter(|i| i.kind != ClassKind::Structure).collect();
    let progress = crate::progress::activity("models retrieved and posed per instance", Some(objects.len()));
    for i in objects {
        progress.advance();
        let skip = |reason: String| SkippedInstance { instance: i.id, class: i.class.clone(), reason };
        if i.kind == ClassKind::Opening {
            skipped.push(skip("an opening (window or door) belongs to the walls, not a model".into()));
            continue;
        }
        if i.pixels < opts.min_pixels {
            skipped.push(skip(format!("{} pixels, under the {} pixel minimum", i.pixels, opts.min_pixels)));
            continue;
        }
        let pts = points_of(i.id);
        if pts.len() < 10 {
            skipped.push(skip(format!("only {} pixels with depth inside the mask", pts.len())));
            continue;
        }
        let (mut xs, mut zs, mut ys): (Vec<f32>, Vec<f32>, Vec<f32>) =
            (pts.iter().map(|p| p.x).collect(), pts.iter().map(|p| p.z).collect(), pts.iter().map(|p| p.y).collect());
        let e = extent(&pts);
        let middle = Vec3::new(percentile(&mut xs, 0.5), 0.0, percentile(&mut zs, 0.5));
        // An instance in front of this one's bottom hides it: neither a support nor a sign that nothing stands
        // under it (real room09's open shelf behind an armchair, wall seen between its boards, was hung on the
        // wall at half its height).
        let (hiders, others): (Vec<_>, Vec<_>) = furniture
            .iter()
            .filter(|(id, _)| *id != i.id)
            .partition(|(id, _)| hides_bottom(&inst.ids, depth, w, i.id, *id, opts.occluder_depth));
        let others: Vec<Extent> = others.into_iter().map(|(_, x)| x).collect();
        // Mounted: its mask has wall right under it, and nothing that could hide legs or a support.
        let mounted = wall_below(inst, i.id) > 0.5 && hiders.is_empty();
        let base = base_height(&i.class, &e, middle, &others, floor_y, mounted);
        let centre = Vec3::new(percentile(&mut xs, 0.5), base, percentile(&mut zs, 0.5));
        let top = (percentile(&mut ys, 0.99) - base).max(0.1);
        let footprint = Vec3::new(side_from_points(&mut xs).max(0.2), top, side_from_points(&mut zs).max(0.2));
        // The whole mask's top: the points come from the mask shrunk by a pixel, which loses a thin top (real
        // room05's bentwood chair: its points stopped at 0.57 m for 0.75, and its model was tried at 0.77 of
        // its size only). Its outline pixels' depth may be another surface's: kept within the points' depths.
        let whole_top = {
            let mut depths: Vec<f32> = pts.iter().map(|p| (*p - cam.origin).dot(fwd)).collect();
            let (near, far) = (percentile(&mut depths, 0.02) - 0.3, percentile(&mut depths, 0.98) + 0.3);
            let mask: Vec<bool> = inst.ids.iter().map(|&v| v == i.id).collect();
            let mut ys: Vec<f32> = surface_points(depth, &mask, &k)
                .into_iter()
                .filter(|s| (near..=far).contains(&s.p.z))
                .map(|s| to_world(s.p).y)
                .collect();
            if ys.is_empty() {
                top
            } else {
                (percentile(&mut ys, 0.995) - base).max(top)
            }
        };
        // Where the two differ by more than a tenth, either may be the height (a thin top, or a table's edge
        // mixed with what stands behind it: real room04's 0.75 m table read 0.87): both are tried.
        let heights: Vec<f32> = if whole_top > opts.thin_top * top { vec![top, whole_top] } else { vec![top] };
        let target = sweep_target(inst, depth, i.id, sw as usize, sh as usize);
        // Candidates: the class's models, else a box of the observed size.
        // A large class is cut to the models whose real size is closest to what the points show (height, and
        // the wider footprint side, which the points bound less well, a side seen edge-on or an end hidden:
        // weighted half) and whose outline best matches the instance's (where the mask shows the whole object:
        // not cut by the border, and as much less as other objects hide of its outline).
        // Cut by the image border, the points' top is only a lower bound of the height (a chair whose back is
        // out of frame shows its seat): a model taller than that is tried at its real size too.
        let cut = touches_border(inst, i.id);
        let mut entries: Vec<&ModelEntry> = models.of_class(&i.class);
        let misfit = |e: &ModelEntry| {
            let s = e.size();
            let height = heights.iter().map(|t| (s.y / t).ln().abs()).fold(f32::MAX, f32::min);
            height + 0.5 * (s.x.max(s.z) / footprint.x.max(footprint.z)).ln().abs()
        };
        let outline_weight = opts.silhouette_weight * (1.0 - hidden_outline(inst, depth, i.id));
        let outline = if entries.len() > opts.max_candidates && !cut && outline_weight > 0.0 {
            let mask: Vec<bool> = inst.ids.iter().map(|&v| v == i.id).collect();
            Silhouette::from_mask(&mask, w, h)
        } else {
            None
        };
        // The crop's embedding against each thumbnail's (a model without a thumbnail gets none).
        let similarity: Vec<Option<f32>> = match appearance.as_mut() {
            Some(a) => {
                let crop = instance_crop(a.photo, inst, i.id).and_then(|c| embed(a.model, &c).ok());
                entries
                    .iter()
                    .map(|e| {
                        let crop = crop.as_ref()?;
                        let thumb = e.thumbnail.as_ref()?;
                        let t = thumbnail_embeddings
                            .entry(thumb.clone())
                            .or_insert_with(|| load_photo(thumb).ok().and_then(|img| embed(a.model, &img).ok()));
                        t.as_ref().map(|t| cosine(crop, t))
                    })
                    .collect()
            }
            None => vec![None; entries.len()],
        };
        let appearance_weight = appearance.as_ref().map_or(0.0, |a| a.weight);
        let rank: Vec<(f32, Option<f32>)> = entries
            .iter()
            .zip(&similarity)
            .map(|(e, sim)| {
                let iou = outline.and_then(|o| e.silhouettes_or_render().ok().map(|v| best_view_iou(&o, &v)));
                let r =
                    misfit(e) + outline_weight * (1.0 - iou.unwrap_or(0.0)) - appearance_weight * sim.unwrap_or(0.0);
                (r, iou)
            })
            .collect();
        let mut order: Vec<usize> = (0..entries.len()).collect();
        order.sort_by(|&a, &b| rank[a].0.total_cmp(&rank[b].0));
        order.truncate(opts.max_candidates.max(1));
        let outline_ious: Vec<Option<f32>> = order.iter().map(|&k| rank[k].1).collect();
        let similarities: Vec<Option<f32>> = order.iter().map(|&k| similarity[k]).collect();
        entries = order.iter().map(|&k| entries[k]).collect();
        let mut options: Vec<(Candidate, Vec<MeshPart>, f32)> = vec![];
        if entries.is_empty() && !opts.placeholders {
            skipped.push(skip(format!(
                "no model of class {} in the database (placeholder boxes are off: --set placeholder_boxes=true)",
                i.class
            )));
            continue;
        }
        if entries.is_empty() {
            let mut b = box_mesh(footprint, false);
            b.positions.iter_mut().for_each(|v| v.y += footprint.y / 2.0);
            let c = Candidate {
                model: format!("placeholder box (no model of class {})", i.class),
                path: None,
                licence: "psdr (generated)".into(),
                yaw_deg: 0.0,
                iou: 0.0,
                score: f32::MIN,
                outline_iou: None,
                embedding_similarity: None,
            };
            options.push((c, vec![b], 1.0));
        }
        for ((e, outline_iou), embedding_similarity) in entries.into_iter().zip(outline_ious).zip(similarities) {
            match e.load_parts() {
                Ok(parts) => {
                    let c = Candidate {
                        model: e.name.clone(),
                        path: Some(e.path.clone()),
                        licence: e.licence.clone(),
                        yaw_deg: 0.0,
                        iou: 0.0,
                        score: f32::MIN,
                        outline_iou,
                        embedding_similarity,
                    };
                    let fitted = |t: f32| (t / e.size().y.max(1e-3)).clamp(0.3, 3.0);
                    if cut && fitted(top) < 0.95 {
                        options.push((c.clone(), parts.clone(), 1.0));
                    }
                    if let Some(&t) = heights.get(1) {
                        options.push((c.clone(), parts.clone(), fitted(t)));
                    }
                    options.push((c, parts, fitted(top)));
                }
                Err(err) => skipped.push(skip(format!("model {} not loadable: {err}", e.name))),
            }
        }
        // The yaw sweep per candidate, each pose slid into place before it is scored; every (yaw, place) is
        // kept as a starting point for the finalists.
        let mut starts: Vec<Vec<(f32, Vec3, f32)>> = vec![vec![]; options.len()];
        for ((c, parts, scale), starts) in options.iter_mut().zip(starts.iter_mut()) {
            let Some(mut renderer) = PoseRenderer::new(cam, parts, sw, sh) else { continue };
            let size = footprint_size(parts) * *scale;
            // Real models have real sizes: scaling one far from 1 to fit is evidence against it.
            let prior = opts.scale_weight * scale.ln().abs();
            for step in 0..opts.yaws.max(1) {
                let yaw = 360.0 * step as f32 / opts.yaws.max(1) as f32;
                let pose = align(cam, &mut renderer, pose_at(centre, yaw, *scale), &target, sw, sh);
                let Some((ids, d)) = renderer.render(pose) else { continue };
                let (iou, s) = score(&target, &ids, &d, size, opts.depth_weight);
                starts.push((yaw, pose.translation, s - prior));
                if s - prior > c.score {
                    (c.yaw_deg, c.iou, c.score) = (yaw, iou, s - prior);
                }
            }
        }
        let mut order: Vec<usize> = (0..options.len()).filter(|&o| !starts[o].is_empty()).collect();
        order.sort_by(|&a, &b| options[b].0.score.total_cmp(&options[a].0.score));
        if order.is_empty() {
            skipped.push(skip("no candidate model could be rendered".into()));
            continue;
        }
        // The leaders searched again at twice the sweep's resolution from their three best distinct yaws:
        // translation, yaw and scale by a compass search on the same score, so that poses the median alignment
        // could not place (an object cut by the border shows a part whose median moves as it slides) are found,
        // a model whose visible height undersold its size gets it back, and small objects' close variants get
        // the pixels to be told apart.
        let (fw, fh) = ((2 * sw).min(w as u32), ((2 * sw).min(w as u32) as usize * h / w).max(6) as u32);
        let fine_target = sweep_target(inst, depth, i.id, fw as usize, fh as usize);
        let mut finals: Vec<(Candidate, f32, Vec3, usize)> = vec![];
        for &o in order.iter().take(opts.finalists.max(1)) {
            let (c, parts, scale) = &options[o];
            let Some(mut renderer) = PoseRenderer::new(cam, parts, fw, fh) else { continue };
            let search = PoseSearch {
                target: &fine_target,
                unit_size: footprint_size(parts),
                scale_weight: opts.scale_weight,
                depth_weight: opts.depth_weight,
                scale_step: opts.scale_step,
            };
            let size = footprint_size(parts) * scale;
            let yaw_step = 180.0 / opts.yaws.max(1) as f32;
            let found: Vec<FoundPose> = distinct_yaws(&starts[o], 3, 4.0 * yaw_step)
                .into_iter()
                .filter_map(|(yaw, t, _)| {
                    let pose = align(cam, &mut renderer, pose_at(t, yaw, *scale), &fine_target, fw, fh);
                    search.compass(&mut renderer, pose, yaw, 0.15 * size, yaw_step)
                })
                .collect();
            let reach = half_depth(parts) * scale;
            if let Some((yaw, sc, iou, t, found_scale)) =
                back_to_the_wall(&found, &walls, reach, opts.wall_tie, cam.origin)
            {
                let chosen = Candidate { yaw_deg: yaw.rem_euclid(360.0), iou, score: sc, ..c.clone() };
                finals.push((chosen, found_scale, t, o));
            }
        }
        finals.sort_by(|a, b| b.0.score.total_cmp(&a.0.score));
        let Some((chosen, scale, centre, o)) = finals.first().cloned() else {
            skipped.push(skip("no candidate model could be rendered".into()));
            continue;
        };
        let parts = options[o].1.clone();
        let against_wall = wall_behind(&walls, centre, half_depth(&parts) * scale)
            .filter(|w| back(chosen.yaw_deg).dot(-w.normal) > 0.7)
            .map(|w| w.name.clone());
        // Alternatives: the other finalists, then the sweep's order; a model tried at two scales counts once (by
        // its file: the libraries name several models alike, real room09's three "Shelves").
        let mut alternatives: Vec<Candidate> = vec![];
        let others = finals.iter().skip(1).map(|f| &f.0).chain(order.iter().map(|&o| &options[o].0));
        for c in others {
            if c.path != chosen.path && !alternatives.iter().any(|a| a.path == c.path) {
                alternatives.push(c.clone());
            }
        }
        alternatives.truncate(opts.top_k.saturating_sub(1));
        let name = format!("{}_{}", i.class, i.id);
        let pose = pose_at(centre, chosen.yaw_deg, scale);
        let object = Object { name: name.clone(), parts, pose, emitter: None };
        placed.push((
            ObjectPlacement {
                instance: i.id,
                class: i.class.clone(),
                name,
                translation: centre.to_array(),
                yaw_deg: chosen.yaw_deg,
                scale,
                chosen,
                alternatives,
                points: pts.len(),
                support: if base > floor_y { "raised" } else { "floor" }.into(),
                merged: merges.iter().filter(|m| m.into == i.id).map(|m| m.merged).collect(),
                against_wall,
            },
            object,
        ));
    }
    (placed, skipped)
}

#[cfg(test)]
mod tests {
    use super::side_from_points;

    #[test]
    fn points_spread_evenly_along_a_side_give_its_length() {
        // 1001 points evenly over a 2.07 m side, in scrambled order: the span's 0.8 undone to the grid's step.
        let mut v: Vec<f32> = (0..=1000).map(|k| ((k * 379) % 1001) as f32 * 2.07 / 1000.0 - 1.0).collect();
        let side = side_from_points(&mut v);
        assert!((side - 2.07).abs() < 0.003, "{side}");
    }
}
