//! The material and light stage on a known geometry (room.rhai with `--set geometry=FILE`: the room and object
//! stages take the file as it is): a room rendered by psdr with two ceiling lights out of view and five
//! homogeneous materials (floor, walls, ceiling, a cabinet, a table), started from grey albedos (0.5) and white
//! unit lights, measured by the pipeline's own evaluation against the truth; the objects, given where they
//! are, cover their instances exactly (mask IoU 1). The photo is a 256-spp render with every bounce (16-vertex
//! paths) saved as 8-bit sRGB, as the pipeline reads photos.
//!
//! Measured (2 cores, 17 s in a release build; the light scale searched per channel from a 3-point grid, the
//! lights' split refitted at each factor with each surface's albedo free): image RMSE at 1/8 size 1.4 %,
//! albedos a median 0.9 % off, the worst 1.2 %, both lights' radiances within 4 % per channel. With the split
//! held at what the first rounds found (`light_scale_split=false`): 2.2 %, 3.1 % and 10.2 % (the table's red:
//! the dimmer light at 3.0 of its true 4.0 red, every albedo too bright). Without the scale search 8.2 % and
//! 20 %; with one factor for the three channels 4.6 % and 12 %; fitted with 3-vertex paths (the photo's bounces
//! missing) RMSE 14 %, albedos 13 % and 32 % (those three measured before the split was refitted). The
//! Appearance issue asks 3 % and 5 %.

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
    let mut errors: Vec<f64> = surfaces.iter().map(|s| s["error_rel"].as_f64().unwrap()).collect();
    errors.sort_by(f64::total_cmp);
    assert!(errors[2] < 0.03 && errors[4] < 0.05, "albedo errors (median, worst) {errors:?}");
    // Each light's radiance per channel against the truth's (its position is given).
    let fitted = psdr::scene::load_scene(&dir.join("out/scene.json")).unwrap();
    for light in truth.objects.iter().filter(|o| o.emitter.is_some()) {
        let name = &light.name;
        let f = fitted.objects.iter().find(|o| &o.name == name).and_then(|o| o.emitter).map(|e| e.radiance);
        let (f, t) = (f.unwrap_or_else(|| panic!("{name} was removed")), light.emitter.unwrap().radiance);
        assert!((f / t - 1.0).abs().max_element() < 0.08, "{name}: {f} for {t}");
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

/// A light scale searched over a range that stops short of the photo's (the test room above wants 1.1-1.3 on its photo with every bounce)
/// ends at the range's end, and the report says the lights and albedos were not told apart there. The lights'
/// split is held (`light_scale_split=false`): refitted at each factor it moves the lights' level as well, so
/// a range short of the truth can end at either end (measured: 0.5, the low one).
#[test]
fn a_light_scale_at_the_range_end_is_reported() {
    let dir = psdr_tests::temp_dir("material-light-scale-edge");
    let (truth, ids) = truth_room();
    write_known_geometry(&dir, &truth, &ids);
    let quick = [
        "light_scale_low=0.5",
        "light_scale_high=0.8",
        "light_scale_steps=3",
        "light_scale_extend=0",
        "light_scale_rounds=1",
        "material_iters=0",
        "light_scale_split=false",
    ];
    let result = run_on_known_geometry(&dir, &[&quick[..], &["texture_top_k=0", "material_light_step=0"]].concat());
    let chosen = result["recorded"]["light_scale"]["chosen"].as_array().unwrap().clone();
    assert!(chosen.iter().any(|c| c.as_f64().unwrap() > 0.799), "{chosen:?}");
    let html = std::fs::read_to_string(dir.join("out/report.html")).unwrap();
    assert!(
        html.contains("(0.50..0.80)") && html.contains("ended at the searched range&#39;s end"),
        "no note on the range's end"
    );
}

/// The same room with its lights left out of the given geometry: the light stage must find them (candidates on
/// a ceiling grid, the ones the photo needs kept, chosen three times with the albedos divided out between, then
/// placed by search with neighbours merged; each surface's albedo free in those fits, the lights white there),
/// and the materials must still come out right. Measured (40 s in a release build beside another job): 2
/// lights for 2, 12 and 11 cm from the true ones, image RMSE 2.5 %, every albedo within 1.6 %. The Appearance
/// issue asks 10 cm; at this photo's 16x12 fitted blocks the fitted albedos' error moves the placement's minimum
/// 10-20 cm (benchmarks/README.md, "Where the known-geometry lights' 11-12 cm comes from"). Before the
/// candidates were chosen again under divided albedos (one choice under the start's grey 0.5): 2 lights, the
/// brighter 50 cm off, the dimmer not found (its light went to the panel behind the camera, 1.5 m away), RMSE
/// 7.1 %, albedos within 21 %; chosen three times without the merge: 4 lights, the brighter fitted as two
/// panels 1 m apart on either side of it, 27-30 cm off, RMSE 2.5 %, albedos within 4 %. With the lights'
/// common scale searched at each division (`light_pass_scale`, which took real rooms 08 and 09 from 2 of 3 and
/// 1 of 2 lights to all five, the twelve rooms' albedo median 11.1 -> 6.8 %): 15 and 10 cm, RMSE 2.6 %, the
/// cabinet's albedo 4.3 % off (2.3 % without), so the albedos are held to the 5 %. With the divisions
/// at 16 spp (`albedo_spp`): 13 and 13 cm, RMSE 2.4 %, every albedo within 2.5 %. With the lights placed once
/// more after the joint pass, under its albedos, at 256 samples per block (`late_light_step`), from 0.1 m: 3.3
/// and 11.8 cm, RMSE 2.1 % (at 64 samples 8.1 and 22 cm; at 1024 3.3 and 10.1 cm); from 0.05 m alone (one step
/// level, the default): **3.3 and 6.3 cm**, RMSE 2.0 %, so both lights are held to the 10 cm.
#[test]
fn known_geometry_without_its_lights_finds_them() {
    let dir = psdr_tests::temp_dir("material-light-find");
    let (truth, ids) = truth_room();
    write_known_geometry(&dir, &truth, &ids);
    let start_path = dir.join("start.json");
    let mut start = psdr::scene::load_scene(&start_path).unwrap();
    start.objects.retain(|o| o.emitter.is_none());
    psdr::scene::save_scene(&start, &start_path).unwrap();
    let result = run_on_known_geometry(&dir, &[]);
    let e = &result["recorded"]["evaluation"];
    eprintln!("{}", serde_json::to_string_pretty(&e["lights"]).unwrap());
    let fitted = e["lights"]["fitted"].as_u64().unwrap();
    assert_eq!(fitted, 2, "{fitted} lights for 2");
    let errors: Vec<(String, f64)> = e["lights"]["positions"]["lights"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| (l["truth"].as_str().unwrap().to_string(), l["error_m"].as_f64().unwrap_or(f64::INFINITY)))
        .collect();
    assert_eq!(errors.len(), 2, "{errors:?}");
    // Each true light matched (least summed distance), within the 10 cm.
    assert!(["light_a", "light_b"].iter().all(|n| errors.iter().any(|e| e.0 == *n)), "{errors:?}");
    assert!(errors.iter().all(|e| e.1 < 0.1), "{errors:?}");
    let rmse = e["image"]["rmse_rel_1_8"].as_f64().unwrap();
    assert!(rmse < 0.035, "image RMSE at 1/8 size {rmse}");
    for s in e["albedo"]["surfaces"].as_array().unwrap() {
        assert!(s["error_rel"].as_f64().unwrap() < 0.05, "{s}");
    }
}
