//! The material and light stage on a known geometry (room.rhai with `--set geometry=FILE`: the room and object
//! stages take the file as it is): a room rendered by psdr with two ceiling lights out of view and five
//! homogeneous materials (floor, walls, ceiling, a cabinet, a table), started from grey albedos (0.5) and white
//! unit lights. The fit must reproduce the photo at 1/8 size within 3 % of its mean (RMSE) and every albedo
//! within 5 % (distance relative to the truth's, RGB), measured by the pipeline's own evaluation against the
//! truth. The photo is a 256-spp render saved as 8-bit sRGB, as the pipeline reads photos. Measured (16 s):
//! RMSE 1.4 %, albedos 0.8-4.9 % (worst the table and the cabinet). The margin on the albedos is small by
//! nature: per colour channel the lights' scale is pinned only by interreflections (`light_scale_search`);
//! before that search the walls came out 30 % too blue under too yellow lights.

use glam::Vec3;
use psdr::backend::CpuBackend;
use psdr::render::{render_cpu, SceneData};
use psdr::scene::{save_scene, Emitter, Material, Scene};
use psdr::script::{run_script, RunOptions, ScriptRun};
use psdr_tests::rooms::{room_scene, FurnitureBox, RoomSpec};
use std::path::{Path, PathBuf};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// The truth in the pipeline's naming (room surfaces floor, ceiling, wall_x0 ... wall_z1 with materials floor,
/// wall, ceiling; furniture CLASS_ID with a material of its own name), and each object's instance id.
fn truth_scene() -> (Scene, Vec<(u16, &'static str)>) {
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
        ("floor", "floor", 0, 1),
        ("ceiling", "ceiling", 2, 6),
        ("wall_left", "wall_x0", 1, 2),
        ("wall_right", "wall_x1", 1, 3),
        ("wall_back", "wall_z0", 1, 4),
        ("wall_front", "wall_z1", 1, 5),
        ("box0", "cabinet_7", 3, 7),
        ("box1", "table_8", 4, 8),
    ];
    let mut ids = vec![];
    for (from, to, m, id) in rename {
        let o = s.objects.iter_mut().find(|o| o.name == from).unwrap();
        o.name = to.into();
        o.parts.iter_mut().for_each(|p| p.material = m);
        ids.push((id, to));
    }
    // Two lights of different colours over the camera's half of the room, out of its view.
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
        k.emitter = Some(Emitter { radiance: le, two_sided: false });
        s.objects.push(k);
    }
    s.settings = psdr::scene::RenderSettings { spp: 256, max_depth: 3, rr_depth: 3, seed: 7 };
    (s, ids)
}

#[test]
fn known_geometry_wrong_materials_and_lights_converge_to_the_photo() {
    let dir = psdr_tests::temp_dir("material-light-fit");
    let (truth, ids) = truth_scene();
    let (w, h) = (truth.camera.width, truth.camera.height);
    let f = render_cpu(&SceneData::build(&truth).unwrap(), &truth.settings, &|_, _| {});
    assert!(f.radiance.chunks(3).all(|p| p.iter().all(|&v| v < 1.0)), "the photo must not clip");
    // Observations: the photo, its instance masks and labels (a segmenter's output), its field of view.
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
    std::fs::write(dir.join("photo.camera.json"), "{\"fov_y_deg\": 60}").unwrap();
    psdr::output::write_exr_channels(&dir.join("photo.depth.exr"), w, h, &[("Z".into(), f.depth.clone())]).unwrap();
    save_scene(&truth, &dir.join("truth.json")).unwrap();
    // The known geometry with wrong materials (grey) and lights (white, unit).
    let mut start = truth.clone();
    start
        .materials
        .iter_mut()
        .filter(|m| m.name != "light")
        .for_each(|m| *m = Material::diffuse(&m.name, Vec3::splat(0.5)));
    start.objects.iter_mut().filter_map(|o| o.emitter.as_mut()).for_each(|e| e.radiance = Vec3::ONE);
    start.settings = psdr::scene::RenderSettings { spp: 16, max_depth: 3, rr_depth: 3, seed: 0 };
    save_scene(&start, &dir.join("start.json")).unwrap();

    let out = dir.join("out");
    let t = std::time::Instant::now();
    run_script(
        ScriptRun {
            script: repo("scripts/room.rhai"),
            photo: dir.join("photo.png"),
            out: out.clone(),
            sets: vec![
                format!("geometry={}", dir.join("start.json").display()),
                format!("truth={}", dir.join("truth.json").display()),
            ],
            options: RunOptions { quiet: true, preview_spp: 4, ..Default::default() },
            command: "test".into(),
        },
        Box::new(CpuBackend),
    )
    .unwrap();
    eprintln!("materials and lights: {:.1} s", t.elapsed().as_secs_f32());
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    let e = &result["recorded"]["evaluation"];
    eprintln!("{}", serde_json::to_string_pretty(&e["albedo"]).unwrap());
    eprintln!("{}", serde_json::to_string_pretty(&e["image"]).unwrap());
    let rmse = e["image"]["rmse_rel_1_8"].as_f64().unwrap();
    assert!(rmse < 0.03, "image RMSE at 1/8 size {rmse}");
    let surfaces = e["albedo"]["surfaces"].as_array().unwrap();
    assert_eq!(surfaces.len(), 5, "floor, wall, ceiling, cabinet, table: {surfaces:?}");
    for s in surfaces {
        assert!(s["error_rel"].as_f64().unwrap() < 0.05, "{s}");
    }
}
