//! scripts/room.rhai's `object_stretch`: the object stage's refinement may scale each axis of a model within
//! that factor of the retrieval's scale. The shipped example's photo (128x96, one cabinet) with a database whose
//! only cabinet is the true one squashed to 3/4 of its width, as a model of the right class but other
//! proportions is on a real photo. Stated: at the default (1) the refined scale is one factor for all three
//! axes; at 1.4 the width's factor over the height's comes within 10 % of the 4/3 the squash took away, and the
//! cabinet's mask IoU rises by at least 0.05.

use psdr::backend::CpuBackend;
use psdr::script::{run_script, RunOptions, ScriptRun};
use psdr_tests::furniture::stretched_obj;
use std::path::{Path, PathBuf};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// A model folder holding the example cabinet with its x coordinates times `sx`.
fn squashed_cabinet(dir: &Path, sx: f32) -> PathBuf {
    let db = dir.join("db");
    std::fs::create_dir_all(&db).unwrap();
    let text = std::fs::read_to_string(repo("examples/models/cabinet.obj")).unwrap();
    let squashed = stretched_obj(&text, [sx, 1.0, 1.0]);
    std::fs::write(db.join("cabinet.obj"), squashed).unwrap();
    db
}

/// The objects stage's refined scale of the cabinet and its final mask IoU.
fn refine(dir: &Path, db: &Path, stretch: &str) -> ([f64; 3], f64) {
    std::fs::create_dir_all(dir).unwrap();
    for ext in ["png", "depth.exr", "camera.json", "masks.png", "labels.json"] {
        std::fs::copy(repo(&format!("examples/fit/target.{ext}")), dir.join(format!("photo.{ext}"))).unwrap();
    }
    let out = dir.join("out");
    run_script(
        ScriptRun {
            script: repo("scripts/room.rhai"),
            photo: dir.join("photo.png"),
            out: out.clone(),
            sets: vec!["room_iters=10".into(), format!("object_stretch={stretch}")],
            options: RunOptions {
                quiet: true,
                preview_spp: 2,
                final_spp: 2,
                db: Some(db.to_path_buf()),
                until_stage: Some("objects".into()),
                ..Default::default()
            },
            command: "test".into(),
        },
        Box::new(CpuBackend),
    )
    .unwrap();
    let scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("scene.json")).unwrap()).unwrap();
    let cabinet = scene["shapes"].as_array().unwrap().iter().find(|s| s["name"] == "cabinet_7").unwrap();
    let s = &cabinet["transform"]["scale"];
    let scale = [0, 1, 2].map(|i| s[i].as_f64().unwrap());
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    let iou = result["recorded"]["object_refine"]["iou_final"][0].as_f64().unwrap();
    (scale, iou)
}

#[test]
fn a_model_of_other_proportions_is_stretched_to_the_photo_only_when_asked() {
    let dir = psdr_tests::temp_dir("object-stretch");
    let db = squashed_cabinet(&dir, 0.75);
    let (kept, iou_kept) = refine(&dir.join("kept"), &db, "1.0");
    let (stretched, iou_stretched) = refine(&dir.join("stretched"), &db, "1.4");
    eprintln!("kept {kept:?} (IoU {iou_kept:.3}), stretched {stretched:?} (IoU {iou_stretched:.3})");
    assert!(kept.iter().all(|&v| (v / kept[0] - 1.0).abs() < 1e-5), "one factor at the default: {kept:?}");
    let ratio = stretched[0] / stretched[1];
    assert!((ratio / (4.0 / 3.0) - 1.0).abs() < 0.1, "width over height {ratio:.3}, the squash took 4/3");
    assert!(iou_stretched > iou_kept + 0.05, "IoU {iou_kept:.3} -> {iou_stretched:.3}");
}
