//! Furnished rooms of real Sweet Home 3D models (Debian `sweethome3d-furniture`, through psdr's model
//! database), for the end-to-end evaluation (`bench_real_rooms`): a seeded generator of rooms of 3.5-6.5 m with
//! 4-7 pieces of furniture each (chairs, plants, lamps, shelves and bookcases, tables, one with a cloth, sofas,
//! armchairs, cabinets, desks; thin legs and many parts, several chairs of one model round a table), the
//! models' own colours and textures from their MTL files, floors and walls procedural (psdr's material
//! library), image-textured (a wood or fabric picture from a model's folder) or plain, 1-3 ceiling lights and
//! an emissive window, and the photo rendered with global illumination with its metric depth, instance masks,
//! labels, fov and the ground-truth scene.
//!
//! Objects are named CLASS_ID, ID their instance in the masks, as the pipeline names the objects it places, so
//! a fitted object and the true one of the same instance share a name.

use crate::rooms::{room_scene, RoomSpec};
use crate::SplitMix64;
use glam::{EulerRot, Quat, Vec2, Vec3};
use psdr::db::{ModelEntry, ModelSet};
use psdr::render::{render_cpu, Frame, SceneData};
use psdr::scene::{
    load_obj, rectangle_mesh, save_scene, Color, Emitter, Material, Object, Pose, Procedural, RenderSettings, Scene,
    Texture, TextureEncoding, UvTransform,
};
use psdr::vision::{canonical_class, Instance, Instances};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// An object must show at least this many pixels at 512 x 384 (scaled with the image's area), else it is drawn
/// again: the pipeline skips instances it cannot see enough of, and the evaluation would count it missed.
pub const MIN_PIXELS_512: usize = 300;

/// Floor-standing models per pool (path endings in the database), the thin and many-part ones included:
/// a pool is a class and where it stands.
const POOLS: &[(&str, &str, &[&str])] = &[
    (
        "chair",
        "chair",
        &[
            "blendswap-cc-0/chair/chair.obj",
            "blendswap-cc-0/chair2/chair2.obj",
            "blendswap-cc-0/thonet/thonet.obj",
            "blendswap-cc-0/osakaChair/osakaChair.obj",
            "blendswap-cc-0/plasticChair/plasticChair.obj",
            "blendswap-cc-0/antiqueChair/antiqueChair.obj",
            "blendswap-cc-by/kitchenChair/kitchenChair.obj",
            "blendswap-cc-by/chair3/chair3.obj",
            "katorlegaz/cafe-chair/cafe-chair.obj",
            "katorlegaz/dining-chair/dining-chair.obj",
            "scopia/chair/chair.obj",
            "scopia/tubular_chair/tubular_chair.obj",
            "scopia/white_kitchen_chair/white_kitchen_chair.obj",
            "scopia/bar_chair/bar_chair.obj",
        ],
    ),
    (
        "armchair",
        "armchair",
        &[
            "blendswap-cc-0/armchair/armchair.obj",
            "blendswap-cc-0/armchair2/armchair2.obj",
            "blendswap-cc-0/modernArmchair/modernArmchair.obj",
            "blendswap-cc-by/armchair1/armchair1.obj",
            "katorlegaz/mid-century-chair/mid-century-chair.obj",
            "scopia/armchair/armchair.obj",
            "scopia/rattanArmchair/rattanArmchair.obj",
        ],
    ),
    (
        "sofa",
        "sofa",
        &[
            "blendswap-cc-0/sofa2/sofa2.obj",
            "blendswap-cc-0/couch/couch.obj",
            "blendswap-cc-by/sofa3/sofa3.obj",
            "katorlegaz/mid-century-sofa/mid-century-sofa.obj",
            "katorlegaz/futon-couch/futon-couch.obj",
            "scopia/beige_sofa_2seats/beige_sofa_2seats.obj",
            "scopia/leather_sofa/leather_sofa.obj",
            "scopia/rattanSofa/rattanSofa.obj",
        ],
    ),
    (
        "coffee_table",
        "table",
        &[
            "blendswap-cc-by/coffeeTable/coffeeTable.obj",
            "scopia/coffee_table/coffee_table.obj",
            "scopia/saloon_table/saloon_table.obj",
            "scopia/table_wood_and_iron/table_wood_and_iron.obj",
            "scopia/living_room_table/living_room_table.obj",
            "katorlegaz/cafe-table/cafe-table.obj",
        ],
    ),
    (
        "dining_table",
        "table",
        &[
            "blendswap-cc-0/tableWithTablecloth/tableWithTablecloth.obj",
            "blendswap-cc-0/oakTable/oakTable.obj",
            "blendswap-cc-by/table/table.obj",
            "scopia/round-table/round-table.obj",
            "scopia/white_kitchen_table/white_kitchen_table.obj",
            "scopia/table4/table4.obj",
            "scopia/wooden_office_pear_table_rect/wooden_office_pear_table_rect.obj",
        ],
    ),
    (
        "plant",
        "plant",
        &[
            "blendswap-cc-0/plant/plant.obj",
            "blendswap-cc-0/decorativePlant/decorativePlant.obj",
            "blendswap-cc-by/spatifilum/spatifilum.obj",
            "blendswap-cc-by/mediumIndoorPlant/mediumIndoorPlant.obj",
            "blendswap-cc-by/yuccaPlant/yuccaPlant.obj",
            "scopia/ficus/ficus.obj",
            "scopia/maceta/maceta.obj",
            "scopia/vase5/vase5.obj",
        ],
    ),
    (
        "lamp",
        "lamp",
        &[
            "scopia/living_lamp/living_lamp.obj",
            "scopia/little_lamp3/little_lamp3.obj",
            "katorlegaz/pedestal-vase-lamp/pedestal-vase-lamp.obj",
            "blendswap-cc-0/lamp2/lamp2.obj",
        ],
    ),
    (
        "bookcase",
        "bookcase",
        &[
            "blendswap-cc-0/bookcase/bookcase.obj",
            "blendswap-cc-by/bookcase/bookcase.obj",
            "katorlegaz/full-bookcase/full-bookcase.obj",
            "scopia/dining_room/dining_room.obj",
        ],
    ),
    (
        "shelf",
        "shelf",
        &[
            "blendswap-cc-0/shelves/shelves.obj",
            "blendswap-cc-0/verticalShelves/verticalShelves.obj",
            "katorlegaz/utility-shelving/utility-shelving.obj",
            "scopia/kids_shelves/kids_shelves.obj",
        ],
    ),
    (
        "cabinet",
        "cabinet",
        &[
            "blendswap-cc-0/cupboard/cupboard.obj",
            "blendswap-cc-0/drawersCabinet/drawersCabinet.obj",
            "blendswap-cc-by/dresserWithDrawers/dresserWithDrawers.obj",
            "blendswap-cc-0/highCabinet/highCabinet.obj",
            "blendswap-cc-0/televisionCabinet/televisionCabinet.obj",
            "katorlegaz/filing-cabinet/filing-cabinet.obj",
            "blendswap-cc-by/kitchenLowerCabinet/kitchenLowerCabinet.obj",
        ],
    ),
    (
        "desk",
        "desk",
        &[
            "blendswap-cc-by/simpleDesk/simpleDesk.obj",
            "blendswap-cc-by/biurko3/biurko3.obj",
            "blendswap-cc-0/lbDesk/lbDesk.obj",
            "scopia/kids_wooden_desk/kids_wooden_desk.obj",
        ],
    ),
];

/// What a room is furnished with, by pool; a `+` marks chairs drawn round the table before them (one model).
const THEMES: &[&[&str]] = &[
    &["sofa", "coffee_table", "armchair", "plant", "lamp"],
    &["dining_table", "+chair", "+chair", "+chair", "cabinet"],
    &["desk", "chair", "bookcase", "lamp", "plant"],
    &["armchair", "armchair", "coffee_table", "shelf", "plant"],
    &["dining_table", "+chair", "+chair", "plant", "bookcase"],
    &["sofa", "armchair", "coffee_table", "plant", "plant", "lamp"],
];

/// Pools one extra object may come from.
const EXTRAS: [&str; 6] = ["plant", "lamp", "chair", "cabinet", "shelf", "armchair"];

/// Where a pool's furniture stands: with its back to a wall, or anywhere on the floor.
fn against_wall(pool: &str) -> bool {
    matches!(pool, "bookcase" | "shelf" | "cabinet" | "desk")
}

/// A floor or wall finish.
#[derive(Clone, Debug)]
pub enum Finish {
    /// A library material (`psdr materials list`), one repeat every `tile` metres.
    Procedural {
        name: &'static str,
        tile: f32,
    },
    /// A picture, one repeat every `tile` metres.
    Image {
        path: PathBuf,
        tile: f32,
    },
    Plain(Vec3),
}

impl Finish {
    /// A short description for tables.
    pub fn describe(&self) -> String {
        match self {
            Finish::Procedural { name, tile } => format!("procedural {name} ({tile} m)"),
            Finish::Image { path, tile } => format!(
                "image {}/{} ({tile} m)",
                path.parent().and_then(Path::file_name).map(|f| f.to_string_lossy()).unwrap_or_default(),
                path.file_name().map(|f| f.to_string_lossy()).unwrap_or_default()
            ),
            Finish::Plain(c) => format!("plain ({:.2}, {:.2}, {:.2})", c.x, c.y, c.z),
        }
    }
}

/// One piece of furniture: its model and where it stands.
#[derive(Clone, Debug)]
pub struct RealItem {
    pub class: String,
    pub model: ModelEntry,
    /// Centre of the footprint on the floor.
    pub at: Vec3,
    /// Degrees about +y; 0 faces +z (the camera's side of the room).
    pub yaw: f32,
}

/// A generated room: everything needed to build its scene.
#[derive(Clone, Debug)]
pub struct RealRoom {
    pub name: String,
    pub spec: RoomSpec,
    pub items: Vec<RealItem>,
    pub floor: Finish,
    pub walls: Finish,
    /// Ceiling lights: centre, side (square) and radiance.
    pub lights: Vec<(Vec3, f32, Vec3)>,
    /// The window: centre, the wall's inward normal, size (width, height), radiance.
    pub window: (Vec3, Vec3, Vec2, Vec3),
}

/// A true object of a written room: its name in the scene (CLASS_ID), instance, class, model, pixels.
#[derive(Clone, Debug)]
pub struct TrueModel {
    pub name: String,
    pub instance: u16,
    pub class: String,
    pub model: String,
    pub file: PathBuf,
    pub licence: String,
    pub pixels: usize,
}

impl TrueModel {
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({ "name": self.name, "instance": self.instance, "class": self.class, "model": self.model,
                            "file": self.file, "licence": self.licence, "pixels": self.pixels })
    }
}

/// The database's models of every pool, by pool (a pool's models the database lacks are left out).
pub fn pool_models(db: &ModelSet) -> HashMap<&'static str, Vec<ModelEntry>> {
    POOLS
        .iter()
        .map(|(pool, class, files)| {
            let found = files
                .iter()
                .filter_map(|f| {
                    db.models.iter().find(|m| m.category == *class && m.path.to_string_lossy().ends_with(f)).cloned()
                })
                .collect();
            (*pool, found)
        })
        .collect()
}

/// The pools' models and how often each has been drawn so far: every draw takes the least used first, so
/// that the rooms together show as many models as they can.
struct Stock {
    pools: HashMap<&'static str, Vec<ModelEntry>>,
    used: HashMap<PathBuf, usize>,
}

impl Stock {
    /// A pool's models, the least used first (ties in random order).
    fn by_use(&self, rng: &mut SplitMix64, pool: &str) -> Vec<ModelEntry> {
        let mut v: Vec<ModelEntry> = self.pools.get(pool).cloned().unwrap_or_default();
        for i in (1..v.len()).rev() {
            v.swap(i, ((rng.next_f32() * (i + 1) as f32) as usize).min(i));
        }
        v.sort_by_key(|m| self.used.get(&m.path).copied().unwrap_or(0));
        v
    }

    fn count(&mut self, m: &ModelEntry, placed: bool) {
        let n = self.used.entry(m.path.clone()).or_default();
        *n = if placed { *n + 1 } else { n.saturating_sub(1) };
    }
}

/// The class a pool's furniture is labelled with.
fn pool_class(pool: &str) -> &'static str {
    POOLS.iter().find(|p| p.0 == pool).map_or("object", |p| p.1)
}

/// Corners of an item's footprint (x, z) grown by `margin`.
fn footprint(model: &ModelEntry, at: Vec3, yaw: f32, margin: f32) -> [Vec2; 4] {
    let s = model.size();
    let (hx, hz) = (s.x / 2.0 + margin, s.z / 2.0 + margin);
    let (sn, cs) = yaw.to_radians().sin_cos();
    // Rotation about +y: x' = x cos + z sin, z' = -x sin + z cos.
    [(-hx, -hz), (hx, -hz), (hx, hz), (-hx, hz)].map(|(x, z)| Vec2::new(at.x + x * cs + z * sn, at.z - x * sn + z * cs))
}

impl RealItem {
    /// Corners of its footprint (x, z) grown by `margin`.
    pub fn footprint(&self, margin: f32) -> [Vec2; 4] {
        footprint(&self.model, self.at, self.yaw, margin)
    }
}

/// Whether two convex quads overlap (separating axes).
pub fn quads_overlap(a: &[Vec2; 4], b: &[Vec2; 4]) -> bool {
    for q in [a, b] {
        for k in 0..4 {
            let e = q[(k + 1) % 4] - q[k];
            let n = Vec2::new(-e.y, e.x);
            let (amin, amax) = a.iter().map(|p| p.dot(n)).fold((f32::MAX, f32::MIN), |(l, h), v| (l.min(v), h.max(v)));
            let (bmin, bmax) = b.iter().map(|p| p.dot(n)).fold((f32::MAX, f32::MIN), |(l, h), v| (l.min(v), h.max(v)));
            if amax < bmin || bmax < amin {
                return false;
            }
        }
    }
    true
}

/// Image position of a world point, None behind the camera.
fn project(cam: &psdr::scene::Camera, p: Vec3) -> Option<Vec2> {
    let f = cam.forward.normalize();
    let r = f.cross(cam.up).normalize();
    let u = r.cross(f);
    let d = p - cam.origin;
    let z = d.dot(f);
    if z < 0.1 {
        return None;
    }
    let tan = (cam.fov_y_deg.to_radians() / 2.0).tan();
    let aspect = cam.width as f32 / cam.height as f32;
    let (x, y) = (d.dot(r) / z / (tan * aspect), d.dot(u) / z / tan);
    Some(Vec2::new((x + 1.0) / 2.0 * cam.width as f32, (1.0 - y) / 2.0 * cam.height as f32))
}

/// The fraction of the item's projected bounding box inside the image (0 when a corner is behind the camera).
fn in_view(cam: &psdr::scene::Camera, model: &ModelEntry, at: Vec3, yaw: f32) -> f32 {
    let h = model.size().y;
    let mut lo = Vec2::splat(f32::MAX);
    let mut hi = Vec2::splat(f32::MIN);
    for c in footprint(model, at, yaw, 0.0) {
        for y in [0.0, h] {
            let Some(p) = project(cam, Vec3::new(c.x, y, c.y)) else { return 0.0 };
            (lo, hi) = (lo.min(p), hi.max(p));
        }
    }
    let (w, hh) = (cam.width as f32, cam.height as f32);
    let inside = (hi.x.min(w) - lo.x.max(0.0)).max(0.0) * (hi.y.min(hh) - lo.y.max(0.0)).max(0.0);
    inside / ((hi.x - lo.x) * (hi.y - lo.y)).max(1e-6)
}

/// Uniform in [a, b).
fn uniform(rng: &mut SplitMix64, a: f32, b: f32) -> f32 {
    a + (b - a) * rng.next_f32()
}

fn pick<'a, T>(rng: &mut SplitMix64, v: &'a [T]) -> &'a T {
    &v[((rng.next_f32() * v.len() as f32) as usize).min(v.len() - 1)]
}

/// Image textures for floors and walls, from models' folders (path endings in the database's folder).
const FLOOR_IMAGES: [&str; 4] = [
    "scopia/puerta/tilewood.jpg",
    "scopia/wooden_office_alder_table/alder_tileable.jpg",
    "scopia/round-table/oaktexture.jpg",
    "scopia/captains-bed/woodtexture.jpg",
];
const WALL_IMAGES: [&str; 3] = [
    "scopia/hammock/fabricTexture.jpg",
    "scopia/stoneGrillDevice/textureStone.jpg",
    "scopia/ryokanChair/fabricTexture.jpg",
];
const FLOOR_MATERIALS: [(&str, f32); 6] = [
    ("oak_planks", 1.0),
    ("square_tiles", 1.2),
    ("herringbone_parquet", 1.0),
    ("walnut_planks", 0.8),
    ("terracotta_tiles", 1.2),
    ("carpet_loop", 0.5),
];
const WALL_MATERIALS: [(&str, f32); 5] = [
    ("painted_plaster", 1.5),
    ("wallpaper_stripes", 1.0),
    ("brick_wall", 1.2),
    ("wallpaper_dots", 0.8),
    ("stucco", 1.5),
];

/// A file under the database's Sweet Home 3D folder by its path ending.
fn find_image(db_dir: &Path, ending: &str) -> Option<PathBuf> {
    let sh3d = db_dir.join("sh3d");
    let vendors = std::fs::read_dir(&sh3d).ok()?;
    for v in vendors.flatten() {
        let Ok(inner) = std::fs::read_dir(v.path()) else { continue };
        for lib in inner.flatten() {
            let (top, rest) = ending.split_once('/')?;
            if lib.file_name().to_string_lossy() == top && lib.path().join(rest).is_file() {
                return Some(lib.path().join(rest));
            }
        }
    }
    None
}

/// The finish of room `k`'s floor (`floor`) or walls: the kind cycles through procedural, image and plain so
/// that every kind comes up on floors and on walls.
fn finish(rng: &mut SplitMix64, db_dir: &Path, k: usize, floor: bool) -> Finish {
    let kind = (k + if floor { 0 } else { 1 }) % 3;
    let plain = if floor {
        Vec3::new(uniform(rng, 0.25, 0.5), uniform(rng, 0.18, 0.35), uniform(rng, 0.12, 0.25))
    } else {
        let g = uniform(rng, 0.55, 0.8);
        Vec3::new(g, g * uniform(rng, 0.92, 1.0), g * uniform(rng, 0.82, 0.97))
    };
    match kind {
        0 => {
            let (name, tile) = if floor { *pick(rng, &FLOOR_MATERIALS) } else { *pick(rng, &WALL_MATERIALS) };
            Finish::Procedural { name, tile }
        }
        1 => {
            let ending = if floor { *pick(rng, &FLOOR_IMAGES) } else { *pick(rng, &WALL_IMAGES) };
            match find_image(db_dir, ending) {
                Some(path) => Finish::Image { path, tile: if floor { 0.8 } else { 0.6 } },
                None => Finish::Plain(plain),
            }
        }
        _ => Finish::Plain(plain),
    }
}

/// The room's camera as the scene builds it.
fn camera(spec: &RoomSpec, w: u32, h: u32) -> psdr::scene::Camera {
    room_scene(spec, &[], false, w, h).0.camera
}

/// Draws one item of `pool` for a room, not overlapping `placed`, inside the walls, mostly in view; `table`:
/// for `+` pools, the table it is drawn round (one side, facing it) and the model to use.
#[allow(clippy::too_many_arguments)]
fn draw_item(
    rng: &mut SplitMix64,
    spec: &RoomSpec,
    cam: &psdr::scene::Camera,
    stock: &Stock,
    pool: &str,
    placed: &[RealItem],
    window: &(Vec3, Vec3, Vec2, Vec3),
    table: Option<(&RealItem, &ModelEntry)>,
) -> Option<RealItem> {
    let models = stock.by_use(rng, pool);
    if models.is_empty() {
        return None;
    }
    let (hw, hd) = (spec.w / 2.0, spec.d / 2.0);
    for attempt in 0..200 {
        // 25 tries per model, the least used first.
        let model = match table {
            Some((_, m)) => m.clone(),
            None => models[(attempt / 25) % models.len()].clone(),
        };
        let s = model.size();
        let (at, yaw) = if let Some((t, _)) = table {
            // One of the table's four sides, the chair's front to the table.
            let ts = t.model.size();
            let side = (rng.next_f32() * 4.0) as usize % 4;
            let gap = s.z / 2.0 + 0.12;
            let local = match side {
                0 => Vec3::new(0.0, 0.0, ts.z / 2.0 + gap),
                1 => Vec3::new(0.0, 0.0, -ts.z / 2.0 - gap),
                2 => Vec3::new(ts.x / 2.0 + gap, 0.0, 0.0),
                _ => Vec3::new(-ts.x / 2.0 - gap, 0.0, 0.0),
            };
            let at = t.at + Quat::from_rotation_y(t.yaw.to_radians()) * local;
            let to_table = t.at - at;
            (at, to_table.x.atan2(to_table.z).to_degrees() + uniform(rng, -5.0, 5.0))
        } else if against_wall(pool) {
            // Back, left or right wall, the back to it.
            let wall = (rng.next_f32() * 3.0) as usize % 3;
            let half = s.z / 2.0 + 0.03;
            match wall {
                0 => (Vec3::new(uniform(rng, -hw + s.x / 2.0, hw - s.x / 2.0), 0.0, -hd + half), 0.0),
                1 => (Vec3::new(-hw + half, 0.0, uniform(rng, -hd + s.x / 2.0, spec.cam.z - 1.5)), 90.0),
                _ => (Vec3::new(hw - half, 0.0, uniform(rng, -hd + s.x / 2.0, spec.cam.z - 1.5)), -90.0),
            }
        } else {
            // Anywhere at least 1.3 m ahead of the camera; sofas and armchairs face the room's front half.
            let at = Vec3::new(uniform(rng, -hw + 0.4, hw - 0.4), 0.0, uniform(rng, -hd + 0.4, spec.cam.z - 1.3));
            let yaw = match pool {
                "sofa" | "armchair" => uniform(rng, -70.0, 70.0),
                _ => uniform(rng, -180.0, 180.0),
            };
            (at, yaw)
        };
        let corners = footprint(&model, at, yaw, 0.0);
        let inside = corners.iter().all(|c| c.x.abs() < hw - 0.02 && c.y.abs() < hd - 0.02);
        let apart = placed.iter().all(|p| !quads_overlap(&footprint(&p.model, p.at, p.yaw, 0.05), &corners));
        // Not in front of the window (it would hide it), nor within 1 m of the camera.
        let (wc, wn, ws, _) = window;
        let along = wn.cross(Vec3::Y).normalize();
        let before_window = corners.iter().any(|c| {
            let p = Vec3::new(c.x, 0.0, c.y) - Vec3::new(wc.x, 0.0, wc.z);
            p.dot(*wn) < 0.6 && p.dot(along).abs() < ws.x / 2.0 + 0.1
        });
        let near_camera = (Vec2::new(at.x - spec.cam.x, at.z - spec.cam.z)).length() < 1.0 + s.x.max(s.z) / 2.0;
        if inside && apart && !before_window && !near_camera && in_view(cam, &model, at, yaw) > 0.7 {
            return Some(RealItem { class: pool_class(pool).to_string(), model, at, yaw });
        }
    }
    None
}

/// Generates `count` rooms from the installed database at `db_dir` (its models and the pictures of its models'
/// folders), deterministically from `seed`, for photos of `w` x `h` pixels.
pub fn generate_rooms(db_dir: &Path, count: usize, seed: u64, w: u32, h: u32) -> psdr::Result<Vec<RealRoom>> {
    let db = ModelSet::from_folder(db_dir)?;
    let mut stock = Stock { pools: pool_models(&db), used: HashMap::new() };
    let mut rng = SplitMix64(seed);
    let mut rooms = vec![];
    for k in 0..count {
        let rng = &mut rng;
        let (rw, rd, rh) = (uniform(rng, 3.5, 6.5), uniform(rng, 3.5, 6.5), uniform(rng, 2.5, 3.0));
        let spec = RoomSpec {
            w: rw,
            d: rd,
            h: rh,
            cam: Vec3::new(
                uniform(rng, -0.3, 0.3) * rw / 2.0,
                uniform(rng, 1.3, 1.7),
                rd / 2.0 - uniform(rng, 0.3, 0.5),
            ),
            yaw: uniform(rng, -12.0, 12.0),
            pitch: uniform(rng, -22.0, -12.0),
            fov: uniform(rng, 50.0, 70.0),
        };
        let cam = camera(&spec, w, h);
        let floor = finish(rng, db_dir, k, true);
        let walls = finish(rng, db_dir, k, false);
        let n = 1 + (uniform(rng, 0.0, 2.99) as usize);
        let lights = (0..n)
            .map(|i| {
                let x = (i as f32 + 0.5) / n as f32 * rw - rw / 2.0 + uniform(rng, -0.2, 0.2);
                let le = Vec3::new(uniform(rng, 9.0, 12.0), uniform(rng, 8.5, 11.0), uniform(rng, 7.0, 10.0));
                (Vec3::new(x, rh - 0.01, uniform(rng, -rd / 3.0, rd / 6.0)), uniform(rng, 0.5, 0.8), le)
            })
            .collect();
        // The window in the left, right or back wall, its sill at about a metre.
        let size = Vec2::new(uniform(rng, 0.9, 1.4), uniform(rng, 0.9, 1.2));
        let y = 1.0 + size.y / 2.0;
        let window_le = Vec3::new(uniform(rng, 2.5, 3.5), uniform(rng, 3.0, 3.8), uniform(rng, 3.5, 4.5));
        let window = match (rng.next_f32() * 3.0) as usize {
            0 => (Vec3::new(-rw / 2.0 + 0.01, y, uniform(rng, -rd / 3.0, 0.0)), Vec3::X, size, window_le),
            1 => (Vec3::new(rw / 2.0 - 0.01, y, uniform(rng, -rd / 3.0, 0.0)), Vec3::NEG_X, size, window_le),
            _ => (Vec3::new(uniform(rng, -rw / 4.0, rw / 4.0), y, -rd / 2.0 + 0.01), Vec3::Z, size, window_le),
        };
        let mut room = RealRoom { name: format!("room{k:02}"), spec, items: vec![], floor, walls, lights, window };
        // The theme's pools, and one extra object in every other room.
        let mut wanted: Vec<String> = THEMES[k % THEMES.len()].iter().map(|s| s.to_string()).collect();
        if k % 2 == 1 {
            wanted.push(pick(rng, &EXTRAS).to_string());
        }
        furnish(rng, &mut room, &cam, &mut stock, &wanted, w, h)?;
        rooms.push(room);
    }
    Ok(rooms)
}

/// Draws the room's furniture, then draws again every object that shows fewer than `MIN_PIXELS_512` pixels
/// (scaled to `w` x `h`) in the instance masks, hidden by others or by the frame; at least 4 objects.
fn furnish(
    rng: &mut SplitMix64,
    room: &mut RealRoom,
    cam: &psdr::scene::Camera,
    stock: &mut Stock,
    wanted: &[String],
    w: u32,
    h: u32,
) -> psdr::Result<()> {
    let min_pixels = (MIN_PIXELS_512 as f64 * (w * h) as f64 / (512.0 * 384.0)).ceil() as usize;
    let mut missing: Vec<String> = wanted.to_vec();
    // The chairs round a table are one model.
    let mut chair_model: Option<ModelEntry> = None;
    for _round in 0..8 {
        for pool in std::mem::take(&mut missing) {
            let companion = pool.strip_prefix('+');
            let t = match companion {
                Some(p) => {
                    let Some(ti) = room.items.iter().position(|i| i.class == "table") else {
                        missing.push(pool.clone());
                        continue;
                    };
                    if chair_model.is_none() {
                        chair_model = stock.by_use(rng, p).first().cloned();
                    }
                    let Some(m) = chair_model.clone() else { continue };
                    Some((room.items[ti].clone(), m))
                }
                None => None,
            };
            let name = companion.unwrap_or(&pool);
            let drawn = draw_item(
                rng,
                &room.spec,
                cam,
                stock,
                name,
                &room.items,
                &room.window,
                t.as_ref().map(|(i, m)| (i, m)),
            );
            match drawn {
                Some(item) => {
                    stock.count(&item.model, true);
                    room.items.push(item);
                }
                None => missing.push(pool.clone()),
            }
        }
        // What the masks show of each object.
        let (_, inst, _) = build_scene(room, w, h)?;
        let first = inst.first_furniture;
        let counts: Vec<usize> = (0..room.items.len())
            .map(|i| inst.instances.instances.iter().find(|x| x.id as usize == first + i + 1).map_or(0, |x| x.pixels))
            .collect();
        let mut k = room.items.len();
        while k > 0 {
            k -= 1;
            if counts[k] < min_pixels {
                let it = room.items.remove(k);
                stock.count(&it.model, false);
                let round_table = chair_model.as_ref().is_some_and(|m| m.path == it.model.path);
                missing.push(if round_table { "+chair".into() } else { pool_of(&it) });
            }
        }
        while room.items.len() + missing.len() < 4 {
            missing.push(pick(rng, &EXTRAS).to_string());
        }
        if missing.is_empty() {
            break;
        }
    }
    if room.items.len() < 4 {
        return Err(psdr::Error::Invalid(format!("{}: only {} objects could be placed", room.name, room.items.len())));
    }
    Ok(())
}

/// The pool an item came from.
fn pool_of(item: &RealItem) -> String {
    POOLS
        .iter()
        .find(|(_, class, files)| {
            *class == item.class && files.iter().any(|f| item.model.path.to_string_lossy().ends_with(f))
        })
        .map_or(item.class.clone(), |p| p.0.to_string())
}

/// A built room: the instance masks of its scene and where its furniture starts among the objects.
pub struct BuiltInstances {
    pub instances: Instances,
    /// Index of the first furniture object in the scene (its instance id is this + 1).
    pub first_furniture: usize,
}

/// Loads (and caches) a picture as a colour texture.
fn image_texture(scene: &mut Scene, cache: &mut HashMap<PathBuf, usize>, path: &Path) -> psdr::Result<usize> {
    if let Some(&t) = cache.get(path) {
        return Ok(t);
    }
    scene.textures.push(Texture::load(path, TextureEncoding::Srgb, 3)?);
    cache.insert(path.to_path_buf(), scene.textures.len() - 1);
    Ok(scene.textures.len() - 1)
}

/// A material for a floor or the walls, spanning `span` metres (u, v) of its rectangle.
fn finish_material(
    scene: &mut Scene,
    cache: &mut HashMap<PathBuf, usize>,
    name: &str,
    f: &Finish,
    span: Vec2,
) -> psdr::Result<usize> {
    scene.materials.push(Material::diffuse(name, Vec3::splat(0.6)));
    let m = scene.materials.len() - 1;
    match f {
        Finish::Plain(c) => scene.materials[m].albedo = Color::Constant(*c),
        Finish::Procedural { name, tile } => {
            scene.set_procedural(m, Procedural::new(name, 256)?)?;
            scene.materials[m].uv_transform = UvTransform { scale: span / *tile, ..Default::default() };
        }
        Finish::Image { path, tile } => {
            let t = image_texture(scene, cache, path)?;
            scene.materials[m].albedo = Color::Texture(t);
            scene.materials[m].uv_transform = UvTransform { scale: span / *tile, ..Default::default() };
        }
    }
    Ok(m)
}

/// The room's ground-truth scene at `w` x `h` (furniture named CLASS_ID, one material per part from the model's
/// MTL file: its colour or its picture), its instance masks (floor, ceiling and walls, then the furniture;
/// lights left out; the window labelled `window`) and the frame they were read from (max depth 1, 1 spp).
pub fn build_scene(room: &RealRoom, w: u32, h: u32) -> psdr::Result<(Scene, BuiltInstances, Frame)> {
    let (mut scene, mut classes) = room_scene(&room.spec, &[], false, w, h);
    let light = scene.objects.iter().position(|o| o.name == "light").unwrap_or(scene.objects.len() - 1);
    scene.objects.remove(light);
    classes.remove(light);
    let mut cache = HashMap::new();
    let (rw, rd, rh) = (room.spec.w, room.spec.d, room.spec.h);
    let floor = finish_material(&mut scene, &mut cache, "floor", &room.floor, Vec2::new(rw, rd))?;
    // The back and front walls span the width, the side walls the depth: one material each, so a pattern
    // keeps its size on both.
    let walls = finish_material(&mut scene, &mut cache, "wall", &room.walls, Vec2::new(rw, rh))?;
    let side_walls = finish_material(&mut scene, &mut cache, "wall_side", &room.walls, Vec2::new(rd, rh))?;
    scene.materials.push(Material::diffuse("ceiling", Vec3::splat(0.8)));
    let ceiling = scene.materials.len() - 1;
    for o in scene.objects.iter_mut() {
        let m = match o.name.as_str() {
            "floor" => floor,
            "ceiling" => ceiling,
            "wall_left" | "wall_right" => side_walls,
            _ => walls,
        };
        o.parts.iter_mut().for_each(|p| p.material = m);
    }
    // Furniture: CLASS_ID, ID the object's index + 1 (its instance id).
    let first_furniture = scene.objects.len();
    for it in &room.items {
        let id = scene.objects.len() + 1;
        let name = format!("{}_{id}", it.class);
        let mut parts = it.model.load_parts()?;
        let mtl: HashMap<String, psdr::scene::MtlMaterial> =
            load_obj(&it.model.path)?.part_mtl.into_iter().flatten().map(|m| (m.name.clone(), m)).collect();
        let dir = it.model.path.parent().unwrap_or(Path::new("."));
        // One material per part name: the reader splits a material's group into parts of the same name where
        // their vertex attributes differ, and a scene's material names must be unique.
        let mut by_part: HashMap<String, usize> = HashMap::new();
        for p in parts.iter_mut() {
            if let Some(&m) = by_part.get(&p.name) {
                p.material = m;
                continue;
            }
            let mut m = Material::diffuse(&format!("{name}:{}", p.name), Vec3::splat(0.5));
            if let Some(mt) = mtl.get(&p.name) {
                if let Some(c) = mt.diffuse {
                    m.albedo = Color::Constant(c.clamp(Vec3::splat(0.02), Vec3::splat(0.85)));
                }
                let picture = mt.diffuse_texture.as_ref().map(|t| dir.join(t)).filter(|t| t.is_file());
                if let (Some(t), true) = (picture, p.uvs.is_some()) {
                    m.albedo = Color::Texture(image_texture(&mut scene, &mut cache, &t)?);
                }
            }
            scene.materials.push(m);
            p.material = scene.materials.len() - 1;
            by_part.insert(p.name.clone(), p.material);
        }
        scene.objects.push(Object {
            name,
            parts,
            pose: Pose { translation: it.at, rotation: Quat::from_rotation_y(it.yaw.to_radians()), scale: Vec3::ONE },
            emitter: None,
        });
        classes.push(it.class.clone());
    }
    // Ceiling lights and the window: one-sided emitters facing into the room.
    scene.materials.push(Material::diffuse("emitter", Vec3::splat(0.8)));
    let em = scene.materials.len() - 1;
    let panel = |name: String, size: Vec2, t: Vec3, rotation: Quat, radiance: Vec3| {
        let mut part = rectangle_mesh(size.x, size.y);
        part.material = em;
        Object {
            name,
            parts: vec![part],
            pose: Pose { translation: t, rotation, scale: Vec3::ONE },
            emitter: Some(Emitter::uniform(radiance, false)),
        }
    };
    for (k, (at, side, le)) in room.lights.iter().enumerate() {
        let down = Quat::from_euler(EulerRot::ZYX, 0.0, 0.0, 90f32.to_radians());
        scene.objects.push(panel(format!("light_{k}"), Vec2::splat(*side), *at, down, *le));
        classes.push("lamp".into());
    }
    let (wc, wn, ws, wle) = room.window;
    // The rectangle faces +z; turned about +y to face the room.
    let turn = Quat::from_rotation_y(wn.x.atan2(wn.z));
    scene.objects.push(panel("window".into(), ws, wc, turn, wle));
    classes.push("window".into());

    // Instances: ids from an object-id render (pixel centres), one per visible non-emitting object.
    let mut view = scene.clone();
    view.settings = RenderSettings { spp: 1, max_depth: 1, rr_depth: 1, seed: 0 };
    let f = render_cpu(&SceneData::build(&view)?, &view.settings, &|_, _| {});
    let n = (w * h) as usize;
    let mut inst = Instances { width: w as usize, height: h as usize, ids: vec![0; n], instances: vec![] };
    let mut pixels = vec![0usize; scene.objects.len()];
    for &o in &f.object_id {
        if let Some(c) = pixels.get_mut(o as usize) {
            *c += 1;
        }
    }
    let window = scene.objects.len() - 1;
    for (o, class) in classes.iter().enumerate() {
        // The window is seen (its pixels are a wall's opening); the ceiling lights are not segmented.
        if pixels[o] == 0 || (scene.objects[o].emitter.is_some() && o != window) {
            continue;
        }
        let id = o as u16 + 1;
        for (p, &i) in f.object_id.iter().enumerate() {
            if i == o as u32 {
                inst.ids[p] = id;
            }
        }
        let (c, kind) = canonical_class(class);
        inst.instances.push(Instance { id, label: Some(class.clone()), class: c.into(), kind, pixels: pixels[o] });
    }
    Ok((scene, BuiltInstances { instances: inst, first_furniture }, f))
}

/// Scales every emitter so the photo's median luminance (of a quick render, `spp` samples) is about `target`
/// (linear): rooms of any size and finish come out neither dark nor burnt out.
fn expose(scene: &mut Scene, target: f32, spp: u32) -> psdr::Result<f32> {
    let mut quick = scene.clone();
    quick.settings.spp = spp;
    let f = render_cpu(&SceneData::build(&quick)?, &quick.settings, &|_, _| {});
    let mut lum: Vec<f32> = f
        .radiance
        .chunks_exact(3)
        .map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])
        .filter(|v| v.is_finite())
        .collect();
    lum.sort_by(f32::total_cmp);
    let median = lum.get(lum.len() / 2).copied().unwrap_or(0.0).max(1e-4);
    let gain = (target / median).clamp(0.25, 8.0);
    for o in scene.objects.iter_mut() {
        if let Some(e) = o.emitter.as_mut() {
            e.radiance *= gain;
        }
    }
    Ok(gain)
}

/// Paths of the photos: long enough that the light a real photo records after many bounces is there (a white
/// room's walls pass 60-80 % on at each bounce: at 4 vertices room03's median pixel had 73-88 % of its
/// converged value, at 16 vertices within 0.1 %), with Russian roulette after the fourth vertex.
pub const PHOTO_MAX_DEPTH: u32 = 16;

/// Writes room `room` into `dir`: `photo.png` (global illumination, `spp` samples, `PHOTO_MAX_DEPTH`),
/// `photo.depth.exr` (camera z, metres), `photo.masks.png` (16-bit instance ids), `photo.labels.json`,
/// `photo.camera.json`, `truth.json` (with its meshes and textures) and `models.json` (the true models).
/// Returns the true models.
pub fn write_room(room: &RealRoom, dir: &Path, w: u32, h: u32, spp: u32) -> psdr::Result<Vec<TrueModel>> {
    write_room_with_paths(room, dir, w, h, spp, PHOTO_MAX_DEPTH)
}

/// `write_room` with the photo's paths `max_depth` vertices long: the depth (the mean over each pixel's
/// samples) and masks are the same at any length, so a test of what reads only those renders short paths.
pub fn write_room_with_paths(
    room: &RealRoom,
    dir: &Path,
    w: u32,
    h: u32,
    spp: u32,
    max_depth: u32,
) -> psdr::Result<Vec<TrueModel>> {
    std::fs::create_dir_all(dir).map_err(|e| psdr::Error::io(dir, e))?;
    let (mut truth, built, _) = build_scene(room, w, h)?;
    truth.settings = RenderSettings { spp, max_depth, rr_depth: 4, seed: 7 };
    expose(&mut truth, 0.18, 8)?;
    let f = render_cpu(&SceneData::build(&truth)?, &truth.settings, &|_, _| {});
    let inst = &built.instances;
    psdr::output::write_png_srgb(&dir.join("photo.png"), w, h, &f.radiance)?;
    psdr::output::write_exr_channels(&dir.join("photo.depth.exr"), w, h, &[("Z".into(), f.depth.clone())])?;
    let masks = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, inst.ids.clone())
        .ok_or_else(|| psdr::Error::Invalid("mask size".into()))?;
    masks.save(dir.join("photo.masks.png")).map_err(|e| psdr::Error::io(&dir.join("photo.masks.png"), e))?;
    let labels: serde_json::Map<String, serde_json::Value> = inst
        .instances
        .iter()
        .map(|i| (i.id.to_string(), serde_json::Value::from(i.label.clone().unwrap_or(i.class.clone()))))
        .collect();
    let write = |name: &str, text: String| {
        std::fs::write(dir.join(name), text).map_err(|e| psdr::Error::io(&dir.join(name), e))
    };
    write("photo.labels.json", serde_json::to_string_pretty(&labels).unwrap_or_default())?;
    write("photo.camera.json", format!("{{\"fov_y_deg\": {}}}", room.spec.fov))?;
    save_scene(&truth, &dir.join("truth.json"))?;
    // The evaluation reads it at the end of a run: a file it cannot read would cost the whole run.
    let back = psdr::scene::load_scene(&dir.join("truth.json"))?;
    if back.objects.len() != truth.objects.len() || back.materials.len() != truth.materials.len() {
        return Err(psdr::Error::Invalid(format!("{}: truth.json reads back differently", room.name)));
    }
    let models: Vec<TrueModel> = room
        .items
        .iter()
        .enumerate()
        .map(|(i, it)| {
            let id = (built.first_furniture + i + 1) as u16;
            TrueModel {
                name: format!("{}_{id}", it.class),
                instance: id,
                class: it.class.clone(),
                model: it.model.name.clone(),
                file: it.model.path.clone(),
                licence: it.model.licence.clone(),
                pixels: inst.instances.iter().find(|x| x.id == id).map_or(0, |x| x.pixels),
            }
        })
        .collect();
    let list: Vec<serde_json::Value> = models.iter().map(TrueModel::to_json).collect();
    write("models.json", serde_json::to_string_pretty(&list).unwrap_or_default())?;
    Ok(models)
}

/// The true models of a written room (`models.json`).
pub fn read_models(dir: &Path) -> Option<Vec<serde_json::Value>> {
    let text = std::fs::read_to_string(dir.join("models.json")).ok()?;
    serde_json::from_str::<serde_json::Value>(&text).ok()?.as_array().cloned()
}

/// A database folder holding the catalog of `db_dir` less every entry whose model file is one of `held_out`
/// (files made absolute, so the models stay where they are); returns how many entries were left out.
pub fn held_out_db(db_dir: &Path, held_out: &[PathBuf], out: &Path) -> psdr::Result<usize> {
    let path = db_dir.join("catalog.json");
    let text = std::fs::read_to_string(&path).map_err(|e| psdr::Error::io(&path, e))?;
    let mut catalog: serde_json::Value = serde_json::from_str(&text).map_err(|e| psdr::Error::io(&path, e))?;
    let same = |a: &Path, b: &Path| a == b || a.canonicalize().ok().is_some_and(|x| b.canonicalize().ok() == Some(x));
    let mut dropped = 0;
    if let Some(models) = catalog["models"].as_array_mut() {
        models.retain(|m| {
            let file = db_dir.join(m["file"].as_str().unwrap_or(""));
            let keep = !held_out.iter().any(|h| same(h, &file));
            dropped += usize::from(!keep);
            keep
        });
        for m in models.iter_mut() {
            for key in ["file", "thumbnail"] {
                if let Some(f) = m[key].as_str() {
                    m[key] = serde_json::Value::from(db_dir.join(f).to_string_lossy().into_owned());
                }
            }
        }
    }
    std::fs::create_dir_all(out).map_err(|e| psdr::Error::io(out, e))?;
    let dest = out.join("catalog.json");
    std::fs::write(&dest, serde_json::to_string(&catalog).unwrap_or_default())
        .map_err(|e| psdr::Error::io(&dest, e))?;
    Ok(dropped)
}

/// What an attribution start (`known_start`) keeps of the truth beside its room and furniture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Known {
    /// Every material grey, no lights: the pipeline fits lights and materials.
    Geometry,
    /// The true materials, no lights: the pipeline fits the lights (with `fit_materials=false`).
    Materials,
    /// Every material grey, the true emitters where they are at unit radiance: radiances and materials fitted.
    Lights,
}

impl Known {
    pub const ALL: [Known; 3] = [Known::Geometry, Known::Materials, Known::Lights];

    /// The bench mode and start file name.
    pub fn mode(self) -> &'static str {
        match self {
            Known::Geometry => "known_geometry",
            Known::Materials => "known_materials",
            Known::Lights => "known_lights",
        }
    }
}

/// The truth's geometry as `--set geometry=FILE` takes it (the error attribution of bench_real_rooms): the walls
/// renamed as the room stage names them (wall_x0/x1 on the left and right, wall_z0/z1 behind and in front of the
/// view). `Known::Materials` keeps the true materials and drops the emitters; otherwise the room surfaces'
/// materials are `floor`, `wall` and `ceiling`, every material grey (0.5, homogeneous), and with
/// `Known::Lights` the truth's emitters stay where they are at unit radiance (else the pipeline places its own).
pub fn known_start(truth: &Scene, known: Known) -> Scene {
    let mut s = truth.clone();
    let rename =
        [("wall_left", "wall_x0"), ("wall_right", "wall_x1"), ("wall_back", "wall_z0"), ("wall_front", "wall_z1")];
    for o in s.objects.iter_mut() {
        if let Some((_, to)) = rename.iter().find(|(from, _)| o.name == *from) {
            o.name = to.to_string();
        }
    }
    if known != Known::Lights {
        s.objects.retain(|o| o.emitter.is_none());
    }
    for o in s.objects.iter_mut() {
        if let Some(e) = o.emitter.as_mut() {
            e.radiance = Vec3::ONE;
        }
    }
    if known == Known::Materials {
        return s;
    }
    // Grey homogeneous materials, the room's under the names the material stage gives them.
    let mut materials: Vec<Material> = vec![];
    let index = |materials: &mut Vec<Material>, name: &str| {
        materials.iter().position(|m| m.name == name).unwrap_or_else(|| {
            materials.push(Material::diffuse(name, Vec3::splat(0.5)));
            materials.len() - 1
        })
    };
    for o in s.objects.iter_mut() {
        let room = match o.name.as_str() {
            "floor" | "ceiling" => Some(o.name.clone()),
            n if n.starts_with("wall_") => Some("wall".to_string()),
            _ => None,
        };
        for p in o.parts.iter_mut() {
            let name = room.clone().unwrap_or_else(|| truth.materials[p.material].name.clone());
            p.material = index(&mut materials, &name);
        }
    }
    s.materials = materials;
    s.textures.clear();
    s
}
