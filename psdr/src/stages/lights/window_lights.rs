//! Windows the photo shows become area lights (PSDR-Room: "visible windows and lamps made emissive"): each
//! window instance's pixels are back-projected with the depth, the wall they lie on is the scene's nearest
//! wall plane, and the window is the range of its points on that wall, an emissive rectangle 1 cm in
//! front of it, radiance 1 (the light fit scales it), its outline then fitted to the photo's pixels
//! (`emitter_outline`). Named `light_window_ID`, so the light fit and the material stage treat it as a light.

use super::emitter_outline::{refine_outline, PlaneRect};
use crate::base::Intrinsics;
use crate::scene::{rectangle_mesh, Emitter, Material, Object, Pose, Scene};
use crate::vision::{is_low_dynamic_range, Instances};
use glam::{Quat, Vec3};

/// Whether `name` is a window the photo shows (`light_window_ID`, ID its instance), as opposed to a candidate
/// window on a wall the photo does not show (`light_window_wall_x0`, `light_init`): its place and size are
/// its pixels', so the placement searches leave it where it is.
pub fn is_visible_window(name: &str) -> bool {
    name.strip_prefix("light_window_").is_some_and(|id| id.parse::<u32>().is_ok())
}

/// How far (pixels) the photo may move a window's edges from its pixels' range.
const OUTLINE_MARGIN: f32 = 4.0;

/// Whether instance `id` of `inst` is a room surface (a wall, the floor, the ceiling).
pub(crate) fn is_room_surface(inst: &Instances, id: u16) -> bool {
    inst.instances.iter().any(|x| x.id == id && ["wall", "floor", "ceiling"].contains(&x.class.as_str()))
}

/// Whether pixel `p` of `inst` tells where window instance `id`'s outline is: within 2 pixels of its mask (a
/// pixel it covers in part reads white though its centre is the wall's; further out a clipped wall is the
/// light's hot spot, not the window: real room04's wall beside its window clips), and the window's, the
/// room's or no instance's (furniture before it, or another window, are not its background).
pub(crate) fn near_window(inst: &Instances, id: u16, p: usize) -> bool {
    let (w, h) = (inst.width, inst.height);
    let own = inst.ids[p];
    if !(own == id || own == 0 || is_room_surface(inst, own)) {
        return false;
    }
    let (x, y) = (p % w, p / w);
    (y.saturating_sub(2)..(y + 3).min(h))
        .any(|yy| (x.saturating_sub(2)..(x + 3).min(w)).any(|xx| inst.ids[yy * w + xx] == id))
}

fn percentile(v: &mut [f32], q: f32) -> f32 {
    v.sort_by(f32::total_cmp);
    v[((v.len() - 1) as f32 * q).round() as usize]
}

/// Adds an emitter for every window instance of `inst` with at least `min_pixels` pixels of depth, its outline
/// fitted to `photo`'s pixels where it is given (linear RGB at the camera's size, `refine_outline`); returns
/// their names.
pub fn add_visible_windows(
    scene: &mut Scene,
    photo: Option<&[f32]>,
    depth: &[f32],
    inst: &Instances,
    min_pixels: usize,
) -> Vec<String> {
    let cam = scene.camera.clone();
    let k = Intrinsics::new(inst.width, inst.height, cam.fov_y_deg);
    let (right, up, fwd) = (cam.right(), cam.up, cam.forward);
    let walls: Vec<(Vec3, f32)> = scene
        .objects
        .iter()
        .filter(|o| o.name.starts_with("wall"))
        .map(|o| {
            let n = (o.pose.rotation * Vec3::Z).normalize();
            (n, n.dot(o.pose.translation))
        })
        .filter(|(n, _)| n.y.abs() < 0.1)
        .collect();
    let mut names = vec![];
    for i in inst.instances.iter().filter(|i| i.class == "window") {
        let points: Vec<Vec3> = (0..inst.width * inst.height)
            .filter(|&p| inst.ids[p] == i.id && depth[p] > 0.0)
            .map(|p| {
                let c = k.point(p % inst.width, p / inst.width, depth[p]);
                cam.origin + right * c.x + up * c.y + fwd * c.z
            })
            .collect();
        if points.len() < min_pixels.max(4) {
            continue;
        }
        // The wall the points lie on: the one with the least median distance to them.
        let distance = |(n, d): &(Vec3, f32)| {
            let mut v: Vec<f32> = points.iter().map(|p| (n.dot(*p) - d).abs()).collect();
            percentile(&mut v, 0.5)
        };
        let Some(&(n, d)) = walls.iter().min_by(|a, b| distance(a).total_cmp(&distance(b))) else { continue };
        let across = Vec3::Y.cross(n).normalize();
        let (mut us, mut vs): (Vec<f32>, Vec<f32>) = points.iter().map(|p| (p.dot(across), p.y)).unzip();
        // The 2-98 % range, widened by the 4 % of a uniform spread it leaves out (a few stray edge pixels do
        // not stretch the window).
        let (u0, u1, v0, v1) = (
            percentile(&mut us, 0.02),
            percentile(&mut us, 0.98),
            percentile(&mut vs, 0.02),
            percentile(&mut vs, 0.98),
        );
        if u1 - u0 < 0.05 || v1 - v0 < 0.05 {
            continue;
        }
        let (du, dv) = ((u1 - u0) / 0.96 - (u1 - u0), (v1 - v0) / 0.96 - (v1 - v0));
        let mut rect = PlaneRect {
            origin: n * (d + 0.01),
            a: across,
            b: Vec3::Y,
            u: [u0 - du / 2.0, u1 + du / 2.0],
            v: [v0 - dv / 2.0, v1 + dv / 2.0],
        };
        // The outline from the photo's pixels where it has them (a window the frame cuts keeps its range
        // beyond the frame: no pixel there pulls on it). Other windows and furniture are not its background.
        if let Some(photo) = photo {
            let usable = |p: usize| near_window(inst, i.id, p);
            if let Some(o) =
                refine_outline(&cam, photo, &usable, rect, OUTLINE_MARGIN, is_low_dynamic_range(photo), None)
            {
                rect = o.rect;
            }
        }
        let (centre, width, height) = rect.centre_and_size();
        if scene.materials.iter().all(|m| m.name != "window") {
            scene.materials.push(Material::diffuse("window", Vec3::splat(0.8)));
        }
        let m = scene.materials.iter().position(|m| m.name == "window").unwrap_or(0);
        let mut part = rectangle_mesh(width, height);
        part.material = m;
        let name = format!("light_window_{}", i.id);
        scene.objects.push(Object {
            name: name.clone(),
            parts: vec![part],
            // The rectangle faces +z: turned about the vertical to face into the room.
            pose: Pose { translation: centre, rotation: Quat::from_rotation_y(n.x.atan2(n.z)), scale: Vec3::ONE },
            emitter: Some(Emitter::uniform(Vec3::ONE, false)),
        });
        names.push(name);
    }
    names
}
