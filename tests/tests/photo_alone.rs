//! `psdr run scripts/room.rhai photo.png` with nothing beside the photo (issue "A photo alone"): with the image
//! models in the models folder it runs every stage from the photo alone; without them it stops before any stage
//! with one message naming both missing models, `psdr models fetch` and the manual layout.
//!
//! The models are the tiny contract stand-ins of tests/models (the pinned networks cannot be downloaded here):
//! `depth.onnx` answers the photo's red channel as disparity, `segmentation.onnx` calls red floor, green wall
//! and blue ceiling. So the photo is painted from an analytic room (4 m wide, 2.6 m high, the back wall 5 m
//! ahead, the camera 1.5 m above the floor looking level with psdr's default 55-degree fov): red holds each
//! pixel's disparity, green marks the walls, blue the ceiling. The room the pipeline finds from what the
//! stand-ins answer is checked against that room. ONNX Runtime is needed (skipped without it unless
//! PSDR_REQUIRE_ORT=1).

use psdr::backend::CpuBackend;
use psdr::script::{run_script, RunOptions, ScriptRun};
use psdr::vision::ObservationInputs;
use std::path::{Path, PathBuf};

const W: u32 = 160;
const H: u32 = 120;
const FOV_Y_DEG: f32 = 55.0;
const CAMERA_HEIGHT: f32 = 1.5;
const HALF_WIDTH: f32 = 2.0;
const HEIGHT: f32 = 2.6;
const BACK: f32 = 5.0;
/// Disparity = DISPARITY_SCALE / distance along the view axis: 0.4-0.8 over what the camera sees, below the
/// walls' green so the segmentation still calls them walls.
const DISPARITY_SCALE: f32 = 2.0;

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// The photo of the analytic room: per pixel the depth along the view axis of the first surface its ray meets,
/// painted as (disparity, wall, ceiling).
fn paint_photo(path: &Path) {
    let t = (FOV_Y_DEG.to_radians() * 0.5).tan();
    let aspect = W as f32 / H as f32;
    let img = image::RgbImage::from_fn(W, H, |x, y| {
        let dx = (2.0 * (x as f32 + 0.5) / W as f32 - 1.0) * t * aspect;
        let dy = (1.0 - 2.0 * (y as f32 + 0.5) / H as f32) * t;
        // Distances along the view axis (z) to each plane the ray can meet; the nearest in front wins.
        let floor = if dy < 0.0 { CAMERA_HEIGHT / -dy } else { f32::INFINITY };
        let ceiling = if dy > 0.0 { (HEIGHT - CAMERA_HEIGHT) / dy } else { f32::INFINITY };
        let side = if dx != 0.0 { HALF_WIDTH / dx.abs() } else { f32::INFINITY };
        let z = floor.min(ceiling).min(side).min(BACK);
        let red = (DISPARITY_SCALE / z).min(1.0);
        let (g, b) = if z == floor {
            (0.05, 0.05)
        } else if z == ceiling {
            (0.1, 0.9)
        } else {
            (0.9, 0.1)
        };
        image::Rgb([(red * 255.0).round() as u8, (g * 255.0) as u8, (b * 255.0) as u8])
    });
    img.save(path).unwrap();
}

fn run(photo: &Path, models: &Path, out: &Path) -> psdr::Result<psdr::script::RunSummary> {
    run_script(
        ScriptRun {
            script: repo("scripts/room.rhai"),
            photo: photo.to_path_buf(),
            out: out.to_path_buf(),
            sets: vec![
                "room_iters=15".into(),
                "object_iters=10".into(),
                "material_iters=8".into(),
                "light_spp=16".into(),
                // The materials stage's searches cost minutes and are tested elsewhere: one division round per
                // light scale at three scales, no light placement or texture search here.
                "light_place_step=0.0".into(),
                "material_light_step=0.0".into(),
                "light_scale_steps=3".into(),
                "light_scale_rounds=1".into(),
                "texture_top_k=0".into(),
            ],
            options: RunOptions {
                quiet: true,
                preview_spp: 2,
                db: Some(repo("examples/models")),
                observations: Some(ObservationInputs {
                    models: Some(models.to_path_buf()),
                    ..ObservationInputs::new(photo)
                }),
                ..Default::default()
            },
            command: "test".into(),
        },
        Box::new(CpuBackend),
    )
}

#[test]
fn a_photo_alone_runs_every_stage_with_the_models_and_stops_at_once_without() {
    let dir = psdr_tests::temp_dir("photo-alone");
    let photo = dir.join("photo.png");
    paint_photo(&photo);

    // Without the models: one message naming both, the command and the manual layout, and no stage run.
    let empty = dir.join("no-models");
    std::fs::create_dir_all(&empty).unwrap();
    let out = dir.join("out-without");
    let err = run(&photo, &empty, &out).unwrap_err().to_string();
    for want in ["no depth and no segmentation", "depth.onnx", "segmentation.onnx", "psdr models fetch", "SHA-256"] {
        assert!(err.contains(want), "'{want}' missing from: {err}");
    }
    assert!(!out.join("stages").exists() || std::fs::read_dir(out.join("stages")).unwrap().next().is_none());

    // With the stand-ins in the models folder: every stage runs from the photo alone.
    let models = dir.join("models");
    std::fs::create_dir_all(&models).unwrap();
    std::fs::copy(repo("tests/models/tiny_depth.onnx"), models.join("depth.onnx")).unwrap();
    std::fs::copy(repo("tests/models/tiny_segmentation.onnx"), models.join("segmentation.onnx")).unwrap();
    // The optional CLIP image tower too: the script finds it in the models folder for the retrieval.
    std::fs::copy(repo("tests/models/tiny_clip_image.onnx"), models.join(psdr::vision::CLIP_IMAGE_FILE)).unwrap();
    let out = dir.join("out");
    let t = std::time::Instant::now();
    let summary = match run(&photo, &models, &out) {
        Ok(s) => s,
        Err(e) if e.to_string().contains("ONNX Runtime not found") => {
            assert!(std::env::var_os("PSDR_REQUIRE_ORT").is_none(), "PSDR_REQUIRE_ORT is set: {e}");
            eprintln!("skipping: {e}");
            return;
        }
        Err(e) => panic!("{e}"),
    };
    eprintln!("photo alone: {} stages in {:.1} s", summary.stages, t.elapsed().as_secs_f32());
    assert_eq!(summary.stages, 4, "room, objects, lights, materials");
    for f in ["scene.json", "render.png", "result.json", "report.html"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    let sources = &result["recorded"]["observations"]["sources"];
    assert!(sources["depth"].as_str().unwrap_or("").contains("depth.onnx"), "{sources}");
    assert!(sources["instances"].as_str().unwrap_or("").contains("segmentation.onnx"), "{sources}");
    let encoder = &result["recorded"]["objects_init"]["embedding"];
    assert!(encoder.as_str().unwrap_or("").ends_with(psdr::vision::CLIP_IMAGE_FILE), "{encoder}");
    // The room from the stand-ins' answers: the disparity is exact but 16x24 (the stand-in's output), so the
    // planes come from a coarse, upsampled map; the scale rests on the 1.5 m camera-height prior, which this
    // room was painted with.
    let room = &result["room"];
    let near = |key: &str, want: f32, tol: f32| {
        let got = room[key].as_f64().unwrap_or(f64::NAN) as f32;
        assert!((got - want).abs() <= tol * want, "room {key} {got:.3} m, painted {want} m (tolerance {tol})\n{room}");
    };
    near("height", HEIGHT, 0.15);
    // Each wall's distance from the camera: the one it faces is the back wall, the two across its view the
    // side walls (the wall behind the camera is not seen, so not checked).
    let v3 = |v: &serde_json::Value| {
        glam::Vec3::from_array(std::array::from_fn(|i| v[i].as_f64().unwrap_or(f64::NAN) as f32))
    };
    let camera = v3(&room["camera"]["position"]);
    let forward = v3(&result["camera"]["forward"]);
    let walls: Vec<(f32, f32)> = ["wall_x0", "wall_x1", "wall_z0", "wall_z1"]
        .iter()
        .map(|w| {
            let plane = &room["planes"][*w];
            let n = v3(&plane["normal"]);
            (n.dot(forward), n.dot(camera) - plane["d"].as_f64().unwrap_or(f64::NAN) as f32)
        })
        .collect();
    let back = walls.iter().min_by(|a, b| a.0.total_cmp(&b.0)).unwrap();
    assert!((back.1 - BACK).abs() <= 0.15 * BACK, "back wall {:.3} m ahead, painted {BACK} m\n{room}", back.1);
    let sides: Vec<f32> = walls.iter().filter(|w| w.0.abs() < 0.5).map(|w| w.1).collect();
    assert_eq!(sides.len(), 2, "{walls:?}");
    for d in sides {
        assert!((d - HALF_WIDTH).abs() <= 0.15 * HALF_WIDTH, "side wall {d:.3} m away, painted {HALF_WIDTH} m\n{room}");
    }
}
