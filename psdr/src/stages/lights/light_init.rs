//! Candidate lights for a room (PSDR-Room, "Material and lighting stage", initialisation): a grid of area lights
//! over the ceiling (one per cell of about `cell` metres, each 0.8 of its cell), less those the camera sees (a
//! light in the photo would show) or that are behind it; one large light behind the camera (what lights the
//! scene from outside the view); and a window-sized light at the middle of each wall the photo does not show
//! (an unseen window; `window_cell` makes it a row along the wall, as `unseen_window` tries after the choice).
//! `fit_lights` then finds their radiances and drops the ones the photo does not need.

use crate::render::{render_cpu, SceneData};
use crate::scene::{rectangle_mesh, Emitter, Material, Object, Pose, Scene};
use glam::{EulerRot, Quat, Vec3};

/// Knobs of the candidates.
#[derive(Clone, Debug)]
pub struct LightInitOptions {
    /// Target size of a ceiling grid cell in metres.
    pub cell: f32,
    /// Each ceiling light's size as a fraction of its cell.
    pub scale: f32,
    /// Walls showing on fewer than this fraction of the pixels count as unseen (and get window lights).
    pub unseen_wall_fraction: f32,
    /// Spacing of the window candidates along an unseen wall, metres (one per cell of about this width); 0 or
    /// less, the default: one at the wall's middle. Offered the row, the elimination chose other ceiling
    /// lights (the known-geometry test's two lights 17 and 34 cm off for 3 and 6): `unseen_window` tries it
    /// after the choice instead.
    pub window_cell: f32,
}

impl Default for LightInitOptions {
    fn default() -> Self {
        LightInitOptions { cell: 1.5, scale: 0.8, unseen_wall_fraction: 0.01, window_cell: 0.0 }
    }
}

fn light(name: String, material: usize, size: (f32, f32), at: Vec3, rot_deg: [f32; 3]) -> Object {
    let mut part = rectangle_mesh(size.0, size.1);
    part.material = material;
    let r = rot_deg.map(f32::to_radians);
    Object {
        name,
        parts: vec![part],
        pose: Pose { translation: at, rotation: Quat::from_euler(EulerRot::ZYX, r[2], r[1], r[0]), scale: Vec3::ONE },
        emitter: Some(Emitter::uniform(Vec3::ONE, false)),
    }
}

/// Replaces the emitters of a room scene (from `room_scene`, refined or not) with the candidate lights; returns
/// their names. A scene without the room's surfaces gets no candidates.
pub fn init_lights(scene: &mut Scene, opts: &LightInitOptions) -> Vec<String> {
    let at = |name: &str| scene.objects.iter().find(|o| o.name == name).map(|o| o.pose.translation);
    let (Some(floor), Some(ceiling), Some(x0), Some(x1), Some(z0), Some(z1)) =
        (at("floor"), at("ceiling"), at("wall_x0"), at("wall_x1"), at("wall_z0"), at("wall_z1"))
    else {
        return vec![];
    };
    // Which walls the photo shows: the room's own render, ids only.
    let mut probe = scene.clone();
    probe.objects.retain(|o| o.emitter.is_none());
    probe.settings.spp = 1;
    probe.settings.max_depth = 1;
    let ids =
        SceneData::build(&probe).map(|d| render_cpu(&d, &probe.settings, &|_, _| {}).object_id).unwrap_or_default();
    let shown = |name: &str| {
        let Some(o) = probe.objects.iter().position(|x| x.name == name) else { return false };
        let n = ids.iter().filter(|&&i| i == o as u32).count();
        n as f32 >= opts.unseen_wall_fraction * ids.len().max(1) as f32
    };
    scene.objects.retain(|o| o.emitter.is_none());
    // The panels' material, made once (a given geometry may have one by that name, or this may run twice).
    let m = scene.material_index("light").unwrap_or_else(|| {
        scene.materials.push(Material::diffuse("light", Vec3::splat(0.8)));
        scene.materials.len() - 1
    });
    let cam = scene.camera.clone();
    let tan_y = (cam.fov_y_deg.to_radians() * 0.5).tan();
    let tan_x = tan_y * cam.width as f32 / cam.height.max(1) as f32;
    let in_view = |p: Vec3| {
        let d = p - cam.origin;
        let z = d.dot(cam.forward);
        z > 0.0 && d.dot(cam.right()).abs() <= z * tan_x && d.dot(cam.up).abs() <= z * tan_y
    };
    let behind = |p: Vec3| (p - cam.origin).dot(cam.forward) < 0.0;
    let mut names = vec![];
    let (w, d) = (x1.x - x0.x, z1.z - z0.z);
    let (nx, nz) = ((w / opts.cell).round().max(1.0) as usize, (d / opts.cell).round().max(1.0) as usize);
    let (cw, cd) = (w / nx as f32, d / nz as f32);
    for i in 0..nx {
        for k in 0..nz {
            let p = Vec3::new(x0.x + cw * (i as f32 + 0.5), ceiling.y - 0.01, z0.z + cd * (k as f32 + 0.5));
            // Any part of it in view would show in the photo: test its corners, not only its centre.
            let (hx, hz) = (0.5 * cw * opts.scale, 0.5 * cd * opts.scale);
            let corners = [(-hx, -hz), (hx, -hz), (-hx, hz), (hx, hz)].map(|(dx, dz)| p + Vec3::new(dx, 0.0, dz));
            if in_view(p) || corners.iter().any(|c| in_view(*c)) || behind(p) {
                continue;
            }
            let name = format!("light_ceiling_{i}_{k}");
            scene.objects.push(light(name.clone(), m, (cw * opts.scale, cd * opts.scale), p, [90.0, 0.0, 0.0]));
            names.push(name);
        }
    }
    // Just behind the camera (2 cm: the wall behind may be close), facing where it looks (horizontally).
    let fwd = Vec3::new(cam.forward.x, 0.0, cam.forward.z).normalize_or_zero();
    if fwd != Vec3::ZERO {
        let p = cam.origin - fwd * 0.02;
        let yaw = fwd.x.atan2(fwd.z).to_degrees();
        scene.objects.push(light("light_behind_camera".into(), m, (1.5, 1.0), p, [0.0, yaw, 0.0]));
        names.push("light_behind_camera".into());
    }
    // Unseen walls: window-sized lights 2 cm inside each, facing into the room (a row with `window_cell`).
    let mid_y = floor.y + 0.55 * (ceiling.y - floor.y);
    let (cx, cz) = ((x0.x + x1.x) / 2.0, (z0.z + z1.z) / 2.0);
    let row = |len: f32| {
        let n = if opts.window_cell > 0.0 { (len / opts.window_cell).round().max(1.0) as usize } else { 1 };
        (0..n).map(move |i| (i as f32 + 0.5) / n as f32 - 0.5).map(move |t| t * len).collect::<Vec<f32>>()
    };
    for (wall, p, along, len, yaw) in [
        ("wall_x0", Vec3::new(x0.x + 0.02, mid_y, cz), Vec3::Z, d, 90.0),
        ("wall_x1", Vec3::new(x1.x - 0.02, mid_y, cz), Vec3::Z, d, -90.0),
        ("wall_z0", Vec3::new(cx, mid_y, z0.z + 0.02), Vec3::X, w, 0.0),
        ("wall_z1", Vec3::new(cx, mid_y, z1.z - 0.02), Vec3::X, w, 180.0),
    ] {
        if shown(wall) {
            continue;
        }
        let offsets = row(len);
        for (i, t) in offsets.iter().enumerate() {
            let name =
                if offsets.len() == 1 { format!("light_window_{wall}") } else { format!("light_window_{wall}_{i}") };
            scene.objects.push(light(name.clone(), m, (1.2, 1.0), p + along * *t, [0.0, yaw, 0.0]));
            names.push(name);
        }
    }
    names
}
