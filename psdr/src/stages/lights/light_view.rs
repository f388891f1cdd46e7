//! The photo's pixels a light covers: the pixels whose camera ray meets its emitting face (occlusion ignored).
//! A ceiling light the frame cuts (`light_edge_K`, `ceiling_panels`) is known where the photo shows it: its
//! part in view is the patch of white pixels it came from, and only its part out of view is a guess. The
//! placement keeps the pixels it covers (`keeps_view`) and moves only that guess; moved freely, real room10's
//! corner light kept a quarter of its patch in view and half the photo's image error sat in that corner.

use crate::base::Intrinsics;
use crate::scene::{Object, Scene};
use glam::Vec3;

/// Per photo pixel (row-major, the camera's size), whether its ray meets the emitting face of `object`: a planar
/// light (a rectangle in its local x-y plane, facing +z), tested against its local x-y bounds.
pub(super) fn pixels_covered(scene: &Scene, object: &Object) -> Vec<bool> {
    let cam = &scene.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let (lo, hi) = local_bounds(object);
    if !(lo.x <= hi.x && lo.y <= hi.y) {
        return vec![false; w * h];
    }
    let to_local = object.pose.matrix().inverse();
    let normal = object.pose.rotation * Vec3::Z;
    let k = Intrinsics::new(w, h, cam.fov_y_deg);
    let (right, up, fwd) = (cam.right(), cam.up, cam.forward);
    (0..w * h)
        .map(|p| {
            let c = k.point(p % w, p / w, 1.0);
            let dir = right * c.x + up * c.y + fwd * c.z;
            let t = (object.pose.translation - cam.origin).dot(normal) / dir.dot(normal);
            if !(t > 0.0 && t.is_finite()) {
                return false;
            }
            let q = to_local.transform_point3(cam.origin + dir * t);
            (lo.x..=hi.x).contains(&q.x) && (lo.y..=hi.y).contains(&q.y)
        })
        .collect()
}

/// The bounds of an object's vertices in its own frame (before its pose).
pub(super) fn local_bounds(object: &Object) -> (Vec3, Vec3) {
    object
        .parts
        .iter()
        .flat_map(|p| &p.positions)
        .fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), v| (lo.min(*v), hi.max(*v)))
}

/// Whether a light that covered `before` and now covers `after` still shows where the photo shows it: the pixels
/// it covers that are not light-source pixels (`bright`), plus those of `before`'s light-source pixels it no
/// longer covers, are at most `tolerance` of the latter more than at `before`. Covering more light-source pixels
/// is free (the start's rectangle spans the 2-98 % range of its patch's points, short of the frame).
pub(super) fn keeps_view(before: &[bool], after: &[bool], bright: &[bool], tolerance: f32) -> bool {
    let shown = |p: usize| before[p] && bright[p];
    let misfit =
        |cover: &[bool]| (0..before.len()).filter(|&p| (cover[p] && !bright[p]) || (shown(p) && !cover[p])).count();
    let reference = (0..before.len()).filter(|&p| shown(p)).count();
    misfit(after) as f32 <= misfit(before) as f32 + tolerance * reference as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{rectangle_mesh, Camera, Pose};
    use glam::Quat;

    /// A 1 m square on a ceiling 1 m above a camera looking up covers the pixels the pinhole projection puts it
    /// on: at a 90-degree field of view and 1 m, the image spans 2 m, so the square covers the middle half of
    /// each axis.
    #[test]
    fn a_ceiling_square_covers_its_projection() {
        let scene = Scene::empty(Camera::look_at(Vec3::ZERO, Vec3::Y, Vec3::Z, 90.0, 64, 64));
        let object = Object {
            name: "light_edge_0".into(),
            parts: vec![rectangle_mesh(1.0, 1.0)],
            pose: Pose {
                translation: Vec3::Y,
                rotation: Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
                scale: Vec3::ONE,
            },
            emitter: None,
        };
        let covered = pixels_covered(&scene, &object);
        let count = covered.iter().filter(|&&c| c).count();
        assert_eq!(count, 32 * 32, "{count} pixels");
        assert!(covered[32 * 64 + 32] && !covered[0] && !covered[10 * 64 + 32]);
        // Moved 0.25 m along its plane it covers a quarter fewer pixels of the same column: the view changed.
        let mut moved = object.clone();
        moved.pose.translation.x += 0.25;
        let after = pixels_covered(&scene, &moved);
        assert!(!keeps_view(&covered, &after, &covered, 0.05));
        assert!(keeps_view(&covered, &covered, &covered, 0.0));
        // Where the photo's light reaches further in that direction (the frame cut it), the move is kept.
        let bright: Vec<bool> = covered.iter().zip(&after).map(|(a, b)| *a || *b).collect();
        assert!(!keeps_view(&covered, &after, &bright, 0.0), "it uncovers pixels it showed");
        let mut grown = object.clone();
        grown.pose.translation.x += 0.125;
        grown.pose.scale.x = 1.25;
        assert!(keeps_view(&covered, &pixels_covered(&scene, &grown), &bright, 0.0));
    }
}
