//! The object stage of scripts/room.rhai on two real-furniture evaluation rooms (of bench_real_rooms: its
//! seed, its 512 x 384 size). Room09, where two failures met: an open shelf stands behind an armchair, wall seen
//! between its boards. Its bottom is hidden, not held up (`hides_bottom`): without that rule the shelf was hung
//! on the wall at half its height, as another model (mask IoU 0.35). And the joint pose refinement drew the
//! rightly placed shelf through the wall behind it, 50 % larger (IoU 0.72 -> 0.11; where the wall cuts it
//! the boundary gradient is missing): the refinement now keeps objects between the walls
//! (`keep_inside_room`), and room.rhai puts back where the retrieval placed it any object whose mask IoU the
//! refinement lowers by more than `object_refine_max_iou_loss` (kept inside, the shelf still turned: 0.44).
//! That collapse depends on float rounding: in this test's build the same inputs refine the shelf to 0.75
//! (the psdr binary and the benchmark: as above), so the test states what must hold either way: every object
//! retrieved as its true model ends with mask IoU >= 0.6 (measured 0.67-0.98), the shelf among them, and no
//! object ends more than 0.1 below where it started. The photo's pixels do not enter this stage (masks and depth do, and the retrieval's image encoder
//! is not given), so it is rendered with direct light only. Skipped without the Sweet Home 3D libraries.
//!
//! And room00, whose sofa (the true "Couch", 2.07 m wide) the retrieval's shortlist left out while the
//! footprint was the visible points' 10-90 % span (1.58 m): another sofa took its place and 60 % of the
//! room's image error. Measured with the span taken as 0.8 of the side: the Couch retrieved (sweep score 0.95
//! against the next model's 0.87), and in the other eleven rooms the same scene to the byte.

use psdr::db::default_db;
use psdr::script::{run_script, RunOptions, ScriptRun};
use psdr_tests::real_rooms::{generate_rooms, write_room_with_paths, TrueModel};
use std::path::Path;

/// The object stage (`--until objects`) of the benchmark's room `index`, at its seed and 512 x 384 size: the
/// run's record and the true models; None without the Sweet Home 3D libraries.
fn objects_stage(index: usize) -> Option<(serde_json::Value, Vec<TrueModel>)> {
    if !Path::new(psdr::db::SWEET_HOME_3D_FURNITURE).is_dir() {
        eprintln!("skipped: the Sweet Home 3D furniture libraries are not installed");
        return None;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let db = default_db(None, &root.join("examples/models")).unwrap();
    let (w, h) = (512, 384);
    let rooms = generate_rooms(&db, index + 1, 2027, w, h).unwrap();
    let room = &rooms[index];
    let dir = psdr_tests::temp_dir(&format!("real-room-objects-{index}"));
    // The benchmark's 128 samples (its depth, the mean over each pixel's samples, to the bit), paths of 2
    // vertices (the photo's pixels are not read here).
    let truth = write_room_with_paths(room, &dir, w, h, 128, 2).unwrap();
    let out = dir.join("out");
    run_script(
        ScriptRun {
            script: root.join("scripts/room.rhai"),
            photo: dir.join("photo.png"),
            out: out.clone(),
            sets: vec![],
            options: RunOptions {
                quiet: true,
                preview_spp: 1,
                final_spp: 1,
                until_stage: Some("objects".into()),
                db: Some(db),
                ..Default::default()
            },
            command: "test".into(),
        },
        Box::new(psdr::backend::CpuBackend),
    )
    .unwrap();
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    Some((result["recorded"].clone(), truth))
}

#[test]
fn a_shelf_behind_an_armchair_stands_on_the_floor_and_keeps_its_pixels() {
    let Some((rec, truth)) = objects_stage(9) else { return };
    let placed = rec["objects_init"]["placed"].as_array().unwrap();
    let refine = &rec["object_refine"];
    let numbers =
        |key: &str| -> Vec<f64> { refine[key].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect() };
    let (start, fin) = (numbers("iou_start"), numbers("iou_final"));
    assert_eq!(start.len(), placed.len(), "{refine}");
    let mut true_models = vec![];
    for (k, p) in placed.iter().enumerate() {
        let instance = p["instance"].as_u64().unwrap() as u16;
        let chosen = p["chosen"]["path"].as_str().unwrap();
        let t = truth.iter().find(|t| t.instance == instance);
        let right = t.is_some_and(|t| Path::new(chosen) == t.file);
        eprintln!(
            "{} ({}): {chosen}{}, support {}, IoU {:.2} -> {:.2}",
            p["name"],
            t.map_or("?", |t| t.class.as_str()),
            if right { " (the true model)" } else { "" },
            p["support"],
            start[k],
            fin[k]
        );
        assert!(fin[k] >= start[k] - 0.1, "{}: IoU {:.2} -> {:.2}", p["name"], start[k], fin[k]);
        if right {
            true_models.push((t.unwrap().class.clone(), fin[k]));
        }
    }
    assert!(true_models.iter().any(|(c, _)| c == "shelf"), "the shelf's true model not retrieved: {true_models:?}");
    assert!(true_models.iter().all(|(_, iou)| *iou >= 0.6), "{true_models:?}");
}

#[test]
fn a_sofa_wider_than_its_visible_points_span_is_retrieved_as_its_true_model() {
    let Some((rec, truth)) = objects_stage(0) else { return };
    let placed = rec["objects_init"]["placed"].as_array().unwrap();
    let sofa = placed.iter().find(|p| p["class"] == "sofa").expect("no sofa placed");
    let t = truth.iter().find(|t| u64::from(t.instance) == sofa["instance"].as_u64().unwrap()).unwrap();
    let chosen = sofa["chosen"]["path"].as_str().unwrap();
    let alternatives: Vec<&str> =
        sofa["alternatives"].as_array().unwrap().iter().map(|a| a["model"].as_str().unwrap()).collect();
    assert_eq!(Path::new(chosen), t.file, "the sofa became {} ({alternatives:?})", sofa["chosen"]["model"]);
}
