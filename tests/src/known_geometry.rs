//! A room whose geometry the material and light stage is given (room.rhai's `--set geometry=FILE`): the truth
//! in the pipeline's naming, its photo and observation files, and the start (the truth's geometry with grey
//! albedos and white unit lights).

use crate::rooms::{room_scene, FurnitureBox, RoomSpec};
use glam::{Vec2, Vec3};
use psdr::render::{render_cpu, Frame, SceneData};
use psdr::scene::{save_scene, Emitter, Material, Object, RenderSettings, Scene};
use psdr::stages::Segment;
use psdr::vision::{canonical_class, Instance, Instances};
use std::path::Path;

/// The truth in the pipeline's naming (room surfaces floor, ceiling, wall_x0 ... wall_z1 with materials floor,
/// wall, ceiling, uv in metres; furniture CLASS_ID with a material of its own name), two ceiling lights of
/// different colours out of the camera's view, 128 x 96 pixels; and each object's instance id.
pub fn truth_room() -> (Scene, Vec<(u16, &'static str)>) {
    let spec = RoomSpec { w: 4.5, d: 5.5, h: 2.7, cam: Vec3::new(0.3, 1.5, 2.2), yaw: 8.0, pitch: -14.0, fov: 60.0 };
    let boxes = [
        FurnitureBox { x: -0.9, z: -1.6, size: Vec3::new(0.9, 1.2, 0.5), yaw: 15.0 },
        FurnitureBox { x: 0.8, z: -0.6, size: Vec3::new(1.2, 0.75, 0.8), yaw: -20.0 },
    ];
    let (mut s, _) = room_scene(&spec, &boxes, false, 128, 96);
    let albedos = [
        ("floor", Vec3::new(0.45, 0.3, 0.2)),
        ("wall", Vec3::new(0.75, 0.72, 0.65)),
        ("ceiling", Vec3::splat(0.85)),
        ("cabinet_7", Vec3::new(0.2, 0.35, 0.55)),
        ("table_8", Vec3::new(0.6, 0.25, 0.15)),
        ("light", Vec3::splat(0.8)),
    ];
    s.materials = albedos.iter().map(|(n, a)| Material::diffuse(n, *a)).collect();
    let rename = [
        ("floor", "floor", 0, 1, Vec2::new(spec.w, spec.d)),
        ("ceiling", "ceiling", 2, 6, Vec2::new(spec.w, spec.d)),
        ("wall_left", "wall_x0", 1, 2, Vec2::new(spec.d, spec.h)),
        ("wall_right", "wall_x1", 1, 3, Vec2::new(spec.d, spec.h)),
        ("wall_back", "wall_z0", 1, 4, Vec2::new(spec.w, spec.h)),
        ("wall_front", "wall_z1", 1, 5, Vec2::new(spec.w, spec.h)),
        ("box0", "cabinet_7", 3, 7, Vec2::ONE),
        ("box1", "table_8", 4, 8, Vec2::ONE),
    ];
    let mut ids = vec![];
    for (from, to, m, id, metres) in rename {
        let o = s.objects.iter_mut().find(|o| o.name == from).unwrap();
        o.name = to.into();
        for p in o.parts.iter_mut() {
            p.material = m;
            p.uvs.iter_mut().flatten().for_each(|uv| *uv *= metres);
        }
        ids.push((id, to));
    }
    let light = s.objects.iter().position(|o| o.name == "light").unwrap();
    let mut l = s.objects.remove(light);
    l.parts.iter_mut().for_each(|p| p.material = 5);
    for (name, x, z, le) in
        [("light_a", -1.0, 0.2, Vec3::new(9.0, 8.0, 6.5)), ("light_b", 1.1, 1.2, Vec3::new(4.0, 4.5, 6.0))]
    {
        let mut k = l.clone();
        k.name = name.into();
        k.pose.translation = Vec3::new(x, spec.h - 0.01, z);
        k.pose.scale = Vec3::splat(0.5);
        k.emitter = Some(Emitter::uniform(le, false));
        s.objects.push(k);
    }
    // Every bounce, as a photo records it (16 vertices: within 0.1 % of converged in a light room).
    s.settings = RenderSettings { spp: 256, max_depth: 16, rr_depth: 3, seed: 7 };
    (s, ids)
}

/// One sample per pixel of `s`, for its object ids.
pub fn id_frame(s: &Scene) -> Frame {
    let mut s = s.clone();
    s.settings = RenderSettings { spp: 1, max_depth: 1, rr_depth: 1, seed: 0 };
    render_cpu(&SceneData::build(&s).unwrap(), &s.settings, &|_, _| {})
}

/// Per material the pixels of `photo` (a render of `s`) that show an object `keep` accepts, as a segmenter's
/// masks would give them through the truth's object ids; a material shown on fewer than 20 pixels is left out.
pub fn truth_segments(s: &Scene, photo: &Frame, keep: impl Fn(&Object) -> bool) -> Vec<Segment> {
    let mut out: Vec<Segment> = vec![];
    for (o, obj) in s.objects.iter().enumerate().filter(|(_, obj)| keep(obj)) {
        let m = obj.parts[0].material;
        let mask: Vec<f32> = photo.object_id.iter().map(|&id| f32::from(u8::from(id as usize == o))).collect();
        if mask.iter().sum::<f32>() < 20.0 {
            continue;
        }
        match out.iter_mut().find(|x| x.material == m) {
            Some(seg) => seg.mask.iter_mut().zip(&mask).for_each(|(a, b)| *a = a.max(*b)),
            None => out.push(Segment { material: m, mask }),
        }
    }
    out
}

/// The segmentation of `truth`'s frame `f`: each object named in `ids` covers its pixels with its id, its
/// class the name's first word.
pub fn instances_of(truth: &Scene, f: &Frame, ids: &[(u16, &str)]) -> Instances {
    let map = |o: u32| truth.objects.get(o as usize).and_then(|x| ids.iter().find(|(_, n)| *n == x.name));
    let px: Vec<u16> = f.object_id.iter().map(|&o| map(o).map_or(0, |i| i.0)).collect();
    let instances = ids
        .iter()
        .map(|&(id, name)| {
            let (class, kind) = canonical_class(name.split('_').next().unwrap());
            let pixels = px.iter().filter(|&&v| v == id).count();
            Instance { id, label: None, class: class.into(), kind, pixels }
        })
        .filter(|i| i.pixels > 0)
        .collect();
    Instances { width: f.width as usize, height: f.height as usize, ids: px, instances }
}

/// Renders `truth` and writes into `dir` what the pipeline reads (photo.png as 8-bit sRGB, its instance masks
/// and labels, its field of view, its depth), truth.json, and start.json: the truth's geometry with grey
/// albedos (0.5, constant) and white unit lights.
pub fn write_known_geometry(dir: &Path, truth: &Scene, ids: &[(u16, &str)]) {
    let (w, h) = (truth.camera.width, truth.camera.height);
    let f = render_cpu(&SceneData::build(truth).unwrap(), &truth.settings, &|_, _| {});
    assert!(f.radiance.iter().all(|&v| v < 1.0), "the photo must not clip");
    let masks: Vec<u16> = f
        .object_id
        .iter()
        .map(|&o| truth.objects.get(o as usize).and_then(|x| ids.iter().find(|(_, n)| *n == x.name)).map_or(0, |i| i.0))
        .collect();
    psdr::output::write_png_srgb(&dir.join("photo.png"), w, h, &f.radiance).unwrap();
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, masks.clone())
        .unwrap()
        .save(dir.join("photo.masks.png"))
        .unwrap();
    let labels: serde_json::Map<String, serde_json::Value> = ids
        .iter()
        .filter(|(id, _)| masks.contains(id))
        .map(|(id, n)| (id.to_string(), n.split('_').next().unwrap().into()))
        .collect();
    std::fs::write(dir.join("photo.labels.json"), serde_json::to_string(&labels).unwrap()).unwrap();
    std::fs::write(dir.join("photo.camera.json"), format!("{{\"fov_y_deg\": {}}}", truth.camera.fov_y_deg)).unwrap();
    psdr::output::write_exr_channels(&dir.join("photo.depth.exr"), w, h, &[("Z".into(), f.depth.clone())]).unwrap();
    save_scene(truth, &dir.join("truth.json")).unwrap();
    let mut start = truth.clone();
    for m in start.materials.iter_mut().filter(|m| m.name != "light") {
        *m = Material::diffuse(&m.name, Vec3::splat(0.5));
    }
    start.objects.iter_mut().filter_map(|o| o.emitter.as_mut()).for_each(|e| e.radiance = Vec3::ONE);
    start.settings = RenderSettings { spp: 16, max_depth: 3, rr_depth: 3, seed: 0 };
    save_scene(&start, &dir.join("start.json")).unwrap();
}

/// Runs scripts/room.rhai on the photo in `dir` with the known geometry start.json and the truth; returns
/// result.json.
pub fn run_on_known_geometry(dir: &Path, extra_sets: &[&str]) -> serde_json::Value {
    use psdr::script::{run_script, RunOptions, ScriptRun};
    let out = dir.join("out");
    let mut sets = vec![
        format!("geometry={}", dir.join("start.json").display()),
        format!("truth={}", dir.join("truth.json").display()),
    ];
    sets.extend(extra_sets.iter().map(|s| s.to_string()));
    run_script(
        ScriptRun {
            script: Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/room.rhai"),
            photo: dir.join("photo.png"),
            out: out.clone(),
            sets,
            options: RunOptions { quiet: true, preview_spp: 4, ..Default::default() },
            command: "test".into(),
        },
        Box::new(psdr::backend::CpuBackend),
    )
    .unwrap();
    serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap()
}
