//! Photos of any size go through the stages at a working size and come out at their own. Independent truth:
//! the observations resampled to the working size (`Observations::resized`: centred crop to sides that are
//! multiples of 8, majority ids, per-instance median depth, the field of view of the crop) must match the same
//! scene rendered directly at that size with that field of view; and the pipeline on a 200x140 photo (sides not
//! multiples of 8) at working size 96 must fit its stages at 96x64 and write the final scene, render and
//! evaluation at 200x140.

use psdr::render::{render_cpu, SceneData};
use psdr::vision::{ObservationInputs, Observations};
use psdr_tests::known_geometry::{run_on_known_geometry, truth_room, write_known_geometry};

#[test]
fn resized_observations_match_a_render_at_the_working_size() {
    let dir = psdr_tests::temp_dir("working-size-resample");
    let (mut truth, ids) = truth_room();
    (truth.camera.width, truth.camera.height) = (200, 140);
    truth.settings.spp = 64;
    write_known_geometry(&dir, &truth, &ids);
    let full = Observations::resolve(&ObservationInputs::new(&dir.join("photo.png"))).unwrap();
    let small = full.resized(96).unwrap();
    let (w, h) = (small.photo.width, small.photo.height);
    assert_eq!((w, h), (96, 64));
    // 200x140 is cropped to the working 3:2, 200x133.3: the vertical fov narrows by that ratio of tangents.
    let fov = small.fov_y_deg.unwrap();
    let want = 2.0 * ((truth.camera.fov_y_deg.to_radians() / 2.0).tan() * (200.0 / 1.5) / 140.0).atan().to_degrees();
    assert!((fov - want).abs() < 1e-3, "fov {fov} vs {want}");
    // The same scene rendered directly at the working size and fov.
    let mut direct = truth.clone();
    (direct.camera.width, direct.camera.height, direct.camera.fov_y_deg) = (w as u32, h as u32, fov);
    let f = render_cpu(&SceneData::build(&direct).unwrap(), &direct.settings, &|_, _| {});
    let id_of =
        |o: u32| direct.objects.get(o as usize).and_then(|x| ids.iter().find(|(_, n)| *n == x.name)).map_or(0, |i| i.0);
    let inst = small.instances.as_ref().unwrap();
    let depth = &small.depth.as_ref().unwrap().image.data;
    let mut same = 0;
    let mut depth_err = vec![];
    for (p, (&d, &truth)) in depth.iter().zip(&f.depth).enumerate().take(w * h) {
        if inst.ids[p] == id_of(f.object_id[p]) {
            same += 1;
            depth_err.push((d - truth).abs() / truth);
        }
    }
    // Ids differ only where an outline crosses a working pixel: a few percent of the pixels.
    let agree = same as f32 / (w * h) as f32;
    assert!(agree > 0.95, "ids agree on {:.1} % of the pixels", 100.0 * agree);
    depth_err.sort_by(f32::total_cmp);
    let median = depth_err[depth_err.len() / 2];
    let p95 = depth_err[depth_err.len() * 95 / 100];
    assert!(median < 0.01 && p95 < 0.03, "depth error median {median}, 95th percentile {p95}");
    // Colour: the area average of the photo against the direct render (two noisy renders, 8-bit photo).
    let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
    let (a, b) = (mean(&small.photo.data), mean(&f.radiance));
    assert!((a / b - 1.0).abs() < 0.03, "mean colour {a} vs {b}");
}

#[test]
fn a_photo_of_any_size_is_fitted_at_the_working_size_and_written_at_its_own() {
    let dir = psdr_tests::temp_dir("working-size-pipeline");
    let (mut truth, ids) = truth_room();
    (truth.camera.width, truth.camera.height) = (200, 140);
    truth.settings.spp = 64;
    write_known_geometry(&dir, &truth, &ids);
    let quick = ["working_size=96", "material_iters=4", "albedo_rounds=1", "light_scale_steps=3", "texture_top_k=0"];
    let result = run_on_known_geometry(&dir, &quick);
    let out = dir.join("out");
    assert_eq!(result["recorded"]["observations"]["working_size"], serde_json::json!([96, 64]));
    for stage in ["01_room", "04_materials"] {
        let s = psdr::scene::load_scene(&out.join("stages").join(stage).join("scene.json")).unwrap();
        assert_eq!((s.camera.width, s.camera.height), (96, 64), "{stage} fits at the working size");
    }
    let fitted = psdr::scene::load_scene(&out.join("scene.json")).unwrap();
    assert_eq!((fitted.camera.width, fitted.camera.height), (200, 140));
    assert!((fitted.camera.fov_y_deg - truth.camera.fov_y_deg).abs() < 1e-4, "the photo's own field of view");
    let render = image::open(out.join("render.png")).unwrap();
    assert_eq!((render.width(), render.height()), (200, 140));
    // The evaluation at the photo's size: the fitted scene reproduces the photo (known geometry).
    let rmse = result["recorded"]["evaluation"]["image"]["rmse_rel_1_8"].as_f64().unwrap();
    assert!(rmse < 0.06, "image RMSE at 1/8 size {rmse}");
}
