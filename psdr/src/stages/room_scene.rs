//! The room box as a scene: floor, ceiling and four walls as separate objects (so each has its own mask and
//! its own pose parameter), a grey material per class and a ceiling light. Each surface is a rectangle three
//! times the room's extent: seen from inside a convex room the overhang lies behind the neighbouring
//! surfaces, so a wall can slide along its normal (the box's size and position) without leaving a gap.

use super::room_init::RoomEstimate;
use crate::scene::{rectangle_mesh, Camera, Emitter, Material, Object, Pose, RenderSettings, Scene};
use glam::{EulerRot, Mat4, Quat, Vec3};

/// Object names of the room's surfaces and the axis each slides along.
pub const ROOM_SURFACES: [(&str, &str); 6] =
    [("floor", "y"), ("ceiling", "y"), ("wall_x0", "x"), ("wall_x1", "x"), ("wall_z0", "z"), ("wall_z1", "z")];

/// The scene of an estimated room seen by its camera (`fov_y_deg`, `width` x `height` pixels).
pub fn room_scene(e: &RoomEstimate, fov_y_deg: f32, width: u32, height: u32) -> Scene {
    let (w, d, h) = (e.width, e.depth, e.height);
    let (cx, cz) = (e.x_min + w / 2.0, e.z_min + d / 2.0);
    let span = 3.0 * w.max(d).max(h);
    let rect = |name: &str, material: usize, t: Vec3, rot_deg: [f32; 3], emitter: Option<Emitter>, size: f32| {
        let mut part = rectangle_mesh(size, size);
        part.material = material;
        let r = rot_deg.map(f32::to_radians);
        Object {
            name: name.to_string(),
            parts: vec![part],
            pose: Pose {
                translation: t,
                rotation: Quat::from_euler(EulerRot::ZYX, r[2], r[1], r[0]),
                scale: Vec3::ONE,
            },
            emitter,
        }
    };
    let objects = vec![
        rect("floor", 0, Vec3::new(cx, 0.0, cz), [-90.0, 0.0, 0.0], None, span),
        rect("ceiling", 2, Vec3::new(cx, h, cz), [90.0, 0.0, 0.0], None, span),
        rect("wall_x0", 1, Vec3::new(e.x_min, h / 2.0, cz), [0.0, 90.0, 0.0], None, span),
        rect("wall_x1", 1, Vec3::new(e.x_min + w, h / 2.0, cz), [0.0, -90.0, 0.0], None, span),
        rect("wall_z0", 1, Vec3::new(cx, h / 2.0, e.z_min), [0.0, 0.0, 0.0], None, span),
        rect("wall_z1", 1, Vec3::new(cx, h / 2.0, e.z_min + d), [0.0, 180.0, 0.0], None, span),
        rect(
            "ceiling_light",
            2,
            Vec3::new(cx, h - 0.01, cz),
            [90.0, 0.0, 0.0],
            Some(Emitter { radiance: Vec3::splat(8.0), two_sided: false }),
            0.6,
        ),
    ];
    let materials = vec![
        Material::diffuse("floor", Vec3::splat(0.45)),
        Material::diffuse("wall", Vec3::splat(0.7)),
        Material::diffuse("ceiling", Vec3::splat(0.8)),
    ];
    let m = Mat4::from_cols_array_2d(&e.camera_to_world).transpose();
    Scene {
        camera: Camera::from_matrix(m, fov_y_deg, width, height),
        settings: RenderSettings { spp: 16, max_depth: 3, rr_depth: 3, seed: 0 },
        materials,
        textures: vec![],
        objects,
        source: None,
        requires_grad: vec![],
    }
}
