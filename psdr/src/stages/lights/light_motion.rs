//! How a light may move when the joint fit optimises its pose by gradient (its boundary and interior terms are
//! those of any moving object): along its own plane (a ceiling light along the ceiling, a window along its
//! wall), kept inside the room, and resized in that plane within a range of its size now. The lights psdr makes
//! are rectangles turned to a room's axes (`init_lights`, `add_visible_windows`), so the plane is two world
//! axes; a light turned otherwise (a given geometry's) keeps its place and only changes size.

use super::light_placement::room_box;
use crate::error::{Error, Result};
use crate::scene::Scene;
use glam::Vec3;

/// A light's freedom in the joint fit.
#[derive(Clone, Debug, PartialEq)]
pub struct LightMotion {
    /// World axes of the light's plane, in xyz order ("xz" for a ceiling light), when its own x and y lie along
    /// world axes.
    pub plane_axes: Option<String>,
    /// Bounds of its translation: every corner inside the room at any size it may take (none without a room).
    pub translation: Option<(Vec3, Vec3)>,
    /// Bounds of its scale along its own axes (z, the flat one, stays).
    pub scale: (Vec3, Vec3),
}

/// The world axis (0, 1, 2) a unit direction lies along, within a degree.
fn world_axis(d: Vec3) -> Option<usize> {
    (0..3).find(|&a| d[a].abs() > 1f32.to_radians().cos())
}

/// The freedom of light `name` in `scene`: its size may range over `size_range` times its size now (less
/// where the room leaves no space to grow).
pub fn light_motion(scene: &Scene, name: &str, size_range: (f32, f32)) -> Result<LightMotion> {
    let i =
        scene.object_index(name).ok_or_else(|| Error::Invalid(format!("light_motion: no object named '{name}'")))?;
    let o = &scene.objects[i];
    if o.emitter.is_none() {
        return Err(Error::Invalid(format!("light_motion: '{name}' does not emit")));
    }
    let (lo_k, hi_k) = size_range;
    if !(lo_k > 0.0 && lo_k <= 1.0 && hi_k >= 1.0 && hi_k.is_finite()) {
        return Err(Error::Invalid(format!("light_motion: size range {lo_k}..{hi_k} must hold 1 and be positive")));
    }
    let p = o.pose;
    let own = [p.rotation * Vec3::X, p.rotation * Vec3::Y];
    let axes = own.map(world_axis);
    let plane = match axes {
        [Some(a), Some(b)] if a != b => Some([a, b]),
        _ => None,
    };
    // Half the light's extent along each world axis, about its origin (rectangles are centred on it).
    let m = p.matrix();
    let mut half = Vec3::ZERO;
    for v in o.parts.iter().flat_map(|q| &q.positions) {
        half = half.max((m.transform_point3(*v) - p.translation).abs());
    }
    let room = room_box(scene);
    // The largest growth that keeps it inside where it is: each in-plane axis's gap to the nearer wall.
    let mut grow = hi_k;
    if let (Some([a, b]), Some((lo, hi))) = (plane, room) {
        for w in [a, b] {
            if half[w] > 1e-6 {
                let gap = (p.translation[w] - half[w] - lo[w]).min(hi[w] - p.translation[w] - half[w]).max(0.0);
                grow = grow.min((half[w] + gap) / half[w]);
            }
        }
    }
    let grow = grow.max(1.0);
    let in_plane = Vec3::new(1.0, 1.0, 0.0);
    let scale_range = |k: f32| p.scale * (in_plane * k + Vec3::Z);
    let translation = match (plane, room) {
        (Some(_), Some((lo, hi))) => {
            let reach = half * grow;
            // Out of plane it stays where it is (the optimiser locks that axis; the bound only has to hold it).
            let (mut a, mut b) = (lo + reach, hi - reach);
            for w in 0..3 {
                let out_of_plane = Some(w) != axes[0] && Some(w) != axes[1];
                if out_of_plane || a[w] > p.translation[w] || b[w] < p.translation[w] {
                    (a[w], b[w]) = (a[w].min(p.translation[w]), b[w].max(p.translation[w]));
                }
            }
            Some((a, b))
        }
        _ => None,
    };
    let plane_axes = plane.map(|mut ab| {
        ab.sort();
        ab.iter().map(|&a| ['x', 'y', 'z'][a]).collect::<String>()
    });
    Ok(LightMotion { plane_axes, translation, scale: (scale_range(lo_k), scale_range(grow)) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{rectangle_mesh, Camera, Emitter, Object, Pose};
    use glam::{EulerRot, Quat};

    fn wall(name: &str, at: Vec3) -> Object {
        Object { name: name.into(), parts: vec![], pose: Pose { translation: at, ..Pose::default() }, emitter: None }
    }

    /// A 4 x 3 x 2.5 m room with a 1 x 1 m ceiling light 0.2 m from the x1 wall and a window on the x0 wall.
    fn room() -> Scene {
        let camera = Camera::look_at(Vec3::new(0.0, 1.5, 1.0), Vec3::new(0.0, 1.5, 0.0), Vec3::Y, 60.0, 8, 8);
        let mut s = Scene::empty(camera);
        for (n, at) in [
            ("floor", Vec3::ZERO),
            ("ceiling", Vec3::new(0.0, 2.5, 0.0)),
            ("wall_x0", Vec3::new(-2.0, 0.0, 0.0)),
            ("wall_x1", Vec3::new(2.0, 0.0, 0.0)),
            ("wall_z0", Vec3::new(0.0, 0.0, -1.5)),
            ("wall_z1", Vec3::new(0.0, 0.0, 1.5)),
        ] {
            s.objects.push(wall(n, at));
        }
        let light = |name: &str, size: (f32, f32), at: Vec3, rot: Quat| Object {
            name: name.into(),
            parts: vec![rectangle_mesh(size.0, size.1)],
            pose: Pose { translation: at, rotation: rot, scale: Vec3::ONE },
            emitter: Some(Emitter::uniform(Vec3::ONE, false)),
        };
        let down = Quat::from_euler(EulerRot::ZYX, 0.0, 0.0, 90f32.to_radians());
        s.objects.push(light("lamp", (1.0, 1.0), Vec3::new(1.3, 2.49, 0.0), down));
        s.objects.push(light(
            "window",
            (1.2, 1.0),
            Vec3::new(-1.98, 1.4, 0.0),
            Quat::from_rotation_y(90f32.to_radians()),
        ));
        s.objects.push(light("tilted", (1.0, 1.0), Vec3::new(0.0, 2.0, 0.0), Quat::from_rotation_x(0.3)));
        s
    }

    #[test]
    fn a_light_moves_in_its_plane_inside_the_room() {
        let s = room();
        let c = light_motion(&s, "lamp", (0.5, 2.0)).unwrap();
        assert_eq!(c.plane_axes.as_deref(), Some("xz"));
        // 0.2 m to the x1 wall (+2 cm slack): it may grow to (0.5 + 0.22) / 0.5 = 1.44 of its size.
        let (lo, hi) = c.translation.unwrap();
        assert!((c.scale.1.x - 1.44).abs() < 1e-3 && (c.scale.1.y - 1.44).abs() < 1e-3, "{:?}", c.scale);
        assert!((c.scale.0.x - 0.5).abs() < 1e-6 && c.scale.1.z == 1.0);
        // At that size it still fits anywhere within the bounds, and where it is lies within them.
        assert!((hi.x - (2.02 - 0.72)).abs() < 1e-3 && (lo.x - (-2.02 + 0.72)).abs() < 1e-3, "{lo} {hi}");
        assert!((hi.z - (1.52 - 0.72)).abs() < 1e-3);
        assert!(lo.y <= 2.49 && hi.y >= 2.49);
        let w = light_motion(&s, "window", (0.5, 2.0)).unwrap();
        assert_eq!(w.plane_axes.as_deref(), Some("yz"));
        let t = light_motion(&s, "tilted", (0.5, 2.0)).unwrap();
        assert_eq!((t.plane_axes, t.translation), (None, None));
        assert!(light_motion(&s, "floor", (0.5, 2.0)).is_err(), "not a light");
        assert!(light_motion(&s, "lamp", (1.5, 2.0)).is_err(), "a range without 1");
    }
}
