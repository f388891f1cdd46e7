//! The whole pipeline on the shipped example (`psdr run scripts/room.rhai examples/fit/target.png --db
//! examples/models --set truth=examples/fit/truth.json`, the README's main command plus the model folder the
//! photo's cabinet comes from and its ground truth), at reduced iterations: every output exists and loads
//! (scene.json renders, the Mitsuba export is XML naming every file it writes, scene.glb passes Khronos'
//! validator), and result.json's `evaluation` against the truth is within stated bounds (measured at these
//! settings on the photo with every bounce, 18 s on 2 cores: room within 0.04 % where seen, the cabinet 0.07 %
//! of its distance / 0.8 degrees / 0.07 % in height with the true model, image RMSE at 1/8 size 2.4 % of the
//! mean, SSIM 0.79, albedos within 15.5 %, the cabinet's body and plinth fitted apart).

use psdr::backend::CpuBackend;
use psdr::render::{render_cpu, SceneData};
use psdr::script::{run_script, RunOptions, ScriptRun};
use std::path::{Path, PathBuf};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

#[test]
fn the_example_photo_becomes_a_scene_close_to_its_truth() {
    let out = psdr_tests::temp_dir("pipeline-example");
    let t = std::time::Instant::now();
    run_script(
        ScriptRun {
            script: repo("scripts/room.rhai"),
            photo: repo("examples/fit/target.png"),
            out: out.clone(),
            sets: vec![
                format!("truth={}", repo("examples/fit/truth.json").display()),
                "room_iters=20".into(),
                "object_iters=30".into(),
                "material_iters=15".into(),
                "light_spp=32".into(),
            ],
            options: RunOptions {
                quiet: true,
                preview_spp: 4,
                db: Some(repo("examples/models")),
                ..Default::default()
            },
            command: "test".into(),
        },
        Box::new(CpuBackend),
    )
    .unwrap();
    eprintln!("pipeline: {:.1} s", t.elapsed().as_secs_f32());
    for f in ["scene.json", "scene.glb", "render.png", "result.json", "report.html", "mitsuba/scene.xml"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // scene.json loads and renders.
    let scene = psdr::scene::load_scene(&out.join("scene.json")).unwrap();
    let frame = render_cpu(&SceneData::build(&scene).unwrap(), &scene.settings, &|_, _| {});
    // Materials per part of the retrieved model: the cabinet's body and plinth fitted apart, as the truth has
    // them (a blue body, a near-black plinth); the handles show on too few pixels and keep their start.
    let albedo = |n: &str| match scene.materials.iter().find(|m| m.name == n).map(|m| m.albedo) {
        Some(psdr::scene::Color::Constant(a)) => a,
        other => panic!("{n}: {other:?}"),
    };
    let (body, plinth) = (albedo("cabinet_7:body"), albedo("cabinet_7:plinth"));
    assert!(body.z > body.y && body.y > body.x, "body {body}");
    assert!(plinth.max_element() < 0.5 * body.z, "plinth {plinth} vs body {body}");
    assert!(frame.radiance.iter().all(|v| v.is_finite()) && frame.radiance.iter().any(|&v| v > 0.0));
    // The Mitsuba export: one <shape> per object part, every mesh file it names written.
    let xml = std::fs::read_to_string(out.join("mitsuba/scene.xml")).unwrap();
    assert!(xml.contains("<scene") && xml.trim_end().ends_with("</scene>"));
    let parts: usize = scene.objects.iter().map(|o| o.parts.len()).sum();
    assert_eq!(xml.matches("<shape").count(), parts);
    let files: Vec<&str> =
        xml.split("name=\"filename\" value=\"").skip(1).filter_map(|s| s.split('"').next()).collect();
    assert_eq!(files.iter().filter(|f| f.starts_with("meshes/")).count(), parts);
    for file in files {
        assert!(out.join("mitsuba").join(file).is_file(), "{file} named but not written");
    }
    if let Some(v) = psdr_tests::gltf_validator() {
        let (errors, warnings, messages) = psdr_tests::validate_glb(&v, &out.join("scene.glb"));
        assert_eq!(errors, 0, "{messages}");
        eprintln!("glTF validator: 0 errors, {warnings} warnings");
    }
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    let e = &result["recorded"]["evaluation"];
    eprintln!("{}", serde_json::to_string_pretty(e).unwrap());
    let num = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let room = &e["room"];
    // The box where the photo shows it (measured 0.01-0.05 %); the wall behind the camera is unseen and
    // assumed 5 cm behind it (the truth: 30 cm), so the length along the view is 5 % short.
    for k in ["across_error_rel", "height_error_rel", "left_error_rel", "right_error_rel", "ahead_error_rel"] {
        assert!(num(&room[k]).abs() < 0.01, "{k}: {}", room[k]);
    }
    assert!(num(&room["along_error_rel"]).abs() < 0.07, "{room}");
    assert!(num(&room["camera_height_error_m"]).abs() < 0.02, "{room}");
    // The cabinet: the true model, centre within 1 % of its distance, yaw within 2 degrees, height within 2 %.
    assert_eq!(
        (e["objects_found"].as_u64(), e["objects_true"].as_u64(), e["models_retrieved"].as_u64()),
        (Some(1), Some(1), Some(1))
    );
    let o = &e["objects"][0];
    assert!(num(&o["centre_error_rel"]) < 0.01 && num(&o["yaw_error_deg"]) < 2.0, "{o}");
    assert!(num(&o["height_error_rel"]).abs() < 0.02, "{o}");
    // Lights kept, and the image: RMSE at 1/8 size within 10 % of the mean (measured 2.4 %; on the earlier
    // 3-vertex photo 4.5 %, 9.6 % before the lights were placed off their grid, 12.2 % before the light-scale
    // search), SSIM above 0.7 (0.79: the evaluation's 64-spp render of 16-vertex paths against a 4096-spp
    // photo; its noise alone costs SSIM, 0.53 at 16 spp).
    assert!(e["lights"]["fitted"].as_u64().unwrap() >= 1);
    let image = &e["image"];
    assert!(num(&image["rmse_rel_1_8"]) < 0.10 && num(&image["ssim"]) > 0.7, "{image}");
    // Albedos (the lights on a grid and moved, not the truth's: the scale they and the albedos share is off
    // by more than on a known geometry): every surface within 40 % (measured worst 15.5 %, the cabinet's
    // body: fitted as a diffuse surface where the truth has a 0.2 specular layer, see the Appearance issue).
    assert!(num(&e["albedo"]["worst_error_rel"]) < 0.4, "{}", e["albedo"]);
    // The report opens with the photo, the final render and their difference (written beside it, the
    // difference within the two images' range), the evaluation and the fitted lights.
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let summary = html.find("<h2>Summary</h2>").expect("a summary");
    assert!(summary < html.find("<h2>Stages</h2>").unwrap());
    for (label, file) in
        [("photo", "photo.png"), ("final render", "render.png"), ("|render - photo|", "difference.png")]
    {
        assert!(html.contains(&format!("<figcaption>{label}</figcaption>")), "{label} missing");
        assert!(out.join("report").join(file).is_file(), "{file} missing");
    }
    // Every stage shows its final render beside its difference from the photo (at the working size).
    for stage in ["01_room", "02_objects", "03_lights", "04_materials"] {
        let diff = out.join("stages").join(stage).join("difference.png");
        assert!(diff.is_file(), "{} missing", diff.display());
    }
    assert_eq!(html.matches("<figcaption>|final - photo|</figcaption>").count(), 4, "one per stage");
    let emitters = e["lights"]["fitted"].as_u64().unwrap() + e["lights"]["fitted_windows"].as_u64().unwrap_or(0);
    assert!(html.contains(&format!("Emitters (lights and windows): {emitters}")), "emitter count");
    assert!(html.contains("Evaluation against the truth"));
    assert!(html.contains("image.rmse_rel_1_8"));
    // The image error split among the truth's surfaces: the shares cover it, the parts add in quadrature to the
    // whole as the evaluation measures it, and the page lists them.
    let parts = e["image"]["by_surface_1_8"].as_array().expect("image.by_surface_1_8 in result.json");
    let share: f64 = parts.iter().map(|p| p["share"].as_f64().unwrap()).sum();
    let whole = parts.iter().map(|p| p["rmse_rel"].as_f64().unwrap().powi(2)).sum::<f64>().sqrt();
    let rmse = e["image"]["rmse_rel_1_8"].as_f64().unwrap();
    assert!((share - 1.0).abs() < 1e-6 && (whole - rmse).abs() < 1e-4 * rmse.max(1e-3), "{share} {whole} {rmse}");
    assert!(parts.iter().any(|p| p["surface"] == "wall") && parts.iter().any(|p| p["surface"] == "floor"), "{parts:?}");
    assert!(html.contains("The image error by the truth"));
    // The lights the fits removed (of the candidates on the ceiling grid, behind the camera and on the walls),
    // each by name, in result.json and on the page.
    let removed = result["recorded"]["lights_removed"].as_array().expect("lights_removed in result.json");
    let first = removed[0]["removed"][0].as_str().unwrap();
    assert!(html.contains("Lights the fit removed") && html.contains(first), "{removed:?}");
    // Every material with what it is and the decisions behind it: the walls, each its own material first,
    // joined back where the photo shows them alike (or kept apart), in result.json and on the page.
    let joined = &result["recorded"]["joined_materials"];
    assert!(joined["members"].as_array().is_some_and(|m| !m.is_empty()), "joined_materials: {joined}");
    let materials = result_materials(&out);
    assert!(html.contains(&format!("Materials: {materials} (")), "materials table");
    assert!(html.contains("one material for wall_"), "the walls' decision on the page");
}

/// The number of materials of the run's fitted scene.
fn result_materials(out: &std::path::Path) -> usize {
    let scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("scene.json")).unwrap()).unwrap();
    scene["materials"].as_array().unwrap().len()
}
