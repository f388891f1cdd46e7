//! Photo observations: a room rendered by psdr (photo, depth AOV, instance ids from the id AOV, labels from
//! object names, the camera's fov) resolves back to exactly what was rendered; `write` (psdr observe) round
//! trips; EXIF orientation is applied; bad input is a clear error.

use psdr::render::{render_cpu, Frame, SceneData};
use psdr::scene::load_scene;
use psdr::vision::{DepthUnits, ObservationInputs, Observations};
use psdr_tests::temp_dir;
use std::path::{Path, PathBuf};

/// Renders the fit example's truth at 48x36 and writes its observation files beside `room.png` in `dir`.
fn rendered_room(dir: &Path) -> (PathBuf, Frame) {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/fit/truth.json"));
    let mut s = load_scene(path).unwrap();
    (s.camera.width, s.camera.height, s.settings.spp) = (48, 36, 16);
    let f = render_cpu(&SceneData::build(&s).unwrap(), &s.settings, &|_, _| {});
    let photo = dir.join("room.png");
    psdr::output::write_png_srgb(&photo, 48, 36, &f.radiance).unwrap();
    psdr::output::write_exr_channels(&dir.join("room.depth.exr"), 48, 36, &[("Z".into(), f.depth.clone())]).unwrap();
    let ids: Vec<u16> = f.object_id.iter().map(|&o| if o == u32::MAX { 0 } else { o as u16 + 1 }).collect();
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(48, 36, ids).unwrap().save(dir.join("room.masks.png")).unwrap();
    let labels: serde_json::Map<String, serde_json::Value> = s
        .objects
        .iter()
        .enumerate()
        .filter(|(o, _)| f.object_id.contains(&(*o as u32)))
        .map(|(o, obj)| {
            (
                (o + 1).to_string(),
                serde_json::Value::from(obj.name.replace("back_", "").replace("left_", "").replace("right_", "")),
            )
        })
        .collect();
    std::fs::write(dir.join("room.labels.json"), serde_json::to_string(&labels).unwrap()).unwrap();
    std::fs::write(dir.join("room.camera.json"), format!("{{\"fov_y_deg\": {}}}", s.camera.fov_y_deg)).unwrap();
    (photo, f)
}

#[test]
fn rendered_observations_resolve_to_what_was_rendered_and_round_trip() {
    let dir = temp_dir("obs-room");
    let (photo, f) = rendered_room(&dir);
    let obs = Observations::resolve(&ObservationInputs::new(&photo)).unwrap();
    let d = obs.require_depth().unwrap();
    assert_eq!(d.image.data, f.depth, "depth read back exactly (EXR f32)");
    assert_eq!(d.units, DepthUnits::Metres);
    let m = obs.require_instances().unwrap();
    let classes: Vec<&str> = m.instances.iter().map(|i| i.class.as_str()).collect();
    for c in ["floor", "wall", "cabinet"] {
        assert!(classes.contains(&c), "{c} in {classes:?}");
    }
    let cab = m.instances.iter().find(|i| i.class == "cabinet").unwrap();
    let n = f.object_id.iter().filter(|&&o| o as usize == (cab.id - 1) as usize).count();
    assert_eq!(cab.pixels, n);
    assert_eq!(obs.require_fov().unwrap(), 55.0);
    // psdr observe's output folder reads back to the same observations.
    let out = dir.join("observed");
    let written = obs.write(&out).unwrap();
    assert!(written.iter().any(|p| p.ends_with("room.overlay.png")) && out.join("observations.json").is_file());
    let again = Observations::resolve(&ObservationInputs::new(&out.join("room.png"))).unwrap();
    assert_eq!(again.depth.unwrap().image.data, f.depth);
    assert_eq!(again.instances.as_ref().unwrap().ids, m.ids);
    assert_eq!(again.instances.unwrap().instances.iter().map(|i| i.class.clone()).collect::<Vec<_>>(), classes);
    assert_eq!(again.fov_y_deg, Some(55.0));
}

/// A JPEG whose EXIF says "rotate 90° clockwise" (orientation 6) loads rotated: a 4x2 image becomes 2x4, and
/// its top-left pixel is the stored bottom-left one.
#[test]
fn exif_orientation_is_applied() {
    let dir = temp_dir("obs-exif");
    let mut img = image::RgbImage::new(4, 2);
    img.put_pixel(0, 1, image::Rgb([255, 0, 0]));
    let mut jpeg = vec![];
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 100).encode_image(&img).unwrap();
    // APP1 Exif segment: little-endian TIFF, one IFD entry: Orientation (0x0112), SHORT, 1, value 6.
    let mut tiff = b"II*\0\x08\0\0\0\x01\0\x12\x01\x03\0\x01\0\0\0\x06\0\0\0\0\0\0\0".to_vec();
    let mut app1 = b"Exif\0\0".to_vec();
    app1.append(&mut tiff);
    let len = (app1.len() + 2) as u16;
    let mut file = vec![0xFF, 0xD8, 0xFF, 0xE1];
    file.extend_from_slice(&len.to_be_bytes());
    file.extend_from_slice(&app1);
    file.extend_from_slice(&jpeg[2..]);
    let path = dir.join("portrait.jpg");
    std::fs::write(&path, file).unwrap();
    let p = psdr::vision::load_photo(&path).unwrap();
    assert_eq!((p.width, p.height), (2, 4), "rotated by the EXIF orientation");
    assert!(p.data[0] > 0.5 && p.data[1] < 0.2, "top-left is the stored bottom-left (red): {:?}", &p.data[..3]);
}

/// A depth map given in the wrong units runs backwards on the floor (distance must rise towards the horizon):
/// the rendered distances given as disparity, and their disparity given as metres, stop with the flag that fits;
/// given rightly, the trend is recorded with the depth's source.
#[test]
fn depth_in_the_wrong_units_is_caught_on_the_floor() {
    let dir = temp_dir("obs-depth-direction");
    let (photo, f) = rendered_room(&dir);
    let floor = {
        let o = Observations::resolve(&ObservationInputs::new(&photo)).unwrap();
        o.instances.unwrap().instances.iter().find(|i| i.class == "floor").unwrap().pixels
    };
    assert!(floor >= 200, "the check needs 200 floor pixels; the room shows {floor}");
    let depth = dir.join("room.depth.exr");
    let e = Observations::resolve(&ObservationInputs {
        depth: Some(depth.clone()),
        depth_units: DepthUnits::Disparity,
        ..ObservationInputs::new(&photo)
    })
    .map(|_| ())
    .unwrap_err()
    .to_string();
    assert!(e.contains("runs backwards for disparity") && e.contains("--depth-units metres"), "{e}");
    let disparity: Vec<f32> = f.depth.iter().map(|&z| if z > 0.0 { 2.0 / z + 0.4 } else { 0.0 }).collect();
    let inverse = dir.join("inverse.exr");
    psdr::output::write_exr_channels(&inverse, 48, 36, &[("Z".into(), disparity)]).unwrap();
    let given = |units| ObservationInputs {
        depth: Some(inverse.clone()),
        depth_units: units,
        ..ObservationInputs::new(&photo)
    };
    let e = Observations::resolve(&given(DepthUnits::Metres)).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("runs backwards for metres") && e.contains("--depth-units disparity"), "{e}");
    let o = Observations::resolve(&given(DepthUnits::Disparity)).unwrap();
    assert!(o.sources["depth"].contains("rises towards the horizon"), "{:?}", o.sources);
}

#[test]
fn bad_observations_are_clear_errors() {
    let dir = temp_dir("obs-bad");
    let (photo, _) = rendered_room(&dir);
    let resolve = |i: &ObservationInputs| Observations::resolve(i).map(|_| ()).unwrap_err().to_string();
    // Masks of another size.
    let small = dir.join("small.png");
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(8, 8, vec![1u16; 64]).unwrap().save(&small).unwrap();
    let e = resolve(&ObservationInputs { masks: Some(small.clone()), ..ObservationInputs::new(&photo) });
    assert!(e.contains("8x8") && e.contains("48x36"), "{e}");
    // Labels naming only ids the mask does not hold (another photo's labels) are an error...
    let labels = dir.join("bad_labels.json");
    std::fs::write(&labels, r#"{"998": "chair", "999": "sofa"}"#).unwrap();
    let e = resolve(&ObservationInputs { labels: Some(labels.clone()), ..ObservationInputs::new(&photo) });
    assert!(e.contains("999") && e.contains("none of which"), "{e}");
    // ...while a few stale ids beside matching ones are a warning that names them, and are left out.
    std::fs::write(&labels, r#"{"1": "floor", "999": "sofa"}"#).unwrap();
    let o =
        Observations::resolve(&ObservationInputs { labels: Some(labels.clone()), ..ObservationInputs::new(&photo) })
            .unwrap();
    assert!(o.warnings.iter().any(|w| w.contains("999") && w.contains("left out")), "{:?}", o.warnings);
    assert!(o.instances.as_ref().unwrap().instances.iter().all(|i| i.id != 999 && i.label.as_deref() != Some("sofa")));
    // Segmenters' spellings are classes (COCO-panoptic "floor-wood"); a name psdr does not know is a warning.
    std::fs::write(&labels, r#"{"1": "floor-wood", "2": "spaceship"}"#).unwrap();
    let o =
        Observations::resolve(&ObservationInputs { labels: Some(labels), ..ObservationInputs::new(&photo) }).unwrap();
    let by_id = |id: u16| o.instances.as_ref().unwrap().instances.iter().find(|i| i.id == id).unwrap().class.clone();
    assert_eq!((by_id(1).as_str(), by_id(2).as_str()), ("floor", "object"));
    assert!(o.warnings.iter().any(|w| w.contains("'spaceship' (id 2)") && w.contains("object")), "{:?}", o.warnings);
    // An all-zero mask.
    let zero = dir.join("zero.png");
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(48, 36, vec![0u16; 48 * 36]).unwrap().save(&zero).unwrap();
    let e = resolve(&ObservationInputs {
        masks: Some(zero),
        labels: Some(dir.join("none.json")),
        ..ObservationInputs::new(&photo)
    });
    assert!(e.contains("no instance"), "{e}");
    // NaN depth is an error; zeros are missing measurements (repaired: counted and left 0).
    let mut d = vec![2.0f32; 48 * 36];
    d[5] = f32::NAN;
    let nan = dir.join("nan.exr");
    psdr::output::write_exr_channels(&nan, 48, 36, &[("Z".into(), d.clone())]).unwrap();
    let e = resolve(&ObservationInputs { depth: Some(nan), ..ObservationInputs::new(&photo) });
    assert!(e.contains("NaN") && e.contains("pixel 5, 0"), "{e}");
    d[5] = 0.0;
    d[6] = -1.0;
    let holes = dir.join("holes.exr");
    psdr::output::write_exr_channels(&holes, 48, 36, &[("Z".into(), d)]).unwrap();
    let o = Observations::resolve(&ObservationInputs { depth: Some(holes), ..ObservationInputs::new(&photo) }).unwrap();
    assert_eq!(o.depth.unwrap().missing, 2);
    // A bad --fov, and quantities with no source list how to supply them.
    let e = resolve(&ObservationInputs { fov_y_deg: Some(400.0), ..ObservationInputs::new(&photo) });
    assert!(e.contains("--fov"), "{e}");
    let bare = dir.join("bare.png");
    std::fs::copy(&photo, &bare).unwrap();
    let o = Observations::resolve(&ObservationInputs::new(&bare)).unwrap();
    for (e, want) in [
        (o.require_depth().unwrap_err().to_string(), "bare.depth.exr"),
        (o.require_instances().unwrap_err().to_string(), "bare.masks.png"),
    ] {
        assert!(e.contains(want), "{e}");
    }
    // The fov has a last resort, a default, and that is said: this 48x36 render has too few lines for the
    // vanishing points.
    assert_eq!(o.fov_y_deg, Some(psdr::vision::DEFAULT_FOV_Y_DEG));
    assert!(o.warnings.iter().any(|w| w.contains("default") && w.contains("--fov")), "{:?}", o.warnings);
    assert!(o.sources["fov"].starts_with("default"), "{:?}", o.sources);
    // Relative depth without a segmentation cannot be made metric: said when the depth is asked for.
    let rel = dir.join("rel.exr");
    psdr::output::write_exr_channels(&rel, 48, 36, &[("Z".into(), vec![0.5; 48 * 36])]).unwrap();
    let o = Observations::resolve(&ObservationInputs {
        depth: Some(rel),
        depth_units: DepthUnits::Disparity,
        ..ObservationInputs::new(&bare)
    })
    .unwrap();
    let e = o.require_depth().unwrap_err().to_string();
    assert!(e.contains("Disparity") && e.contains("segmentation"), "{e}");
    let e = resolve(&ObservationInputs::new(&dir.join("missing.jpg")));
    assert!(e.contains("missing.jpg") && e.contains("not found"), "{e}");
}
