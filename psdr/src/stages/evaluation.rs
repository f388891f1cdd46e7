//! A fitted scene's errors against a ground-truth scene of the same photo, for the examples, the tests and the
//! evaluation benchmark. Both scenes share only the camera (a fit chooses its own world frame), so everything
//! is compared in the camera's frame: the room's extent across and along the view and its height, the camera's
//! height and pitch, every ground-truth object matched to the nearest fitted object of its class (centre error
//! relative to the camera distance, yaw relative to the camera's, height ratio, whether the model is the same),
//! the light counts, the render against the photo (RMSE at 1/8 size relative to the photo's mean, SSIM of
//! the luminance at full size; the render clamped where an 8-bit photo clips; `noise_and_bias` splits the
//! RMSE into the render's noise and the rest, given a second render), and the albedos the fit gives each surface the truth shows (floor, walls,
//! ceiling, every piece of furniture), pixel by pixel through both scenes' albedo images; and, given the photo's
//! instance masks, every fitted object's rendered pixels against the instance it was fitted to (mask IoU).

use crate::loss::{Image, Tensor};
use crate::render::Frame;
use crate::scene::{Camera, Object, Scene};
use crate::vision::{canonical_class, Instances};
use glam::Vec3;
use serde_json::{json, Value};

/// Words in a name that make an object part of the room, not furniture.
fn is_structure(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    ["floor", "wall", "ceiling", "window", "light"].iter().any(|w| n.contains(w))
}

/// Camera frame: right, up, forward (orthonormal).
fn frame(c: &Camera) -> (Vec3, Vec3, Vec3) {
    let f = c.forward.normalize();
    let r = f.cross(c.up).normalize();
    (r, r.cross(f), f)
}

/// A point in the camera's frame.
fn to_camera(c: &Camera, p: Vec3) -> Vec3 {
    let (r, u, f) = frame(c);
    let d = p - c.origin;
    Vec3::new(d.dot(r), d.dot(u), d.dot(f))
}

/// World-space bounds of an object's parts.
fn bounds(o: &Object) -> Option<(Vec3, Vec3)> {
    let m = o.pose.matrix();
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for v in o.parts.iter().flat_map(|p| &p.positions) {
        let w = m.transform_point3(*v);
        (lo, hi) = (lo.min(w), hi.max(w));
    }
    (lo.x <= hi.x).then_some((lo, hi))
}

/// The horizontal angle of a direction, degrees.
fn heading(v: Vec3) -> f32 {
    v.x.atan2(v.z).to_degrees()
}

/// The signed difference of two angles, in -180..180 degrees.
fn angle_diff(a: f32, b: f32) -> f32 {
    (a - b + 180.0).rem_euclid(360.0) - 180.0
}

/// The room as the camera sees it: extent across the view (between the walls whose normals are most nearly
/// the camera's right), along it, height; the distance from the camera to the walls on its left and right,
/// ahead and behind (a mirrored room has the right extents but not these); the camera's height above the
/// floor and pitch.
pub fn room_in_camera_frame(s: &Scene) -> Value {
    let c = &s.camera;
    let (right, _, fwd) = frame(c);
    let level = |o: &Object| bounds(o).map(|(lo, hi)| (lo.y + hi.y) / 2.0);
    let named = |w: &'static str| s.objects.iter().filter(move |o| o.name.to_ascii_lowercase().contains(w));
    let floor = named("floor").filter_map(level).reduce(f32::min);
    let ceiling = named("ceiling").filter(|o| o.emitter.is_none()).filter_map(level).reduce(f32::max);
    // Walls: an inward normal and its offset; the extent along a direction is between opposite walls.
    let walls: Vec<(Vec3, f32)> = named("wall")
        .map(|o| {
            let n = (o.pose.rotation * Vec3::Z).normalize();
            (n, n.dot(o.pose.translation))
        })
        .filter(|(n, _)| n.y.abs() < 0.1)
        .collect();
    // The wall farthest along `axis` (sign +1) or against it (-1): its offset along the axis.
    let side = |axis: Vec3, sign: f32| {
        walls.iter().filter(|(n, _)| n.dot(axis) * sign < -0.9).map(|(n, d)| *d / n.dot(axis)).reduce(|a, b| {
            if sign > 0.0 {
                a.max(b)
            } else {
                a.min(b)
            }
        })
    };
    let extent = |axis: Vec3| Some(side(axis, 1.0)? - side(axis, -1.0)?);
    // Distance from the camera to the wall on one side (signed along the axis pointing to that side).
    let distance = |axis: Vec3, sign: f32| side(axis * sign, 1.0).map(|o| o - c.origin.dot(axis * sign));
    // The Manhattan axis nearest the camera's right, and the one nearest its forward direction.
    let across =
        walls.iter().map(|(n, _)| *n * n.dot(right).signum()).max_by(|a, b| a.dot(right).total_cmp(&b.dot(right)));
    let along = walls.iter().map(|(n, _)| *n * n.dot(fwd).signum()).max_by(|a, b| a.dot(fwd).total_cmp(&b.dot(fwd)));
    json!({
        "across": across.and_then(extent),
        "along": along.and_then(extent),
        "left": across.and_then(|a| distance(a, -1.0)),
        "right": across.and_then(|a| distance(a, 1.0)),
        "ahead": along.and_then(|a| distance(a, 1.0)),
        "behind": along.and_then(|a| distance(a, -1.0)),
        "height": floor.zip(ceiling).map(|(f, c)| c - f),
        "camera_height": floor.map(|f| c.origin.y - f),
        "pitch_deg": c.forward.normalize().y.asin().to_degrees(),
    })
}

/// A piece of furniture as the camera sees it.
struct Seen {
    name: String,
    class: String,
    centre: Vec3,
    height: f32,
    yaw: f32,
}

fn furniture(s: &Scene) -> Vec<Seen> {
    let cam_heading = heading(s.camera.forward);
    s.objects
        .iter()
        .filter(|o| o.emitter.is_none() && !is_structure(&o.name))
        .filter_map(|o| {
            let (lo, hi) = bounds(o)?;
            let class = canonical_class(o.name.split(['_', '-']).next().unwrap_or("")).0.to_string();
            Some(Seen {
                name: o.name.clone(),
                class,
                centre: to_camera(&s.camera, (lo + hi) / 2.0),
                height: hi.y - lo.y,
                yaw: angle_diff(heading(o.pose.rotation * Vec3::Z), cam_heading),
            })
        })
        .collect()
}

/// The `k` x `k` box means of an RGB image (`w` x `h`), block by block, channel by channel; blocks at the
/// right and bottom edges take the pixels that are left.
fn block_means(img: &[f32], w: usize, h: usize, k: usize) -> Vec<f64> {
    let (sw, sh) = ((w / k).max(1), (h / k).max(1));
    let mut out = Vec::with_capacity(sw * sh * 3);
    for y in 0..sh {
        for x in 0..sw {
            for c in 0..3 {
                let (mut sum, mut n) = (0.0f32, 0.0f32);
                for yy in y * k..((y + 1) * k).min(h) {
                    for xx in x * k..((x + 1) * k).min(w) {
                        sum += img[(yy * w + xx) * 3 + c];
                        n += 1.0;
                    }
                }
                out.push((sum / n.max(1.0)) as f64);
            }
        }
    }
    out
}

/// Root-mean-square error of `a` against `b` (RGB, `w` x `h`) after `k` x `k` box downsampling, relative to
/// `b`'s mean.
pub fn relative_rmse_downsampled(a: &[f32], b: &[f32], w: usize, h: usize, k: usize) -> f32 {
    let (a, b) = (block_means(a, w, h, k), block_means(b, w, h, k));
    (mean_squared_difference(&a, &b).sqrt() / mean(&b)) as f32
}

fn mean_squared_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum::<f64>() / b.len().max(1) as f64
}

/// The mean of `v`, at least 1e-9 (a relative error's denominator).
fn mean(v: &[f64]) -> f64 {
    (v.iter().sum::<f64>() / v.len().max(1) as f64).max(1e-9)
}

/// A Monte Carlo render's error against a photo split into the render's own noise and the rest, both as
/// `relative_rmse_downsampled` measures: `render` and `repeat` are two renders of one scene with independent
/// samples at the same spp. Their difference holds twice one render's noise variance and none of the scene's
/// error, so E[(render - photo)^2] less E[(render - repeat)^2] / 2 is the squared error a converged render
/// would have (the photo's own noise stays in it). Returns (noise, bias); the bias is 0 where the noise
/// estimate exceeds the error (a render as close to the photo as its noise can tell).
pub fn noise_and_bias(render: &[f32], repeat: &[f32], photo: &[f32], w: usize, h: usize, k: usize) -> (f32, f32) {
    let (a, r, p) = (block_means(render, w, h, k), block_means(repeat, w, h, k), block_means(photo, w, h, k));
    let (error, noise, mean) = (mean_squared_difference(&a, &p), mean_squared_difference(&a, &r) / 2.0, mean(&p));
    ((noise.sqrt() / mean) as f32, ((error - noise).max(0.0).sqrt() / mean) as f32)
}

/// Mean SSIM of the luminance of two RGB images (7 x 7 windows, the usual constants for values in 0..1).
pub fn ssim_luminance(a: &[f32], b: &[f32], w: usize, h: usize) -> f32 {
    let lum = |img: &[f32]| -> Vec<f32> {
        (0..w * h).map(|p| 0.2126 * img[p * 3] + 0.7152 * img[p * 3 + 1] + 0.0722 * img[p * 3 + 2]).collect()
    };
    let (x, y) = (lum(a), lum(b));
    let (c1, c2) = (0.01f32 * 0.01, 0.03f32 * 0.03);
    let r = 3usize;
    let (mut total, mut n) = (0.0f64, 0usize);
    for cy in r..h.saturating_sub(r) {
        for cx in r..w.saturating_sub(r) {
            let (mut mx, mut my, mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for py in cy - r..=cy + r {
                for px in cx - r..=cx + r {
                    let (u, v) = (x[py * w + px], y[py * w + px]);
                    (mx, my, xx, yy, xy) = (mx + u, my + v, xx + u * u, yy + v * v, xy + u * v);
                }
            }
            let k = ((2 * r + 1) * (2 * r + 1)) as f32;
            let (mx, my) = (mx / k, my / k);
            let (vx, vy, cxy) = (xx / k - mx * mx, yy / k - my * my, xy / k - mx * my);
            let s = ((2.0 * mx * my + c1) * (2.0 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2));
            total += s as f64;
            n += 1;
        }
    }
    if n == 0 {
        1.0
    } else {
        (total / n as f64) as f32
    }
}

/// The surface a truth object belongs to for the albedo comparison: floor, wall or ceiling for the room's
/// surfaces, the object itself for furniture, none for lights and windows.
fn albedo_segment(o: &Object) -> Option<String> {
    let n = o.name.to_ascii_lowercase();
    if o.emitter.is_some() || n.contains("window") || n.contains("light") {
        return None;
    }
    Some(["floor", "wall", "ceiling"].into_iter().find(|w| n.contains(w)).map_or(o.name.clone(), String::from))
}

/// Per surface the truth shows on at least 0.5 % of the pixels: the mean albedo of the fitted scene's render
/// and of the truth's over the truth's pixels of that surface, and their distance relative to the truth's
/// (|fitted - truth| / |truth|, RGB); where the truth's albedo there has texture, `texture_error`: the texture
/// descriptor distance (`loss::texture_loss`: 0 for the same statistics, 1 for a flat colour against the
/// truth's texture) between the two albedo images, each divided by its mean colour, on the surface's squarest
/// rectangle (at least 24 pixels a side): a procedural material's pattern, judged where pixels cannot align.
pub fn albedo_errors(truth: &Scene, fitted_frame: &Frame, truth_frame: &Frame) -> Value {
    let n = truth_frame.object_id.len();
    let segment_of: Vec<Option<String>> = truth.objects.iter().map(albedo_segment).collect();
    let mut sums: Vec<(String, [f64; 3], [f64; 3], usize)> = vec![];
    for (p, &id) in truth_frame.object_id.iter().enumerate() {
        let Some(seg) = segment_of.get(id as usize).cloned().flatten() else { continue };
        let k = match sums.iter().position(|s| s.0 == seg) {
            Some(k) => k,
            None => {
                sums.push((seg, [0.0; 3], [0.0; 3], 0));
                sums.len() - 1
            }
        };
        for c in 0..3 {
            sums[k].1[c] += fitted_frame.albedo[p * 3 + c] as f64;
            sums[k].2[c] += truth_frame.albedo[p * 3 + c] as f64;
        }
        sums[k].3 += 1;
    }
    let mut worst = 0.0f64;
    let surfaces: Vec<Value> = sums
        .into_iter()
        .filter(|s| s.3 * 200 >= n)
        .map(|(seg, f, t, count)| {
            let (f, t) = (f.map(|v| v / count as f64), t.map(|v| v / count as f64));
            let norm = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
            let err = norm([f[0] - t[0], f[1] - t[1], f[2] - t[2]]) / norm(t).max(1e-6);
            worst = worst.max(err);
            let mask: Vec<bool> = truth_frame
                .object_id
                .iter()
                .map(|&id| segment_of.get(id as usize).is_some_and(|s| s.as_deref() == Some(seg.as_str())))
                .collect();
            let texture = texture_error(fitted_frame, truth_frame, &mask);
            json!({ "surface": seg, "pixels": count, "fitted": f, "truth": t, "error_rel": err,
                    "texture_error": texture })
        })
        .collect();
    json!({ "surfaces": surfaces, "worst_error_rel": worst })
}

/// The image error at 1/`k` size (`relative_rmse_downsampled`) split among the truth's surfaces, named as
/// `albedo_errors` names them (the walls as one; its lights and windows as "lights and windows", what the truth
/// shows nothing at as "none"): each block's squared error shared among the surfaces by their pixels in it.
/// Per surface, largest first: its `share` of the squared error and its `rmse_rel`, the part of the relative
/// error it carries (the parts add in quadrature to the whole). Says which surface a fit gets wrong: a floor's
/// photographed wood no library material reproduces, a sofa of another model, a wall lit from the wrong place.
pub fn image_error_by_surface(render: &[f32], photo: &[f32], truth: &Scene, truth_frame: &Frame, k: usize) -> Value {
    let (w, h) = (truth_frame.width as usize, truth_frame.height as usize);
    if render.len() != w * h * 3 || photo.len() != w * h * 3 || truth_frame.object_id.len() != w * h {
        return Value::Null;
    }
    let mut names: Vec<String> = vec![];
    let mut index = |name: String| match names.iter().position(|n| *n == name) {
        Some(i) => i,
        None => {
            names.push(name);
            names.len() - 1
        }
    };
    let labels: Vec<usize> = truth_frame
        .object_id
        .iter()
        .map(|&id| match truth.objects.get(id as usize) {
            None => index("none".into()),
            Some(o) => index(albedo_segment(o).unwrap_or_else(|| "lights and windows".into())),
        })
        .collect();
    let parts = error_by_label(render, photo, &labels, names.len(), w, h, k);
    let total: f64 = parts.iter().sum();
    let mut order: Vec<usize> = (0..names.len()).collect();
    order.sort_by(|&a, &b| parts[b].total_cmp(&parts[a]));
    let scale = mean(&block_means(photo, w, h, k));
    let blocks = ((w / k).max(1) * (h / k).max(1) * 3) as f64;
    let surfaces: Vec<Value> = order
        .into_iter()
        .filter(|&i| parts[i] > 0.0)
        .map(|i| {
            json!({ "surface": names[i], "share": parts[i] / total.max(1e-30),
                    "rmse_rel": (parts[i] / blocks).sqrt() / scale })
        })
        .collect();
    Value::Array(surfaces)
}

/// The squared error of `a` against `b` (RGB, `w` x `h`) after `k` x `k` box downsampling, summed over blocks
/// and channels, split among `n` labels (`labels`: one per pixel) by each label's share of a block's pixels.
fn error_by_label(a: &[f32], b: &[f32], labels: &[usize], n: usize, w: usize, h: usize, k: usize) -> Vec<f64> {
    let (da, db) = (block_means(a, w, h, k), block_means(b, w, h, k));
    let (sw, sh) = ((w / k).max(1), (h / k).max(1));
    let mut parts = vec![0.0f64; n];
    let mut count = vec![0usize; n];
    for y in 0..sh {
        for x in 0..sw {
            let e: f64 = (0..3).map(|c| (da[(y * sw + x) * 3 + c] - db[(y * sw + x) * 3 + c]).powi(2)).sum();
            count.iter_mut().for_each(|c| *c = 0);
            let mut pixels = 0usize;
            for yy in y * k..((y + 1) * k).min(h) {
                for xx in x * k..((x + 1) * k).min(w) {
                    count[labels[yy * w + xx]] += 1;
                    pixels += 1;
                }
            }
            for (part, &c) in parts.iter_mut().zip(&count) {
                *part += e * c as f64 / pixels.max(1) as f64;
            }
        }
    }
    parts
}

/// `texture_loss` of the fitted albedo against the truth's on the mask's squarest rectangle, both divided by
/// their mean colours; None where it is under 24 pixels a side or the truth's albedo there is flat (local
/// contrast under 2 %).
fn texture_error(fitted: &Frame, truth: &Frame, mask: &[bool]) -> Option<f32> {
    let (w, h) = (truth.width as usize, truth.height as usize);
    let m = Image::new(w, h, 1, mask.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect()).ok()?;
    let r = crate::base::squarest_rect(&m).ok()??;
    if r.w.min(r.h) < crate::loss::MIN_CROP {
        return None;
    }
    // Each crop divided by its mean colour: the pattern, not the colour (the mean error says that).
    let image = |f: &Frame| -> Option<Tensor> {
        let img = Image::new(w, h, 3, f.albedo.clone()).ok()?;
        let mut c = crate::loss::crop(&Tensor::constant(img), r.x, r.y, r.w, r.h).ok()?.value().clone();
        let n = (c.width * c.height) as f32;
        let mean: [f32; 3] = std::array::from_fn(|k| c.data.iter().skip(k).step_by(3).sum::<f32>() / n);
        c.data.iter_mut().enumerate().for_each(|(i, v)| *v /= mean[i % 3].max(1e-4));
        Some(Tensor::constant(c))
    };
    let truth_crop = image(truth)?;
    if crate::stages::contrast(truth_crop.value()) < 0.02 {
        return None;
    }
    crate::loss::texture_loss(&image(fitted)?, &truth_crop).ok()?.item()
}

/// Per object name, the instances merged into its own (split pieces the object stage joined).
pub type Merged = [(String, Vec<u16>)];

/// Per fitted object named CLASS_ID, with ID an instance of the observed masks (the object stage names its
/// objects so): the IoU of the pixels the fitted scene shows it on (`fitted_frame`'s object ids, at the masks'
/// size) and that instance's pixels, with those of the instances merged into it (`merged`: object name ->
/// instance ids, split pieces the object stage joined); with their median and worst. The pose and model as the
/// photo judges them, in no world frame: a centre error says nothing of a chair turned inside its own outline.
/// None when the frame and the masks differ in size.
pub fn mask_ious(fitted: &Scene, fitted_frame: &Frame, masks: &Instances, merged: &Merged) -> Option<Value> {
    if (fitted_frame.width as usize, fitted_frame.height as usize) != (masks.width, masks.height) {
        return None;
    }
    let mut per_object = vec![];
    for (k, o) in fitted.objects.iter().enumerate() {
        // The id after the last '_' (a class may hold one itself), and only ids the masks know.
        let Some(id) = o.name.rsplit_once('_').and_then(|(_, id)| id.parse::<u16>().ok()) else { continue };
        if o.emitter.is_some() || !masks.instances.iter().any(|i| i.id == id) {
            continue;
        }
        let mut ids = vec![id];
        ids.extend(merged.iter().filter(|(n, _)| *n == o.name).flat_map(|(_, m)| m.iter().copied()));
        let (mut both, mut either) = (0usize, 0usize);
        for (&obj, inst) in fitted_frame.object_id.iter().zip(&masks.ids) {
            let (a, b) = (obj == k as u32, ids.contains(inst));
            both += usize::from(a && b);
            either += usize::from(a || b);
        }
        let iou = both as f64 / either.max(1) as f64;
        per_object.push(json!({ "name": o.name, "instances": ids, "iou": iou }));
    }
    let mut values: Vec<f64> = per_object.iter().filter_map(|v| v["iou"].as_f64()).collect();
    values.sort_by(f64::total_cmp);
    // The lower median of an even count: a benchmark's headline should not flatter.
    let median = values.get(values.len().saturating_sub(1) / 2).copied();
    Some(json!({ "objects": per_object, "median": median, "worst": values.first() }))
}

/// Every true light (windows apart) matched to a fitted one so that the matched distances sum to the least
/// (as many pairs as the fewer of the two): the distance of their centres in metres (in the camera's frame, as
/// everything here), and the worst; a true light left over has no fitted one. Matching the brightest true light
/// first to its nearest took a fitted light from the true light it sat on (real room10: a light 6 cm from
/// one true light reported 2.40 m from another).
fn light_position_errors(fitted: &Scene, truth: &Scene) -> Value {
    let lights = |s: &Scene| -> Vec<(String, Vec3)> {
        s.objects
            .iter()
            .filter(|o| !o.name.to_ascii_lowercase().contains("window"))
            .filter_map(|o| {
                o.emitter.as_ref()?;
                let (lo, hi) = bounds(o)?;
                Some((o.name.clone(), to_camera(&s.camera, (lo + hi) / 2.0)))
            })
            .collect()
    };
    let (fit, want) = (lights(fitted), lights(truth));
    let distances: Vec<Vec<f32>> =
        want.iter().map(|(_, t)| fit.iter().map(|(_, f)| (*f - *t).length()).collect()).collect();
    let pairs = least_distance_matching(&distances);
    let mut worst: Option<f32> = None;
    let matched: Vec<Value> = want
        .iter()
        .zip(pairs.iter().zip(&distances))
        .map(|((name, _), (pair, row))| match pair {
            Some(k) => {
                let e = row[*k];
                worst = Some(worst.map_or(e, |w: f32| w.max(e)));
                json!({ "truth": name, "fitted": fit[*k].0, "error_m": e })
            }
            None => json!({ "truth": name, "fitted": null }),
        })
        .collect();
    json!({ "lights": matched, "worst_error_m": worst })
}

/// For each row (a true light) the column (a fitted light) it is matched to, every column at most once and
/// min(rows, columns) pairs, the matched distances' sum the least: exact by dynamic programming over the sets
/// of columns taken (rooms have a handful of lights; beyond 16 fitted ones, nearest first in row order).
fn least_distance_matching(d: &[Vec<f32>]) -> Vec<Option<usize>> {
    let (rows, cols) = (d.len(), d.first().map_or(0, Vec::len));
    if cols > 16 {
        let mut used = vec![false; cols];
        return d
            .iter()
            .map(|row| {
                let k = (0..cols).filter(|&k| !used[k]).min_by(|&a, &b| row[a].total_cmp(&row[b]))?;
                used[k] = true;
                Some(k)
            })
            .collect();
    }
    // best[r][mask]: the least sum for rows r.. with the columns in `mask` taken; a row is left unmatched
    // only where the columns left are fewer than the rows left.
    let full = 1usize << cols;
    let mut best = vec![vec![f32::INFINITY; full]; rows + 1];
    best[rows].iter_mut().for_each(|b| *b = 0.0);
    for r in (0..rows).rev() {
        for mask in 0..full {
            let free = cols - mask.count_ones() as usize;
            let mut b = if free < rows - r { best[r + 1][mask] } else { f32::INFINITY };
            for k in (0..cols).filter(|k| mask & (1 << k) == 0) {
                b = b.min(d[r][k] + best[r + 1][mask | 1 << k]);
            }
            best[r][mask] = b;
        }
    }
    let mut mask = 0usize;
    (0..rows)
        .map(|r| {
            let k = (0..cols).filter(|k| mask & (1 << k) == 0).find(|&k| {
                (d[r][k] + best[r + 1][mask | 1 << k] - best[r][mask]).abs() <= 1e-6 * best[r][mask].max(1.0)
            })?;
            mask |= 1 << k;
            Some(k)
        })
        .collect()
}

/// The errors of `fitted` against `truth`. `models`: fitted object name -> retrieved model name (a ground-truth
/// object's name is its model's); `render` and `photo`: RGB of the camera's size; `masks`: the photo's
/// instances and the instances merged into each object, for the objects' mask IoU (`mask_ious`).
pub fn evaluate(
    fitted: &Scene,
    truth: &Scene,
    models: &[(String, String)],
    fitted_frame: &Frame,
    truth_frame: &Frame,
    photo: &[f32],
    masks: Option<(&Instances, &Merged)>,
) -> Value {
    // The render as the photo's camera would record it (clamped at an 8-bit photo's white): a visible lamp
    // brighter than white is not an error the photo can show.
    let render = &crate::vision::clip_like_photo(&fitted_frame.radiance, photo);
    let (w, h) = (fitted.camera.width as usize, fitted.camera.height as usize);
    let room = (room_in_camera_frame(fitted), room_in_camera_frame(truth));
    let rel = |k: &str| -> Value {
        match (room.0[k].as_f64(), room.1[k].as_f64()) {
            (Some(a), Some(b)) if b.abs() > 1e-9 => json!((a - b) / b),
            _ => Value::Null,
        }
    };
    let (fit, want) = (furniture(fitted), furniture(truth));
    let mut used = vec![false; fit.len()];
    let mut objects = vec![];
    let (mut found, mut retrieved) = (0, 0);
    // The truth's largest objects choose first.
    let mut order: Vec<usize> = (0..want.len()).collect();
    order.sort_by(|&a, &b| want[b].height.total_cmp(&want[a].height));
    for t in order.into_iter().map(|k| &want[k]) {
        let best = fit
            .iter()
            .enumerate()
            .filter(|(k, f)| !used[*k] && f.class == t.class)
            .min_by(|a, b| (a.1.centre - t.centre).length().total_cmp(&(b.1.centre - t.centre).length()));
        let dist = t.centre.length().max(1e-3);
        let entry = match best {
            Some((k, f)) if (f.centre - t.centre).length() < 0.25 * dist => {
                used[k] = true;
                found += 1;
                let model = models.iter().find(|(n, _)| *n == f.name).map(|(_, m)| m.clone());
                let same = model.as_deref() == Some(t.name.as_str());
                retrieved += usize::from(same);
                json!({
                    "truth": t.name, "class": t.class, "fitted": f.name, "model": model, "same_model": same,
                    "centre_error_m": (f.centre - t.centre).length(),
                    "centre_error_rel": (f.centre - t.centre).length() / dist,
                    "yaw_error_deg": angle_diff(f.yaw, t.yaw).abs(),
                    "height_error_rel": f.height / t.height.max(1e-3) - 1.0,
                })
            }
            _ => json!({ "truth": t.name, "class": t.class, "fitted": null }),
        };
        objects.push(entry);
    }
    let lights = |s: &Scene, window: bool| {
        s.objects
            .iter()
            .filter(|o| o.emitter.is_some() && o.name.to_ascii_lowercase().contains("window") == window)
            .count()
    };
    let light_positions = light_position_errors(fitted, truth);
    json!({
        "room": { "fitted": room.0, "truth": room.1,
                  "across_error_rel": rel("across"), "along_error_rel": rel("along"), "height_error_rel": rel("height"),
                  "left_error_rel": rel("left"), "right_error_rel": rel("right"), "ahead_error_rel": rel("ahead"),
                  "camera_height_error_m": room.0["camera_height"].as_f64().zip(room.1["camera_height"].as_f64()).map(|(a, b)| a - b) },
        "objects": objects,
        "objects_found": found,
        "objects_true": want.len(),
        "objects_extra": fit.len() - found,
        "models_retrieved": retrieved,
        "lights": { "fitted": lights(fitted, false), "truth": lights(truth, false),
                    "truth_windows": lights(truth, true), "fitted_windows": lights(fitted, true),
                    "positions": light_positions },
        "image": { "rmse_rel_1_8": relative_rmse_downsampled(render, photo, w, h, 8),
                   "rmse_rel_1_32": relative_rmse_downsampled(render, photo, w, h, 32),
                   "by_surface_1_8": image_error_by_surface(render, photo, truth, truth_frame, 8),
                   "ssim": ssim_luminance(render, photo, w, h) },
        "albedo": albedo_errors(truth, fitted_frame, truth_frame),
        "mask_iou": masks.and_then(|(m, merged)| mask_ious(fitted, fitted_frame, m, merged)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_image_error_is_shared_among_surfaces_by_their_pixels() {
        // 16 x 8: two 8 x 8 blocks. Label 0 on the left block and the right block's left half, label 1 on the
        // right block's right half; only the right block differs (by 0.2 in every channel).
        let (w, h) = (16, 8);
        let photo = vec![0.5f32; w * h * 3];
        let render: Vec<f32> = (0..w * h * 3).map(|i| if (i / 3) % w >= 8 { 0.7 } else { 0.5 }).collect();
        let labels: Vec<usize> = (0..w * h).map(|p| usize::from(p % w >= 12)).collect();
        let parts = error_by_label(&render, &photo, &labels, 2, w, h, 8);
        // The right block's squared error, 3 x 0.2^2, half to each label; none from the left block.
        assert!((parts[0] - 0.06).abs() < 1e-6 && (parts[1] - 0.06).abs() < 1e-6, "{parts:?}");
        // The parts add up to the whole error as relative_rmse_downsampled measures it.
        let whole = relative_rmse_downsampled(&render, &photo, w, h, 8) as f64;
        let from_parts = ((parts[0] + parts[1]) / (2.0 * 3.0)).sqrt() / 0.5;
        assert!((whole - from_parts).abs() < 1e-6, "{whole} {from_parts}");
        // A render equal to the photo has no error anywhere.
        assert!(error_by_label(&photo, &photo, &labels, 2, w, h, 8).iter().all(|&p| p == 0.0));
    }

    #[test]
    fn image_metrics_meet_their_definitions() {
        let (w, h) = (32, 24);
        let a: Vec<f32> = (0..w * h * 3).map(|i| 0.2 + 0.5 * ((i * 7919) % 101) as f32 / 101.0).collect();
        assert!(relative_rmse_downsampled(&a, &a, w, h, 8) == 0.0);
        assert!((ssim_luminance(&a, &a, w, h) - 1.0).abs() < 1e-5);
        // On a uniform image a 10 % gain is an RMSE of exactly 10 % of the mean.
        let grey = vec![0.5f32; w * h * 3];
        let brighter: Vec<f32> = grey.iter().map(|v| v * 1.1).collect();
        assert!((relative_rmse_downsampled(&brighter, &grey, w, h, 8) - 0.1).abs() < 1e-5);
        let b: Vec<f32> = a.iter().map(|v| v * 1.1).collect();
        assert!(ssim_luminance(&b, &a, w, h) < 1.0);
        assert_eq!(angle_diff(350.0, 10.0), -20.0);
    }

    /// Two renders with independent noise of known size (uniform per pixel, 5 % of the mean per 8x8 block)
    /// around a photo, one with a 5 % gain: the split gives back both sizes. 16x12 blocks x 3 channels = 576
    /// values: each squared-error mean has a relative standard deviation of sqrt(2/576) = 6 %, so 15 % is
    /// 2.5 of them; with no gain the estimated bias is under 0.45 of the noise (its square, a difference of
    /// two such means, has a standard deviation of 0.06 of the noise's square: 0.45^2 is over 3 of them).
    #[test]
    fn image_error_splits_into_noise_and_bias() {
        let (w, h) = (128, 96);
        let photo = vec![0.5f32; w * h * 3];
        // A deterministic hash to uniform [-1, 1): independent draws for the two renders.
        let uniform = |i: usize, seed: u64| {
            let mut x = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ seed.wrapping_mul(0xBF58_476D_1CE4_E5B9);
            x ^= x >> 31;
            x = x.wrapping_mul(0x94D0_49BB_1331_11EB);
            x ^= x >> 29;
            (x >> 11) as f32 / (1u64 << 53) as f32 * 2.0 - 1.0
        };
        // Per-pixel standard deviation 0.2 (a uniform of half-width 0.2 sqrt 3): 0.025 per block, 5 % of 0.5.
        let render = |gain: f32, seed: u64| -> Vec<f32> {
            (0..w * h * 3).map(|i| 0.5 * gain + 0.2 * 3f32.sqrt() * uniform(i, seed)).collect()
        };
        let (noise, bias) = noise_and_bias(&render(1.05, 1), &render(1.05, 2), &photo, w, h, 8);
        assert!((noise - 0.05).abs() < 0.15 * 0.05, "noise {noise}");
        assert!((bias - 0.05).abs() < 0.15 * 0.05, "bias {bias}");
        let total = relative_rmse_downsampled(&render(1.05, 1), &photo, w, h, 8);
        assert!((total - 0.05 * 2f32.sqrt()).abs() < 0.15 * 0.07, "total {total}");
        let (noise, bias) = noise_and_bias(&render(1.0, 3), &render(1.0, 4), &photo, w, h, 8);
        assert!(bias < 0.45 * noise, "no gain: noise {noise}, bias {bias}");
        // Without noise the bias is the error itself.
        let exact = vec![0.525f32; w * h * 3];
        let (noise, bias) = noise_and_bias(&exact, &exact, &photo, w, h, 8);
        assert!(noise == 0.0 && (bias - 0.05).abs() < 1e-5, "{noise} {bias}");
    }

    /// The least-sum matching against every injective assignment, on random distance tables of every shape up
    /// to 4 x 5 (more true lights than fitted leaves the extra rows unmatched).
    #[test]
    fn light_matching_is_the_least_sum() {
        fn all(
            rows: usize,
            cols: usize,
            r: usize,
            used: &mut Vec<bool>,
            cur: &mut Vec<Option<usize>>,
            out: &mut Vec<Vec<Option<usize>>>,
        ) {
            if r == rows {
                let matched = cur.iter().flatten().count();
                if matched == rows.min(cols) {
                    out.push(cur.clone());
                }
                return;
            }
            for k in 0..=cols {
                if k < cols && used[k] {
                    continue;
                }
                cur.push((k < cols).then_some(k));
                if k < cols {
                    used[k] = true;
                }
                all(rows, cols, r + 1, used, cur, out);
                if k < cols {
                    used[k] = false;
                }
                cur.pop();
            }
        }
        let mut seed = 12345u32;
        let mut next = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 * 3.0
        };
        for rows in 1..=4 {
            for cols in 0..=5 {
                let d: Vec<Vec<f32>> = (0..rows).map(|_| (0..cols).map(|_| next()).collect()).collect();
                let sum =
                    |m: &[Option<usize>]| -> f32 { m.iter().enumerate().filter_map(|(r, k)| k.map(|k| d[r][k])).sum() };
                let mut every = vec![];
                all(rows, cols, 0, &mut vec![false; cols], &mut vec![], &mut every);
                let least = every.iter().map(|m| sum(m)).fold(f32::INFINITY, f32::min);
                let got = least_distance_matching(&d);
                assert_eq!(got.iter().flatten().count(), rows.min(cols), "{rows}x{cols}");
                let mut taken: Vec<usize> = got.iter().flatten().copied().collect();
                taken.sort_unstable();
                taken.dedup();
                assert_eq!(taken.len(), rows.min(cols), "a fitted light matched twice: {got:?}");
                assert!((sum(&got) - least).abs() < 1e-5, "{rows}x{cols}: {} against {least}", sum(&got));
            }
        }
        // Nearest-first in brightness order would take column 0 for row 0 (0.6) and leave row 1 at 2.4.
        assert_eq!(least_distance_matching(&[vec![0.6, 1.0], vec![0.06, 2.4]]), vec![Some(1), Some(0)]);
    }
}
