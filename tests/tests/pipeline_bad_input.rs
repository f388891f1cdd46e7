//! The whole pipeline (scripts/room.rhai) on bad or thin input, at reduced settings: a photo with no
//! segmentation beside it is a clear error naming the files it looked for, and no scene is written; a labels
//! file naming no furniture gives the empty room (every output written); a model folder that is missing, empty
//! or lacks a class the photo shows, labels of another photo and an output path that cannot be written stop the
//! run before its first stage with a message naming what is wrong; labels of ids the mask lacks are a warning;
//! placeholder boxes only when asked for, and then said; never a panic.

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
    run_with(photo, out, db, &[])
}

fn run_with(photo: &Path, out: &Path, db: &Path, extra: &[&str]) -> psdr::Result<()> {
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
            sets: quick.iter().chain(extra).map(|s| s.to_string()).collect(),
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

/// Whether the run made any stage folder (a check before the first stage leaves none).
fn ran_a_stage(out: &Path) -> bool {
    out.join("stages").read_dir().is_ok_and(|mut d| d.next().is_some())
}

#[test]
fn a_model_folder_that_is_missing_empty_or_lacks_a_class_stops_before_the_first_stage() {
    let dir = psdr_tests::temp_dir("pipeline-bad-db");
    let photo = example_copy(&dir, true);
    // Missing.
    let out = dir.join("out-missing");
    let e = run(&photo, &out, &dir.join("no-such-folder")).unwrap_err().to_string();
    assert!(e.contains("no-such-folder") && e.contains("does not exist"), "{e}");
    assert!(!ran_a_stage(&out));
    // Empty.
    let empty = dir.join("models-empty");
    std::fs::create_dir_all(&empty).unwrap();
    let out = dir.join("out-empty");
    let e = run(&photo, &out, &empty).unwrap_err().to_string();
    assert!(e.contains("models-empty") && e.contains("holds no models"), "{e}");
    assert!(!ran_a_stage(&out));
    // Models, but none of the photo's class (the example shows a cabinet).
    let chairs = dir.join("models-chairs");
    std::fs::create_dir_all(&chairs).unwrap();
    for f in ["chair.obj", "chair.mtl"] {
        std::fs::copy(repo(&format!("examples/models/{f}")), chairs.join(f)).unwrap();
    }
    let out = dir.join("out-chairs");
    let e = run(&photo, &out, &chairs).unwrap_err().to_string();
    assert!(e.contains("no model of cabinet (instances [7])") && e.contains("placeholder_boxes"), "{e}");
    assert!(!ran_a_stage(&out));
}

#[test]
fn placeholder_boxes_only_when_asked_and_said() {
    let dir = psdr_tests::temp_dir("pipeline-placeholders");
    let photo = example_copy(&dir, true);
    let db = dir.join("models");
    std::fs::create_dir_all(&db).unwrap();
    std::fs::copy(repo("examples/models/chair.obj"), db.join("chair.obj")).unwrap();
    let out = dir.join("out");
    run_with(&photo, &out, &db, &["placeholder_boxes=true"]).unwrap();
    let v = result(&out);
    let init = &v["recorded"]["objects_init"];
    let placed = init["placed"].as_array().unwrap();
    assert_eq!(placed.len(), 1, "{init}");
    let model = placed[0]["chosen"]["model"].as_str().unwrap();
    assert!(model.contains("placeholder box (no model of class cabinet)"), "{model}");
    assert_eq!(v["recorded"]["placeholders"][0]["class"], "cabinet", "{}", v["recorded"]);
    let report = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(report.contains("placeholder boxes for classes the database lacks: cabinet"));
    for f in ["scene.json", "scene.glb", "render.png", "report.html", "mitsuba/scene.xml"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
}

#[test]
fn labels_of_ids_the_mask_lacks_warn_and_only_none_matching_is_an_error() {
    let dir = psdr_tests::temp_dir("pipeline-labels");
    let photo = example_copy(&dir, true);
    // Two labels for instances the mask does not hold (a cropped-out object, an exporter's full class list).
    std::fs::write(
        dir.join("photo.labels.json"),
        r#"{"1": "floor", "2": "wall", "3": "wall", "4": "wall", "6": "ceiling", "7": "cabinet", "40": "sofa", "41": "lamp"}"#,
    )
    .unwrap();
    let out = dir.join("out");
    run(&photo, &out, &repo("examples/models")).unwrap();
    let warnings = result(&out)["recorded"]["observations"]["warnings"].to_string();
    assert!(warnings.contains("[40, 41]") && warnings.contains("left out"), "{warnings}");
    // Labels of another photo: nothing matches.
    std::fs::write(dir.join("photo.labels.json"), r#"{"40": "sofa", "41": "floor"}"#).unwrap();
    let e = run(&photo, &dir.join("out2"), &repo("examples/models")).unwrap_err().to_string();
    assert!(e.contains("none of which the mask") && e.contains("[40, 41]"), "{e}");
    assert!(!ran_a_stage(&dir.join("out2")));
}

#[test]
fn an_output_path_that_is_a_file_or_not_writable_is_refused_before_any_work() {
    let dir = psdr_tests::temp_dir("pipeline-bad-out");
    let photo = example_copy(&dir, true);
    let file = dir.join("taken");
    std::fs::write(&file, "a file").unwrap();
    let e = run(&photo, &file, &repo("examples/models")).unwrap_err().to_string();
    assert!(e.contains("taken") && e.contains("existing file"), "{e}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "a file", "the file is left alone");
    // A folder that cannot be made or written (read-only file system; file modes do not stop root).
    let e = run(&photo, Path::new("/proc/psdr-out"), &repo("examples/models")).unwrap_err().to_string();
    assert!(e.contains("/proc/psdr-out") && e.contains("output folder"), "{e}");
}
