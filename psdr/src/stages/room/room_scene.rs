//! The room box as a scene: floor, ceiling and four walls as separate objects (so each has its own mask and
//! its own pose parameter), a grey material per class and a ceiling light. Each surface is a rectangle three
//! times the room's extent: seen from inside a convex room the overhang lies behind the neighbouring
//! surfaces, so a wall can slide along its normal (the box's size and position) without leaving a gap.

use crate::scene::{rectangle_mesh, Camera, Emitter, Material, Object, Pose, RenderSettings, Scene};
use crate::vision::RoomEstimate;
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
        // uv in metres: a texture's uv scale is its repeats per metre.
        part.uvs.iter_mut().flatten().for_each(|uv| *uv *= size);
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
            Some(Emitter::uniform(Vec3::splat(8.0), false)),
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

/// The room of a scene built by `room_scene` (after any refinement), for `result.json`: size, bounds, each
/// surface's plane (world normal pointing into the room, n·p = d) and the camera relative to the room (height
/// above the floor, pitch, roll, fov). None when the scene has no room surfaces.
pub fn room_summary(scene: &Scene) -> Option<serde_json::Value> {
    let at = |name: &str| scene.objects.iter().find(|o| o.name == name).map(|o| o.pose.translation);
    let (floor, ceiling) = (at("floor")?, at("ceiling")?);
    let (x0, x1, z0, z1) = (at("wall_x0")?, at("wall_x1")?, at("wall_z0")?, at("wall_z1")?);
    let plane = |n: Vec3, p: Vec3| serde_json::json!({ "normal": n.to_array(), "d": n.dot(p) });
    let c = &scene.camera;
    let right = c.forward.cross(c.up).normalize();
    Some(serde_json::json!({
        "width": x1.x - x0.x,
        "depth": z1.z - z0.z,
        "height": ceiling.y - floor.y,
        "x_range": [x0.x, x1.x],
        "z_range": [z0.z, z1.z],
        "floor_y": floor.y,
        "planes": {
            "floor": plane(Vec3::Y, floor),
            "ceiling": plane(-Vec3::Y, ceiling),
            "wall_x0": plane(Vec3::X, x0),
            "wall_x1": plane(-Vec3::X, x1),
            "wall_z0": plane(Vec3::Z, z0),
            "wall_z1": plane(-Vec3::Z, z1),
        },
        "camera": {
            "position": c.origin.to_array(),
            "height_above_floor": c.origin.y - floor.y,
            "pitch_deg": c.forward.y.clamp(-1.0, 1.0).asin().to_degrees(),
            "roll_deg": right.y.atan2(c.up.y).to_degrees(),
            "fov_y_deg": c.fov_y_deg,
        },
    }))
}
