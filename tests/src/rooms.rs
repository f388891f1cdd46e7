//! Rooms rendered by psdr for the room stage's tests: a box of floor, ceiling and four walls (separate objects,
//! room centred at the origin in x and z, floor at y = 0), furniture boxes on the floor, a ceiling light, and
//! optionally textures that give a photo straight lines (a checker floor, panelled walls), as real rooms have.

use glam::{EulerRot, Quat, Vec2, Vec3};
use psdr::scene::{
    box_mesh, rectangle_mesh, Camera, Color, Emitter, Material, Object, Pose, RenderSettings, Scene, Texture,
    UvTransform,
};

/// A room and the camera in it.
#[derive(Clone, Debug)]
pub struct RoomSpec {
    pub w: f32,
    pub d: f32,
    pub h: f32,
    pub cam: Vec3,
    pub yaw: f32,
    pub pitch: f32,
    pub fov: f32,
}

/// A furniture box: centre on the floor (x, z), size (x, y, z), yaw in degrees.
#[derive(Clone, Copy, Debug)]
pub struct FurnitureBox {
    pub x: f32,
    pub z: f32,
    pub size: Vec3,
    pub yaw: f32,
}

/// A checker texture of n x n cells (linear albedos `a` and `b`).
fn checker(n: u32, a: f32, b: f32) -> Texture {
    let res = n * 32;
    let texels = (0..res * res)
        .flat_map(|p| {
            let (x, y) = (p % res / 32, p / res / 32);
            let v = if (x + y) % 2 == 0 { a } else { b };
            [v, v, v]
        })
        .collect();
    Texture { path: None, width: res, height: res, channels: 3, texels }
}

/// Vertical stripes (panelling): `n` panels with a dark seam at each edge.
fn panels(n: u32) -> Texture {
    let res = n * 64;
    let texels = (0..res * 4).flat_map(|p| {
        let x = p % res;
        let v = if x % 64 < 2 { 0.25 } else { 0.7 };
        [v, v, v]
    });
    Texture { path: None, width: res, height: 4, channels: 3, texels: texels.collect() }
}

/// The scene and the class of each object (floor, ceiling, wall x4, one entry per furniture box, the light).
/// `textured`: checker floor (50 cm tiles) and panelled walls (one panel per metre).
pub fn room_scene(r: &RoomSpec, furniture: &[FurnitureBox], textured: bool, w: u32, h: u32) -> (Scene, Vec<String>) {
    let mut materials = vec![Material::diffuse("grey", Vec3::splat(0.6))];
    let mut textures = vec![];
    let (mut floor_m, mut wall_m) = (0, 0);
    if textured {
        textures.push(checker(8, 0.15, 0.6));
        let mut m = Material::diffuse("checker", Vec3::ONE);
        m.albedo = Color::Texture(0);
        // 8 cells per texture repeat; 50 cm cells.
        m.uv_transform = UvTransform { scale: Vec2::new(r.w / 4.0, r.d / 4.0), ..Default::default() };
        materials.push(m);
        floor_m = 1;
        textures.push(panels(8));
        let mut m = Material::diffuse("panels", Vec3::ONE);
        m.albedo = Color::Texture(1);
        m.uv_transform = UvTransform { scale: Vec2::new(r.w.max(r.d) / 8.0, 1.0), ..Default::default() };
        materials.push(m);
        wall_m = 2;
    }
    let rect = |name: &str, sx: f32, sy: f32, t: Vec3, rot: Vec3, mat: usize| {
        let mut part = rectangle_mesh(sx, sy);
        part.material = mat;
        Object {
            name: name.into(),
            parts: vec![part],
            pose: Pose {
                translation: t,
                rotation: Quat::from_euler(EulerRot::ZYX, rot.z.to_radians(), rot.y.to_radians(), rot.x.to_radians()),
                scale: Vec3::ONE,
            },
            emitter: None,
        }
    };
    let (hw, hd) = (r.w / 2.0, r.d / 2.0);
    let mut objects = vec![
        rect("floor", r.w, r.d, Vec3::ZERO, Vec3::new(-90.0, 0.0, 0.0), floor_m),
        rect("ceiling", r.w, r.d, Vec3::new(0.0, r.h, 0.0), Vec3::new(90.0, 0.0, 0.0), 0),
        rect("wall_back", r.w, r.h, Vec3::new(0.0, r.h / 2.0, -hd), Vec3::ZERO, wall_m),
        rect("wall_front", r.w, r.h, Vec3::new(0.0, r.h / 2.0, hd), Vec3::new(0.0, 180.0, 0.0), wall_m),
        rect("wall_left", r.d, r.h, Vec3::new(-hw, r.h / 2.0, 0.0), Vec3::new(0.0, 90.0, 0.0), wall_m),
        rect("wall_right", r.d, r.h, Vec3::new(hw, r.h / 2.0, 0.0), Vec3::new(0.0, -90.0, 0.0), wall_m),
    ];
    let mut classes: Vec<String> = ["floor", "ceiling", "wall", "wall", "wall", "wall"].map(String::from).to_vec();
    for (i, f) in furniture.iter().enumerate() {
        objects.push(Object {
            name: format!("box{i}"),
            parts: vec![box_mesh(f.size, false)],
            pose: Pose {
                translation: Vec3::new(f.x, f.size.y / 2.0, f.z),
                rotation: Quat::from_rotation_y(f.yaw.to_radians()),
                scale: Vec3::ONE,
            },
            emitter: None,
        });
        classes.push(if i % 2 == 0 { "sofa" } else { "table" }.into());
    }
    let mut light = rect("light", 1.2, 1.2, Vec3::new(0.0, r.h - 0.01, 0.0), Vec3::new(90.0, 0.0, 0.0), 0);
    light.emitter = Some(Emitter::uniform(Vec3::splat(10.0), false));
    objects.push(light);
    classes.push("lamp".into());
    let dir = Quat::from_euler(EulerRot::YXZ, r.yaw.to_radians(), r.pitch.to_radians(), 0.0) * -Vec3::Z;
    let camera = Camera::look_at(r.cam, r.cam + dir, Vec3::Y, r.fov, w, h);
    let scene = Scene {
        camera,
        settings: RenderSettings { spp: 4, max_depth: 3, rr_depth: 3, seed: 0 },
        materials,
        textures,
        objects,
        source: None,
        requires_grad: vec![],
    };
    (scene, classes)
}

/// Furniture boxes on the floor in front of a camera at `cam` looking toward −z, covering about `coverage`
/// of the floor's area (0..0.4), kept 30 cm from the walls.
pub fn furniture(r: &RoomSpec, coverage: f32, rng: &mut crate::SplitMix64) -> Vec<FurnitureBox> {
    let mut out = vec![];
    let target = coverage * r.w * r.d;
    let mut area = 0.0;
    for _ in 0..40 {
        if area >= target {
            break;
        }
        let size = Vec3::new(0.6 + 1.4 * rng.next_f32(), 0.4 + 0.6 * rng.next_f32(), 0.5 + 1.0 * rng.next_f32());
        let (mx, mz) = (r.w / 2.0 - 0.3 - size.x / 2.0, r.d / 2.0 - 0.3 - size.z / 2.0);
        if mx <= 0.0 || mz <= 0.0 {
            continue;
        }
        let (x, z) = ((2.0 * rng.next_f32() - 1.0) * mx, (2.0 * rng.next_f32() - 1.0) * mz);
        // Not within a metre of the camera, and not overlapping another box.
        let overlaps = out.iter().any(|b: &FurnitureBox| {
            (b.x - x).abs() < (b.size.x + size.x) / 2.0 && (b.z - z).abs() < (b.size.z + size.z) / 2.0
        });
        if overlaps || ((x - r.cam.x).powi(2) + (z - r.cam.z).powi(2)).sqrt() < 1.0 + size.x.max(size.z) {
            continue;
        }
        area += size.x * size.z;
        out.push(FurnitureBox { x, z, size, yaw: 0.0 });
    }
    out
}
