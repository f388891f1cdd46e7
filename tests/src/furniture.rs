//! Parametric furniture made of boxes, as OBJ text, for the object stage's tests: each class has six variants
//! of different proportions, so a test can hide the true model among five same-class distractors.

/// OBJ text accumulating axis-aligned boxes (outward faces).
#[derive(Default)]
pub struct BoxModel {
    text: String,
    vertices: usize,
}

impl BoxModel {
    /// A box spanning `lo` to `hi` (metres).
    pub fn add(&mut self, lo: [f32; 3], hi: [f32; 3]) -> &mut Self {
        let c = |i: usize| {
            [
                if i & 1 == 0 { lo[0] } else { hi[0] },
                if i & 2 == 0 { lo[1] } else { hi[1] },
                if i & 4 == 0 { lo[2] } else { hi[2] },
            ]
        };
        for i in 0..8 {
            let v = c(i);
            self.text += &format!("v {} {} {}\n", v[0], v[1], v[2]);
        }
        let b = self.vertices + 1;
        // Corner index bits: x = 1, y = 2, z = 4; quads counter-clockwise seen from outside.
        for q in [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]] {
            self.text +=
                &format!("f {} {} {}\nf {} {} {}\n", b + q[0], b + q[1], b + q[2], b + q[0], b + q[2], b + q[3]);
        }
        self.vertices += 8;
        self
    }

    pub fn obj(&self) -> String {
        self.text.clone()
    }
}

/// Classes the generator knows.
pub const CLASSES: [&str; 6] = ["table", "chair", "sofa", "cabinet", "lamp", "bookcase"];

/// Variant `k` (0..6) of a class, standing on y = 0, centred on x = z = 0, front toward +z.
pub fn variant(class: &str, k: usize) -> String {
    let f = |a: [f32; 6]| a[k % 6];
    let mut m = BoxModel::default();
    match class {
        "table" => {
            let (w, d, h, leg) = (
                f([1.2, 1.6, 0.8, 1.0, 1.4, 0.9]),
                f([0.8, 0.9, 0.8, 0.5, 0.7, 0.9]),
                f([0.75, 0.74, 0.72, 0.45, 0.9, 0.6]),
                0.06,
            );
            m.add([-w / 2.0, h - 0.04, -d / 2.0], [w / 2.0, h, d / 2.0]);
            for (sx, sz) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
                let (x, z) = (sx * (w / 2.0 - leg), sz * (d / 2.0 - leg));
                m.add([x - leg / 2.0, 0.0, z - leg / 2.0], [x + leg / 2.0, h - 0.04, z + leg / 2.0]);
            }
        }
        "chair" => {
            let (w, seat, back) = (
                f([0.45, 0.5, 0.42, 0.55, 0.48, 0.4]),
                f([0.45, 0.48, 0.42, 0.5, 0.4, 0.46]),
                f([0.9, 1.0, 0.8, 1.1, 0.75, 0.95]),
            );
            m.add([-w / 2.0, seat - 0.05, -w / 2.0], [w / 2.0, seat, w / 2.0]);
            m.add([-w / 2.0, seat, -w / 2.0], [w / 2.0, back, -w / 2.0 + 0.05]);
            for (sx, sz) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
                let (x, z) = (sx * (w / 2.0 - 0.03), sz * (w / 2.0 - 0.03));
                m.add([x - 0.025, 0.0, z - 0.025], [x + 0.025, seat - 0.05, z + 0.025]);
            }
        }
        "sofa" => {
            let (w, d, back, arm) = (
                f([2.0, 1.6, 2.4, 1.8, 2.2, 1.4]),
                f([0.9, 0.85, 1.0, 0.8, 0.95, 0.9]),
                f([0.85, 0.8, 0.9, 0.75, 1.0, 0.8]),
                f([0.2, 0.15, 0.25, 0.1, 0.2, 0.3]),
            );
            m.add([-w / 2.0, 0.0, -d / 2.0], [w / 2.0, 0.42, d / 2.0]);
            m.add([-w / 2.0, 0.42, -d / 2.0], [w / 2.0, back, -d / 2.0 + 0.2]);
            m.add([-w / 2.0, 0.42, -d / 2.0], [-w / 2.0 + arm, 0.62, d / 2.0]);
            m.add([w / 2.0 - arm, 0.42, -d / 2.0], [w / 2.0, 0.62, d / 2.0]);
        }
        "cabinet" => {
            let (w, d, h) = (
                f([0.8, 1.2, 0.6, 1.0, 0.5, 1.6]),
                f([0.45, 0.5, 0.4, 0.35, 0.55, 0.45]),
                f([0.9, 0.8, 1.2, 1.8, 0.7, 0.85]),
            );
            m.add([-w / 2.0, 0.08, -d / 2.0], [w / 2.0, h, d / 2.0]);
            m.add([-w / 2.0 + 0.03, 0.0, -d / 2.0 + 0.03], [w / 2.0 - 0.03, 0.08, d / 2.0 - 0.03]);
            m.add([-0.15, h * 0.75, d / 2.0], [0.15, h * 0.75 + 0.03, d / 2.0 + 0.03]);
        }
        "lamp" => {
            let (base, h, shade) = (
                f([0.12, 0.15, 0.1, 0.2, 0.12, 0.08]),
                f([0.5, 0.6, 0.4, 0.7, 0.45, 0.55]),
                f([0.3, 0.35, 0.25, 0.4, 0.2, 0.3]),
            );
            m.add([-base / 2.0, 0.0, -base / 2.0], [base / 2.0, 0.03, base / 2.0]);
            m.add([-0.015, 0.03, -0.015], [0.015, h * 0.7, 0.015]);
            m.add([-shade / 2.0, h * 0.7, -shade / 2.0], [shade / 2.0, h, shade / 2.0]);
        }
        _ => {
            // bookcase
            let (w, d, h, n) = (
                f([0.8, 1.0, 0.6, 1.2, 0.9, 0.7]),
                f([0.3, 0.35, 0.28, 0.4, 0.32, 0.25]),
                f([1.8, 2.0, 1.2, 1.6, 0.9, 2.1]),
                [4, 5, 3, 4, 2, 6][k % 6],
            );
            m.add([-w / 2.0, 0.0, -d / 2.0], [-w / 2.0 + 0.03, h, d / 2.0]);
            m.add([w / 2.0 - 0.03, 0.0, -d / 2.0], [w / 2.0, h, d / 2.0]);
            m.add([-w / 2.0, 0.0, -d / 2.0], [w / 2.0, h, -d / 2.0 + 0.02]);
            for s in 0..=n {
                let y = h * s as f32 / n as f32;
                m.add([-w / 2.0, (y - 0.02).max(0.0), -d / 2.0], [w / 2.0, y.max(0.02), d / 2.0]);
            }
        }
    }
    m.obj()
}

/// Writes every class's six variants (`CLASS_K.obj`) into `dir`.
pub fn write_model_set(dir: &std::path::Path) {
    std::fs::create_dir_all(dir).unwrap();
    for class in CLASSES {
        for k in 0..6 {
            std::fs::write(dir.join(format!("{class}_{k}.obj")), variant(class, k)).unwrap();
        }
    }
}

/// The refinement of scripts/room.rhai's object stage, on the objects of start.json.
pub fn refine_script(names: &[String], iters: usize) -> String {
    let list = names.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ");
    format!(
        r#"
let s = load_scene(PHOTO_DIR + "/start.json");
let names = [{list}];
let targets = [];
let params = [];
for n in names {{
    targets.push(load_image(PHOTO_DIR + "/" + n + ".mask.exr"));
    params.push(#{{ select: "object/" + n + "/translation", free: "xz" }});
    params.push("object/" + n + "/yaw");
    params.push(#{{ select: "object/" + n + "/scale", space: "uniform_log" }});
}}
let depth = load_image(PHOTO_DIR + "/depth.exr");
let union = targets[0];
for t in targets {{ union = union + t; }}
let scale = masked_mean(depth, union);
// Gaussian pyramids of the masks (full size to 1/16): coarse levels pull objects that do not yet overlap
// their instance. The targets' pyramids are built once.
let levels = 5;
let weights = [1.0, 2.0, 4.0, 8.0, 16.0];
let target_pyramids = [];
for t in targets {{ target_pyramids.push(pyramid(t, levels)); }}
optimize(s, #{{
    params: params, iters: {iters}, spp: 4, seed: 1,
    lr: #{{ "object/*/translation": 0.02, "object/*/yaw": 0.05, "object/*/scale": 0.03 }},
    schedule: #{{ kind: "exponential", gamma: 0.96 }},
    loss: |r| {{
        let masks = 0.0;
        for k in 0..names.len() {{
            let p = pyramid(r.mask(names[k]), levels);
            for l in 0..levels {{
                masks = masks + weights[l] * mean(abs(p[l] - target_pyramids[k][l]));
            }}
        }}
        #{{ masks: masks, depth: 10.0 * masked_mean(abs(r.depth - depth), union) / scale }}
    }},
}});
let out = #{{}};
for n in names {{
    out[n] = #{{ t: s.get("object/" + n + "/translation"), yaw: s.get("object/" + n + "/yaw"), scale: s.get("object/" + n + "/scale") }};
}}
record("poses", out);
"#
    )
}

use glam::{Quat, Vec3};
use psdr::render::{render_cpu, Frame, SceneData};
use psdr::scene::{save_scene, Material, Object, Pose, Scene};
use psdr::stages::ObjectPlacement;
use psdr::vision::{canonical_class, Instance, Instances};
use std::path::Path;

/// A generated model (`CLASS_K`) placed on the floor (or on another object) at `at`, turned by `yaw` degrees.
#[derive(Clone, Copy)]
pub struct Item {
    pub model: &'static str,
    pub at: Vec3,
    pub yaw: f32,
}

impl Item {
    pub fn class(&self) -> &'static str {
        self.model.split('_').next().unwrap_or("object")
    }
}

/// The degrees a generated model of `class` looks the same turned by (the table's four legs: 180; the lamp's
/// square boxes: 90).
pub fn symmetry(class: &str) -> f32 {
    match class {
        "table" => 180.0,
        "lamp" => 90.0,
        _ => 360.0,
    }
}

/// The yaw period of `items[k]` as this view shows it: the class's symmetry, or 180 or 90 degrees where the
/// item turned by that much changes its mask or its depth (by over 1 % of the depth) in under 5 % of its pixels
/// (a cabinet whose only asymmetry is a 3 cm handle, under a pixel at 5 m: 3 %, from the half-pixel shift of its
/// body; a chair whose back is out of frame: 11 %). Yaw errors are judged modulo this: the photo cannot tell the rest.
pub fn observed_symmetry(
    room: &Scene,
    room_classes: &[String],
    items: &[Item],
    k: usize,
    db_dir: &Path,
    frame: &Frame,
) -> f32 {
    let o = room.objects.len() + k;
    let mut period = symmetry(items[k].class());
    for turn in [180.0, 90.0] {
        if turn >= period {
            continue;
        }
        let mut turned = items.to_vec();
        turned[k].yaw += turn;
        let (_, g, _) = furnished_room(room, room_classes, &turned, db_dir);
        let (mut either, mut changed) = (0usize, 0usize);
        for p in 0..frame.object_id.len() {
            let (a, b) = (frame.object_id[p] == o as u32, g.object_id[p] == o as u32);
            either += (a || b) as usize;
            changed += (a != b || (a && (frame.depth[p] - g.depth[p]).abs() > 0.01 * frame.depth[p])) as usize;
        }
        if either > 0 && (changed as f32) < 0.05 * either as f32 {
            period = turn;
        }
    }
    period
}

/// `room` (from `rooms::room_scene`, no furniture) with the items' models from `db_dir`, rendered at the room's
/// camera (max depth 1): the scene, the frame, and its instances (one per visible item, classes by name; the
/// room's surfaces as floor/wall/ceiling, its ceiling light left out).
pub fn furnished_room(
    room: &Scene,
    room_classes: &[String],
    items: &[Item],
    db_dir: &Path,
) -> (Scene, Frame, Instances) {
    let mut truth = room.clone();
    let mut classes = room_classes.to_vec();
    truth.materials.push(Material::diffuse("wood", Vec3::splat(0.4)));
    let m = truth.materials.len() - 1;
    let db = psdr::db::ModelSet::from_folder(db_dir).unwrap();
    for it in items {
        // The model as the database serves it (its footprint centred, its base at y = 0), so that a pose
        // means the same to the truth and to the retrieval.
        let entry = db.models.iter().find(|m| m.name == it.model).unwrap();
        let mut parts = entry.load_parts().unwrap();
        parts.iter_mut().for_each(|p| p.material = m);
        truth.objects.push(Object {
            name: it.model.into(),
            parts,
            pose: Pose { translation: it.at, rotation: Quat::from_rotation_y(it.yaw.to_radians()), scale: Vec3::ONE },
            emitter: None,
        });
        classes.push(it.class().into());
    }
    truth.settings.max_depth = 1;
    let f = render_cpu(&SceneData::build(&truth).unwrap(), &truth.settings, &|_, _| {});
    let (w, h) = (truth.camera.width as usize, truth.camera.height as usize);
    let mut inst = Instances { width: w, height: h, ids: vec![0; w * h], instances: vec![] };
    for (o, class) in classes.iter().enumerate() {
        let pixels = f.object_id.iter().filter(|&&i| i == o as u32).count();
        if pixels == 0 || truth.objects[o].emitter.is_some() {
            continue;
        }
        let id = o as u16 + 1;
        for (p, &i) in f.object_id.iter().enumerate() {
            if i == o as u32 {
                inst.ids[p] = id;
            }
        }
        let (c, kind) = canonical_class(class);
        inst.instances.push(Instance { id, label: Some(class.clone()), class: c.into(), kind, pixels });
    }
    (truth, f, inst)
}

/// Writes what `refine_script` reads into `dir`: start.json (the room with the placed objects, one material
/// each), NAME.mask.exr per placed object (its instance), depth.exr and photo.png. Returns the objects' names.
pub fn write_refinement_inputs(
    dir: &Path,
    room: &Scene,
    placed: &[(ObjectPlacement, Object)],
    inst: &Instances,
    frame: &Frame,
) -> Vec<String> {
    std::fs::create_dir_all(dir).unwrap();
    let (w, h) = (frame.width, frame.height);
    let mut start = room.clone();
    let mut names = vec![];
    for (p, o) in placed {
        let mut o = o.clone();
        start.materials.push(Material::diffuse(&p.name, Vec3::splat(0.5)));
        let mi = start.materials.len() - 1;
        o.parts.iter_mut().for_each(|q| q.material = mi);
        start.objects.push(o);
        let mask: Vec<f32> = inst.ids.iter().map(|&v| (v == p.instance) as u32 as f32).collect();
        psdr::output::write_exr_channels(&dir.join(format!("{}.mask.exr", p.name)), w, h, &[("Y".into(), mask)])
            .unwrap();
        names.push(p.name.clone());
    }
    start.settings.max_depth = 1;
    psdr::output::write_exr_channels(&dir.join("depth.exr"), w, h, &[("Z".into(), frame.depth.clone())]).unwrap();
    psdr::output::write_png_srgb(&dir.join("photo.png"), w, h, &frame.radiance).unwrap();
    save_scene(&start, &dir.join("start.json")).unwrap();
    names
}

/// Runs `refine_script(names, iters)` on the inputs in `dir`; returns the recorded poses (name -> #{t, yaw,
/// scale}).
pub fn run_refinement(dir: &Path, names: &[String], iters: usize) -> serde_json::Value {
    use psdr::script::{run_script, RunOptions, ScriptRun};
    std::fs::write(dir.join("refine.rhai"), refine_script(names, iters)).unwrap();
    let out = dir.join(format!("out{iters}"));
    run_script(
        ScriptRun {
            script: dir.join("refine.rhai"),
            photo: dir.join("photo.png"),
            out: out.clone(),
            sets: vec![],
            options: RunOptions { quiet: true, preview_spp: 1, ..Default::default() },
            command: "refinement".into(),
        },
        Box::new(psdr::backend::CpuBackend),
    )
    .unwrap();
    let res: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    res["recorded"]["poses"].clone()
}

/// The first number of a JSON number or array (a parameter's value as `s.get` records it).
pub fn first_number(v: &serde_json::Value) -> f32 {
    v.as_array().map_or_else(|| v.as_f64().unwrap_or(f64::NAN), |a| a[0].as_f64().unwrap_or(f64::NAN)) as f32
}

/// The object stage's test rooms (6 x 6 x 2.8 m, one camera): three furnishings of 4-5 generated models, among
/// them a lamp on a table, objects cut by the image border and objects hidden by others.
pub fn stage_rooms() -> (crate::rooms::RoomSpec, Vec<Vec<Item>>) {
    let r = crate::rooms::RoomSpec {
        w: 6.0,
        d: 6.0,
        h: 2.8,
        cam: Vec3::new(0.0, 1.6, 2.6),
        yaw: 0.0,
        pitch: -18.0,
        fov: 60.0,
    };
    let rooms: Vec<Vec<Item>> = vec![
        vec![
            Item { model: "sofa_2", at: Vec3::new(0.0, 0.0, -1.6), yaw: 0.0 },
            Item { model: "table_0", at: Vec3::new(0.3, 0.0, -0.2), yaw: 10.0 },
            Item { model: "lamp_1", at: Vec3::new(0.6, 0.74, -0.3), yaw: 0.0 },
            Item { model: "chair_3", at: Vec3::new(-1.9, 0.0, 0.4), yaw: 70.0 },
        ],
        vec![
            Item { model: "cabinet_1", at: Vec3::new(1.2, 0.0, -2.7), yaw: 0.0 },
            Item { model: "bookcase_0", at: Vec3::new(-1.6, 0.0, -2.75), yaw: 0.0 },
            Item { model: "chair_0", at: Vec3::new(0.9, 0.0, -1.6), yaw: -30.0 },
            Item { model: "table_4", at: Vec3::new(2.0, 0.0, 0.3), yaw: 45.0 },
        ],
        vec![
            Item { model: "sofa_0", at: Vec3::new(-0.6, 0.0, -2.2), yaw: 15.0 },
            Item { model: "chair_5", at: Vec3::new(-0.3, 0.0, -1.0), yaw: 200.0 },
            Item { model: "lamp_3", at: Vec3::new(1.8, 0.0, -2.3), yaw: 0.0 },
            Item { model: "cabinet_4", at: Vec3::new(-2.2, 0.0, -0.6), yaw: 90.0 },
            Item { model: "bookcase_2", at: Vec3::new(1.2, 0.0, -2.75), yaw: 0.0 },
        ],
    ];
    (r, rooms)
}

/// An OBJ file's text with every vertex scaled per axis by `s` and its `mtllib` line dropped: a model of the same
/// class with other proportions (a distractor, or a database model unlike the photo's).
pub fn stretched_obj(text: &str, s: [f32; 3]) -> String {
    text.lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(rest) => {
                let v: Vec<f32> = rest.split_whitespace().map(|x| x.parse().unwrap()).collect();
                format!("v {} {} {}\n", v[0] * s[0], v[1] * s[1], v[2] * s[2])
            }
            None if l.starts_with("mtllib") => String::new(),
            None => format!("{l}\n"),
        })
        .collect()
}
