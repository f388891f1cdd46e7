//! The material and light stage on a known geometry (room.rhai with `--set geometry=FILE`: the room and object
//! stages take the file as it is): a room rendered by psdr with two ceiling lights out of view and five
//! homogeneous materials (floor, walls, ceiling, a cabinet, a table), started from grey albedos (0.5) and white
//! unit lights. The fit must reproduce the photo at 1/8 size within 3 % of its mean (RMSE) and every albedo
//! within 5 % (distance relative to the truth's, RGB), measured by the pipeline's own evaluation against the
//! truth; the objects, given where they are, cover their instances exactly (mask IoU 1). The photo is a
//! 256-spp render saved as 8-bit sRGB, as the pipeline reads photos. Measured (20 s): RMSE 1.4 %, albedos
//! 1.1-4.5 % (worst the table and the cabinet); with one division round per searched light scale (the
//! script's setting for a while) the albedos came out 12-16 % off. The margin on the albedos is small by nature: per colour
//! channel the lights' scale is pinned only by interreflections (`light_scale_search`); before that search the
//! walls came out 30 % too blue under too yellow lights.

use psdr_tests::known_geometry::{run_on_known_geometry, truth_room, write_known_geometry};

#[test]
fn known_geometry_wrong_materials_and_lights_converge_to_the_photo() {
    let dir = psdr_tests::temp_dir("material-light-fit");
    let (truth, ids) = truth_room();
    write_known_geometry(&dir, &truth, &ids);
    let t = std::time::Instant::now();
    let result = run_on_known_geometry(&dir, &[]);
    eprintln!("materials and lights: {:.1} s", t.elapsed().as_secs_f32());
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
    // The given geometry is the truth's: each object covers exactly its instance (`evaluation.mask_iou`
    // through the script's `evaluate`, at the photo's size, against the masks read beside the photo).
    let ious = e["mask_iou"]["objects"].as_array().unwrap();
    assert_eq!(ious.len(), 2, "cabinet_7 and table_8: {ious:?}");
    assert!(e["mask_iou"]["worst"].as_f64().unwrap() > 0.999, "{}", e["mask_iou"]);
    // Homogeneous truth, homogeneous result: no crop looked textured.
    for s in result["recorded"]["surface_textures"].as_array().unwrap() {
        assert!(s["chosen"].is_null(), "{s}");
    }
}

/// A light scale searched over a range that stops short of the photo's (the test room above wants 1.1-1.6)
/// ends at the range's end, and the report says the lights and albedos were not told apart there.
#[test]
fn a_light_scale_at_the_range_end_is_reported() {
    let dir = psdr_tests::temp_dir("material-light-scale-edge");
    let (truth, ids) = truth_room();
    write_known_geometry(&dir, &truth, &ids);
    let quick = [
        "light_scale_low=0.5",
        "light_scale_high=0.8",
        "light_scale_steps=3",
        "light_scale_rounds=1",
        "material_iters=0",
    ];
    let result = run_on_known_geometry(&dir, &[&quick[..], &["texture_top_k=0", "material_light_step=0"]].concat());
    let chosen = result["recorded"]["light_scale"]["chosen"].as_array().unwrap().clone();
    assert!(chosen.iter().any(|c| c.as_f64().unwrap() > 0.799), "{chosen:?}");
    let html = std::fs::read_to_string(dir.join("out/report.html")).unwrap();
    assert!(html.contains("ended at the searched range&#39;s end (0.5..0.8)"), "no note on the range's end");
}
