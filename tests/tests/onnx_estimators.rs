//! The ONNX estimators' contracts, checked with tiny models committed under tests/models (made by
//! tests/models/make_tiny_models.py) through the ONNX Runtime library `.ci/install-deps` installs: input
//! resizing (static and dynamic sizes), ImageNet normalisation, output shapes, the ADE20K class mapping and
//! instance split, and clear errors for missing, malformed and mismatched models. Without ONNX Runtime the
//! tests skip, unless PSDR_REQUIRE_ORT=1 (CI).

use psdr::loss::Image;
use psdr::scene::srgb_to_linear;
use psdr::vision::{
    estimate_depth, estimate_fov_onnx, estimate_instances, DepthUnits, ObservationInputs, Observations, OnnxModel,
};
use psdr_tests::temp_dir;
use std::path::{Path, PathBuf};

fn model_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("models").join(name)
}

/// The model, or None (skip) when ONNX Runtime is not installed and not required.
fn load(name: &str) -> Option<OnnxModel> {
    match OnnxModel::load(&model_path(name)) {
        Ok(m) => Some(m),
        Err(e) if e.to_string().contains("ONNX Runtime not found") => {
            assert!(std::env::var_os("PSDR_REQUIRE_ORT").is_none(), "PSDR_REQUIRE_ORT is set: {e}");
            eprintln!("skipping: {e}");
            None
        }
        Err(e) => panic!("{e}"),
    }
}

/// A linear-RGB photo from per-pixel sRGB-encoded colours.
fn photo(w: usize, h: usize, srgb: impl Fn(usize, usize) -> [f32; 3]) -> Image {
    let data = (0..w * h).flat_map(|p| srgb(p % w, p / w).map(srgb_to_linear)).collect();
    Image::new(w, h, 3, data).unwrap()
}

#[test]
fn fov_model_reads_the_normalised_photo() {
    let Some(mut m) = load("tiny_fov.onnx") else { return };
    // The model returns 40 + 40 * mean(red) of the un-normalised input: red 0.5 -> 60 degrees, whatever the
    // photo's size (it is resized to the model's 16x16).
    for (w, h, red) in [(16, 16, 0.5f32), (73, 41, 0.5), (30, 20, 0.25)] {
        let fov = estimate_fov_onnx(&mut m, &photo(w, h, |_, _| [red, 0.1, 0.9])).unwrap();
        assert!((fov - (40.0 + 40.0 * red)).abs() < 1e-2, "{w}x{h} red {red}: fov {fov}");
    }
}

/// The pinned CLIP image tower's contract (`clip_image.onnx`: CLIP's mean and std, 224x224) with a stand-in of
/// its signature that returns the sRGB image pooled to 3x8x8: a uniform photo comes back as its sRGB colour in
/// every cell, whatever the photo's size, only when psdr normalised by CLIP's numbers; the same file under
/// another name is fed by the generic embedding contract (0..1, nothing subtracted) and comes back otherwise.
#[test]
fn clip_image_tower_gets_clips_normalisation() {
    if load("tiny_fov.onnx").is_none() {
        return;
    }
    let dir = temp_dir("onnx-clip");
    let clip = dir.join(psdr::vision::CLIP_IMAGE_FILE);
    let other = dir.join("my_encoder.onnx");
    std::fs::copy(model_path("tiny_clip_image.onnx"), &clip).unwrap();
    std::fs::copy(model_path("tiny_clip_image.onnx"), &other).unwrap();
    let colour = [0.8f32, 0.3, 0.55];
    let mut want: Vec<f32> = (0..192).map(|i| colour[i / 64]).collect();
    want.resize(512, 0.0);
    let norm = want.iter().map(|v| v * v).sum::<f32>().sqrt();
    let want: Vec<f32> = want.iter().map(|v| v / norm).collect();
    for (w, h) in [(224, 224), (300, 170)] {
        let p = photo(w, h, |_, _| colour);
        let mut m = psdr::vision::load_embedding_model(&clip).unwrap();
        let e = psdr::vision::embed(&mut m, &p).unwrap();
        let err = e.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert_eq!(e.len(), 512);
        assert!(err < 1e-3, "{w}x{h}: embedding off by {err}");
        let mut g = psdr::vision::load_embedding_model(&other).unwrap();
        let e = psdr::vision::embed(&mut g, &p).unwrap();
        let err = e.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(err > 1e-2, "the generic contract fed CLIP's numbers");
    }
}

#[test]
fn depth_model_output_is_resized_to_the_photo_as_disparity() {
    let Some(mut m) = load("tiny_depth.onnx") else { return };
    // Static input 48x32, output 24x16 = the red channel pooled 2x2. A horizontal ramp in red comes back as a
    // horizontal ramp at the photo's size (not transposed, not flipped), min-max mapped to 0.01..1.01.
    let (w, h) = (96, 64);
    let d = estimate_depth(&mut m, &photo(w, h, |x, _| [x as f32 / (w - 1) as f32, 0.0, 0.0])).unwrap();
    assert_eq!((d.image.width, d.image.height, d.units), (w, h, DepthUnits::Disparity));
    let at = |x: usize, y: usize| d.image.data[y * w + x];
    for y in [0, 20, 63] {
        assert!((at(10, y) - at(10, 0)).abs() < 1e-5, "not constant down a column");
        for x in 8..w - 9 {
            assert!(at(x + 1, y) > at(x, y), "not increasing along x at {x}");
        }
    }
    let (lo, hi) = d.image.data.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    assert!((lo - 0.01).abs() < 1e-4 && (hi - 1.01).abs() < 1e-4, "range {lo}..{hi}");
    // Interior slope: the ramp spans the photo, so one pixel is 1/(w - 1) of the range give or take the
    // resampling's blur at the ends.
    let slope = (at(70, 5) - at(26, 5)) / 44.0;
    assert!((slope * (w - 1) as f32 - 1.0).abs() < 0.1, "slope {slope}");
    // A vertical ramp: constant along rows.
    let d = estimate_depth(&mut m, &photo(w, h, |_, y| [y as f32 / (h - 1) as f32, 0.0, 0.0])).unwrap();
    assert!((d.image.data[30 * w + 5] - d.image.data[30 * w + 90]).abs() < 1e-5);
    assert!(d.image.data[50 * w + 5] > d.image.data[10 * w + 5]);
}

#[test]
fn segmentation_model_maps_ade20k_classes_to_instances() {
    let Some(mut m) = load("tiny_segmentation.onnx") else { return };
    // Dynamic input: a 100x70 photo is fed at 98x70 (multiples of 14), the logits come back at 49x35. The
    // model calls red floor (ADE 3), green wall (0), blue ceiling (5) and black "building" (1, not a psdr
    // class: an object). Two black squares become two object instances; the wall is one instance although
    // it is split in two by a red band.
    let (w, h) = (100, 70);
    let p = photo(w, h, |x, y| {
        let black = (10..26).contains(&y) && ((40..56).contains(&x) || (70..86).contains(&x));
        if black {
            [0.0, 0.0, 0.0]
        } else if y >= 50 {
            [1.0, 0.0, 0.0]
        } else if y < 8 {
            [0.0, 0.0, 1.0]
        } else if (30..36).contains(&x) && y < 40 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        }
    });
    let inst = estimate_instances(&mut m, &p).unwrap();
    assert_eq!((inst.width, inst.height), (w, h));
    let classes: Vec<(&str, Option<&str>)> =
        inst.instances.iter().map(|i| (i.class.as_str(), i.label.as_deref())).collect();
    eprintln!("{:?}", inst.instances);
    let count = |c: &str| classes.iter().filter(|(k, _)| *k == c).count();
    assert_eq!((count("wall"), count("ceiling")), (1, 1), "{classes:?}");
    assert_eq!(count("object"), 2, "{classes:?}");
    assert!(classes.contains(&("object", Some("building"))));
    // The floor: the bottom band and the red stripe are two regions of one class, one instance.
    assert_eq!(count("floor"), 1, "{classes:?}");
    let floor = inst.class_mask("floor");
    let px = |x: usize, y: usize| floor[y * w + x] > 0.5;
    assert!(px(50, 60) && px(32, 20) && !px(50, 20) && !px(50, 3));
    // Pixel counts add up and match the mask.
    let total: usize = inst.instances.iter().map(|i| i.pixels).sum();
    assert_eq!(total, inst.ids.iter().filter(|&&i| i != 0).count());
    let sq = inst.instances.iter().find(|i| i.class == "object").unwrap();
    assert!((sq.pixels as i64 - 256).abs() <= 40, "square of 16x16 came out {} px", sq.pixels);
}

#[test]
fn observations_use_the_models_folder_and_report_bad_models() {
    if load("tiny_fov.onnx").is_none() {
        return;
    }
    let dir = temp_dir("onnx-obs");
    let models = dir.join("models");
    std::fs::create_dir_all(&models).unwrap();
    std::fs::copy(model_path("tiny_fov.onnx"), models.join("fov.onnx")).unwrap();
    std::fs::copy(model_path("tiny_segmentation.onnx"), models.join("segmentation.onnx")).unwrap();
    std::fs::copy(model_path("tiny_depth.onnx"), models.join("depth.onnx")).unwrap();
    let img = photo(64, 48, |x, y| if y > 30 { [1.0, 0.0, 0.0] } else { [0.5, (x % 2) as f32, 0.0] });
    let photo_path = dir.join("room.png");
    psdr::output::write_png_srgb(&photo_path, 64, 48, &img.data).unwrap();
    let inputs = ObservationInputs { models: Some(models.clone()), ..ObservationInputs::new(&photo_path) };
    let o = Observations::resolve(&inputs).unwrap();
    for q in ["depth", "instances", "fov"] {
        assert!(o.sources[q].starts_with("model "), "{q}: {}", o.sources[q]);
    }
    assert!(o.instances.as_ref().unwrap().instances.iter().any(|i| i.class == "floor"));
    // A file beside the photo wins over the model.
    std::fs::write(dir.join("room.camera.json"), r#"{"fov_y_deg": 47}"#).unwrap();
    assert_eq!(Observations::resolve(&inputs).unwrap().fov_y_deg, Some(47.0));
    std::fs::remove_file(dir.join("room.camera.json")).unwrap();
    // A model that does not follow its contract, a file that is no model, a folder that does not exist.
    std::fs::copy(model_path("tiny_fov.onnx"), models.join("depth.onnx")).unwrap();
    let e = Observations::resolve(&inputs).unwrap_err().to_string();
    assert!(e.contains("depth.onnx") && e.contains("depth model's output must be"), "{e}");
    std::fs::write(models.join("depth.onnx"), b"not an onnx file").unwrap();
    let e = Observations::resolve(&inputs).unwrap_err().to_string();
    assert!(e.contains("depth.onnx") && e.contains("not a loadable ONNX model"), "{e}");
    let e = Observations::resolve(&ObservationInputs { models: Some(dir.join("nope")), ..inputs.clone() })
        .unwrap_err()
        .to_string();
    assert!(e.contains("nope") && e.contains("models folder"), "{e}");
}
