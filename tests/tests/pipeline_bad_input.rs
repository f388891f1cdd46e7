//! The whole pipeline (scripts/room.rhai) on bad or thin input, at reduced settings: a photo with no
//! segmentation beside it is a clear error naming the files it looked for, and no scene is written; a labels
//! file naming no furniture gives the empty room (every output written); an empty model folder gives the
//! documented fallback, each instance as a box of its size recorded as "no model of class ..."; never a panic.

use psdr::backend::CpuBackend;
use psdr::script::{run_script, RunOptions, ScriptRun};
use std::path::{Path, PathBuf};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// A copy of the shipped example's photo and observation files in `dir`, as `photo.*`.
fn example_copy(dir: &Path, with_masks: bool) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let mut files = vec!["png", "depth.exr", "camera.json"];
    if with_masks {
        files.extend(["masks.png", "labels.json"]);
    }
    for ext in files {
        std::fs::copy(repo(&format!("examples/fit/target.{ext}")), dir.join(format!("photo.{ext}"))).unwrap();
    }
    dir.join("photo.png")
}

fn run(photo: &Path, out: &Path, db: &Path) -> psdr::Result<()> {
    let quick = [
        "room_iters=5",
        "object_iters=5",
        "material_iters=2",
        "albedo_rounds=1",
        "light_spp=8",
        "light_place_step=0",
        "material_light_step=0",
        "light_scale_steps=3",
        "texture_top_k=0",
    ];
    run_script(
        ScriptRun {
            script: repo("scripts/room.rhai"),
            photo: photo.to_path_buf(),
            out: out.to_path_buf(),
            sets: quick.iter().map(|s| s.to_string()).collect(),
            options: RunOptions { quiet: true, preview_spp: 2, db: Some(db.to_path_buf()), ..Default::default() },
            command: "test".into(),
        },
        Box::new(CpuBackend),
    )
    .map(|_| ())
}

fn result(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap()
}

#[test]
fn no_segmentation_is_a_clear_error_and_writes_no_scene() {
    let dir = psdr_tests::temp_dir("pipeline-no-masks");
    let photo = example_copy(&dir, false);
    let out = dir.join("out");
    let e = run(&photo, &out, &repo("examples/models")).unwrap_err().to_string();
    assert!(e.contains("photo.masks.png"), "{e}");
    assert!(!out.join("scene.json").exists() && !out.join("scene.glb").exists());
}

#[test]
fn labels_naming_no_furniture_give_the_empty_room() {
    let dir = psdr_tests::temp_dir("pipeline-no-furniture");
    let photo = example_copy(&dir, true);
    // The cabinet's instance (7) labelled as part of the floor: the labels name the room only.
    std::fs::write(
        dir.join("photo.labels.json"),
        r#"{"1": "floor", "2": "wall", "3": "wall", "4": "wall", "6": "ceiling", "7": "floor"}"#,
    )
    .unwrap();
    let out = dir.join("out");
    run(&photo, &out, &repo("examples/models")).unwrap();
    let scene = psdr::scene::load_scene(&out.join("scene.json")).unwrap();
    let furniture: Vec<&str> = scene
        .objects
        .iter()
        .map(|o| o.name.as_str())
        .filter(|n| !["floor", "ceiling"].contains(n) && !n.starts_with("wall_") && !n.starts_with("light_"))
        .collect();
    assert!(furniture.is_empty(), "{furniture:?}");
    for f in ["scene.glb", "render.png", "report.html", "mitsuba/scene.xml"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert!(result(&out)["recorded"]["objects_init"]["placed"].as_array().unwrap().is_empty());
}

#[test]
fn an_empty_model_folder_places_boxes_and_says_why() {
    let dir = psdr_tests::temp_dir("pipeline-empty-db");
    let photo = example_copy(&dir, true);
    let db = dir.join("models");
    std::fs::create_dir_all(&db).unwrap();
    let out = dir.join("out");
    run(&photo, &out, &db).unwrap();
    let v = result(&out);
    let init = &v["recorded"]["objects_init"];
    assert_eq!(init["models_indexed"], 0, "{init}");
    let placed = init["placed"].as_array().unwrap();
    assert_eq!(placed.len(), 1, "{init}");
    let model = placed[0]["chosen"]["model"].as_str().unwrap();
    assert!(model.contains("no model of class cabinet"), "{model}");
    for f in ["scene.json", "scene.glb", "render.png", "report.html", "mitsuba/scene.xml"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
}
