//! Ceiling lights the photo shows become area lights where their pixels are. The candidate grid
//! (`init_lights`) leaves out every place the camera sees, as a light there would show in the photo; where the
//! photo does show one (a bright panel on the ceiling, at the 8-bit photo's white), nothing stood in for it and
//! the fit lit the room from elsewhere (real room00: two panels in view, both left out; a window 10x too bright
//! lit the room). Each connected patch of light-source pixels (every channel near white and one clipped in an
//! 8-bit photo; 20x the median luminance in a high-dynamic-range one) that lies on the ceiling (its ray meets
//! the ceiling plane where the depth says, or the depth is missing), that no furniture instance covers and the
//! frame does not cut becomes an emissive rectangle 1 cm under the ceiling over the range of its pixels'
//! points, its outline then fitted to the photo's pixels (`emitter_outline`), facing down, radiance 1 (the
//! light fit scales it). Named `light_panel_K`; like a window the photo
//! shows, the fits never remove it and the placement leaves it where it is. A patch the frame cuts is either a
//! light partly in view or a brightly lit white ceiling clipping there (real room01's strip of ceiling above a
//! window), so it becomes a candidate like the grid's (`light_edge_K`, over the part in view): the fit removes
//! it where the photo does not need it, and the placement may move and resize its part out of view
//! (`light_view`). Left out, nothing could light those pixels: the grid leaves out every place in view (real
//! room10's ceiling light in the photo's corner was matched only while a grid candidate happened to be moved
//! next to it).

use super::emitter_outline::{refine_outline, PlaneRect};
use crate::base::{connected_regions, Intrinsics};
use crate::scene::{rectangle_mesh, Emitter, Material, Object, Pose, Scene};
use crate::vision::{is_low_dynamic_range, Instances, CLIPPED_LINEAR};
use glam::{Quat, Vec3};

/// Whether `name` is a ceiling light the photo shows (`light_panel_K`, from `add_visible_ceiling_lights`).
pub fn is_visible_ceiling_light(name: &str) -> bool {
    name.strip_prefix("light_panel_").is_some_and(|k| k.parse::<u32>().is_ok())
}

/// Whether `name` is a ceiling light the frame cuts (`light_edge_K`): the placement keeps its part in view.
pub fn is_edge_ceiling_light(name: &str) -> bool {
    name.strip_prefix("light_edge_").is_some_and(|k| k.parse::<u32>().is_ok())
}

/// Whether a pixel (linear RGB) looks like a light source: in an 8-bit photo near white with a channel at its
/// top; else far brighter than the photo's median.
pub(super) fn light_pixels(photo: &[f32]) -> Vec<bool> {
    if is_low_dynamic_range(photo) {
        return photo
            .chunks(3)
            .map(|c| c.iter().all(|v| *v >= 0.8 * CLIPPED_LINEAR) && c.iter().any(|v| *v >= CLIPPED_LINEAR))
            .collect();
    }
    let lum: Vec<f32> = photo.chunks(3).map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]).collect();
    let mut sorted = lum.clone();
    sorted.sort_by(f32::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    lum.iter().map(|l| median > 0.0 && *l >= 20.0 * median).collect()
}

/// Whether an 8-bit photo's pixel is white in every channel: an emitter brighter than white clips all three
/// over its whole area, its edges too.
fn fully_clipped(c: &[f32]) -> bool {
    c.iter().all(|v| *v >= CLIPPED_LINEAR)
}

/// The pixels of `patch` (light-source pixels, `light_pixels`) that say where the light is: in an 8-bit photo
/// the largest 4-connected run of its pixels white in every channel, where that is at least half of them (a
/// tinted light may clip one channel only); else all of them.
/// A ceiling lit near white beside a light clips one channel and, in scattered pixels, all three: joined to
/// the light's patch it stretched the panel over it (real room00: a 0.79 m panel fitted 1.56 x 1.30 m, at a
/// third of its radiance, with the true materials given).
fn light_core(patch: &[usize], photo: &[f32], width: usize, ldr: bool) -> Vec<usize> {
    if !ldr {
        return patch.to_vec();
    }
    let mut white = vec![false; photo.len() / 3];
    for &p in patch {
        white[p] = fully_clipped(&photo[3 * p..3 * p + 3]);
    }
    let core = connected_regions(&white, width)
        .into_iter()
        .filter(|r| white[r[0]])
        .max_by_key(|r| r.len())
        .unwrap_or_default();
    if core.len() >= 4 && 2 * core.len() >= patch.len() {
        core
    } else {
        patch.to_vec()
    }
}

/// How far (pixels) the photo may move a ceiling light's edges from its pixels' range.
const OUTLINE_MARGIN: f32 = 4.0;

fn percentile(v: &mut [f32], q: f32) -> f32 {
    v.sort_by(f32::total_cmp);
    v[((v.len() - 1) as f32 * q).round() as usize]
}

/// Adds an emitter for every patch of at least `min_pixels` light-source pixels on the ceiling of `scene` (a
/// room scene with a `ceiling`); `photo` (linear RGB), `depth` (camera-space z, 0 = none) and `inst` at the
/// camera's size. Returns their names.
pub fn add_visible_ceiling_lights(
    scene: &mut Scene,
    photo: &[f32],
    depth: &[f32],
    inst: Option<&Instances>,
    min_pixels: usize,
) -> Vec<String> {
    let cam = scene.camera.clone();
    let (w, h) = (cam.width as usize, cam.height as usize);
    let Some(ceiling_y) = scene.objects.iter().find(|o| o.name == "ceiling").map(|o| o.pose.translation.y) else {
        return vec![];
    };
    if w < 3 || h < 3 || photo.len() != w * h * 3 || depth.len() != w * h {
        return vec![];
    }
    let k = Intrinsics::new(w, h, cam.fov_y_deg);
    let (right, up, fwd) = (cam.right(), cam.up, cam.forward);
    // Furniture covers a pixel when its instance is neither the ceiling nor unlabelled.
    let furniture = |p: usize| {
        inst.is_some_and(|i| {
            let id = i.ids[p];
            id != 0 && i.instances.iter().any(|x| x.id == id && x.class != "ceiling")
        })
    };
    let bright = light_pixels(photo);
    let ldr = is_low_dynamic_range(photo);
    // Each light pixel's point on the ceiling plane, where its ray meets it in front of the camera and the
    // depth (if any) agrees within 15 %.
    let on_ceiling: Vec<Option<Vec3>> = (0..w * h)
        .map(|p| {
            if !bright[p] || furniture(p) {
                return None;
            }
            let c = k.point(p % w, p / w, 1.0);
            let dir = right * c.x + up * c.y + fwd * c.z;
            let t = (ceiling_y - cam.origin.y) / dir.y;
            if !(t > 0.0 && t.is_finite()) {
                return None;
            }
            let agrees = depth[p] <= 0.0 || (depth[p] / t - 1.0).abs() < 0.15;
            agrees.then(|| cam.origin + dir * t)
        })
        .collect();
    // Connected patches (4-neighbours) of such pixels.
    let on: Vec<bool> = on_ceiling.iter().map(Option::is_some).collect();
    // A light in full view is a patch with ceiling all round it; one that reaches the image's border may be a
    // light cut by the frame or a lit white ceiling clipping there (a candidate, not a visible light).
    let inside = |p: usize| (1..w - 1).contains(&(p % w)) && (1..h - 1).contains(&(p / w));
    let patches: Vec<(bool, Vec<Vec3>)> = connected_regions(&on, w)
        .into_iter()
        .filter(|r| on[r[0]] && r.len() >= min_pixels.max(4))
        .map(|r| {
            let core = light_core(&r, photo, w, ldr);
            (r.iter().all(|&p| inside(p)), core.iter().filter_map(|&p| on_ceiling[p]).collect())
        })
        .collect();
    let material = scene.material_index("light").unwrap_or_else(|| {
        scene.materials.push(Material::diffuse("light", Vec3::splat(0.8)));
        scene.materials.len() - 1
    });
    let mut names = vec![];
    let (mut panels, mut edges) = (0, 0);
    for (in_view, points) in patches {
        // First the 2-98 % range of the pixels' points, not widened as for windows: a light's edge pixels clip
        // too (a tenth of its radiance is already white), so the patch reaches past the light by up to a
        // pixel's footprint, which at a grazing view of the ceiling is several centimetres (the full range made
        // a 1.2 m panel 1.28 m deep, the windows' widened range 1.25 m).
        let (mut xs, mut zs): (Vec<f32>, Vec<f32>) = points.iter().map(|p| (p.x, p.z)).unzip();
        let (x0, x1, z0, z1) = (
            percentile(&mut xs, 0.02),
            percentile(&mut xs, 0.98),
            percentile(&mut zs, 0.02),
            percentile(&mut zs, 0.98),
        );
        let mut rect = PlaneRect {
            origin: Vec3::Y * (ceiling_y - 0.01),
            a: Vec3::X,
            b: Vec3::Z,
            u: [x0.min(x1 - 0.05), x1],
            v: [z0.min(z1 - 0.05), z1],
        };
        // Then its outline fitted to the photo's pixels around it, furniture left out.
        if let Some(o) = refine_outline(&cam, photo, &|p| !furniture(p), rect, OUTLINE_MARGIN, ldr, None) {
            rect = o.rect;
        }
        let (centre, sx, sz) = rect.centre_and_size();
        let mut part = rectangle_mesh(sx, sz);
        part.material = material;
        let name = if in_view {
            panels += 1;
            format!("light_panel_{}", panels - 1)
        } else {
            edges += 1;
            format!("light_edge_{}", edges - 1)
        };
        scene.objects.push(Object {
            name: name.clone(),
            parts: vec![part],
            // The rectangle lies in its x-y plane facing +z: turned to lie in x-z facing down.
            pose: Pose {
                translation: centre,
                rotation: Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
                scale: Vec3::ONE,
            },
            emitter: Some(Emitter::uniform(Vec3::ONE, false)),
        });
        names.push(name);
    }
    names
}
