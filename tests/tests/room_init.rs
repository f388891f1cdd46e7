//! The room stage's initialisation on rooms rendered by psdr: from the rendered depth, the class masks (from
//! the id AOV) and the fov. Rooms 3-7 m wide and deep, 2.4-3.2 m high, camera 20 cm from the wall behind it (a
//! photographer's position; the unseen wall is placed 5 cm behind the camera, and the test takes that
//! assumption's 15 cm out of the comparison), pitch -20..5 degrees, yaw -25..25, fov
//! 45-75, a furniture box covering part of the floor. Where the estimator saw the three walls and the ceiling, the
//! box's width, depth and height come out within 3 %; always: the camera height within 5 cm and the pitch
//! within 1 degree, the estimator says which walls it saw (only walls the render shows, every wall shown on over 3 % of
//! the image), and the box holds
//! every point it saw. A wall or ceiling outside the photo cannot be measured: the box then ends at the
//! farthest point seen that way (or 1.2x the highest point for the ceiling), stated, not guessed as exact.

use glam::Vec3;
use psdr::base::Intrinsics;
use psdr::render::{render_cpu, Frame, SceneData};
use psdr::scene::Scene;
use psdr::stages::{init_room, RoomEstimate, RoomInitOptions};
use psdr::vision::calibrate_relative_depth;
use psdr::vision::DepthUnits;
use psdr_tests::rooms::{furniture, room_scene, FurnitureBox, RoomSpec};
use psdr_tests::SplitMix64;

type Room = RoomSpec;

/// The room with one 1 x 0.8 x 0.9 m box in front of the camera, or the given furniture.
fn scene_with(r: &Room, boxes: Option<Vec<FurnitureBox>>, w: u32, h: u32) -> (Scene, Vec<String>) {
    let boxes = boxes.unwrap_or_else(|| {
        vec![FurnitureBox { x: 0.1 * r.w, z: r.cam.z - 2.2, size: Vec3::new(1.0, 0.8, 0.9), yaw: 0.0 }]
    });
    let (mut s, classes) = room_scene(r, &boxes, false, w, h);
    s.settings.max_depth = 1;
    (s, classes)
}

fn scene(r: &Room, w: u32, h: u32) -> (Scene, Vec<String>) {
    scene_with(r, None, w, h)
}

/// Per-class masks from the id AOV.
fn class_mask(f: &Frame, classes: &[String], c: &str) -> Vec<bool> {
    f.object_id.iter().map(|&o| o != u32::MAX && classes[o as usize] == c).collect()
}

/// The camera's distance from the wall behind it in the test rooms.
const BEHIND: f32 = 0.2;

/// Relative errors of (side-to-side extent, front-to-back extent, height) where the estimate saw three walls
/// and the ceiling, in units where the truth's metres are multiplied by `scale`. The box's axes may come out
/// rotated by a multiple of 90°: the axis spanned by the two seen side walls is the truth's w; along the other
/// (d) the wall behind the camera is assumed 0.05 units behind it while the truth puts it BEHIND metres back:
/// that part is the assumption's error, not a measurement, and is taken out.
fn full_view_errors(e: &RoomEstimate, r: &Room, scale: f32) -> Option<[f32; 3]> {
    if e.walls_seen.iter().filter(|&&b| b).count() < 3 || !e.ceiling_seen {
        return None;
    }
    let x_measured = e.walls_seen[0] && e.walls_seen[1];
    let (measured, assumed) = if x_measured { (e.width, e.depth) } else { (e.depth, e.width) };
    let assumed = assumed + BEHIND * scale - 0.05;
    let (w, d, h) = (r.w * scale, r.d * scale, r.h * scale);
    Some([(measured - w).abs() / w, (assumed - d).abs() / d, (e.height - h).abs() / h])
}

#[test]
fn room_box_and_camera_height_from_rendered_depth_and_masks() {
    let mut rng = 7u64;
    let mut u = || {
        rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (rng >> 40) as f32 / (1u64 << 24) as f32
    };
    let (iw, ih) = (128u32, 96u32);
    let mut worst = [0.0f32; 4];
    let (mut full_views, mut cases) = (0, 0);
    let (mut relative_views, mut worst_ratio) = (0, 0.0f32);
    while cases < 40 {
        let (w, d, h) = (3.0 + 4.0 * u(), 3.0 + 4.0 * u(), 2.4 + 0.8 * u());
        let r = Room {
            w,
            d,
            h,
            cam: Vec3::new((u() - 0.5) * 0.4 * w, 1.2 + 0.6 * u(), d / 2.0 - BEHIND),
            yaw: (u() - 0.5) * 50.0,
            pitch: -20.0 + 25.0 * u(),
            fov: 45.0 + 30.0 * u(),
        };
        cases += 1;
        // Furniture over up to 40 % of the floor.
        let boxes = furniture(&r, 0.4 * u(), &mut SplitMix64(cases));
        let (s, classes) = scene_with(&r, Some(boxes), iw, ih);
        let f = render_cpu(&SceneData::build(&s).unwrap(), &s.settings, &|_, _| {});
        let mask = |c: &str| class_mask(&f, &classes, c);
        // What the render shows: pixels of each wall object and of the ceiling.
        let pixels = |o: usize| f.object_id.iter().filter(|&&x| x == o as u32).count();
        let shown = |o: usize| pixels(o) >= 60;
        let clearly = |o: usize| pixels(o) >= 400; // 3 % of the image
        let walls_shown = [4, 5, 2].iter().filter(|&&o| shown(o)).count(); // left, right, back
        let walls_clear = [4, 5, 2].iter().filter(|&&o| clearly(o)).count();
        let k = Intrinsics::new(iw as usize, ih as usize, r.fov);
        let e =
            match init_room(&f.depth, &mask("floor"), &mask("wall"), &mask("ceiling"), &k, &RoomInitOptions::default())
            {
                Ok(e) => e,
                Err(err) => {
                    // Without the floor in view there is no plane to stand the room on: a clear error, not a guess.
                    assert!(pixels(0) < 200 && err.to_string().contains("floor"), "{err} ({} floor pixels)", pixels(0));
                    continue;
                }
            };
        eprintln!(
            "{w:.2}x{d:.2}x{h:.2} cam {:.2} pitch {:.0} yaw {:.0} fov {:.0} -> {:.2}x{:.2}x{:.2} cam {:.3} pitch {:.1} \
             seen {:?} (render shows {walls_shown} walls, ceiling {}) ceiling {}",
            r.cam.y, r.pitch, r.yaw, r.fov, e.width, e.depth, e.height, e.camera_height, e.pitch_deg, e.walls_seen,
            shown(1), e.ceiling_seen
        );
        assert!((e.camera_height - r.cam.y).abs() < 0.05, "camera height {} vs {}", e.camera_height, r.cam.y);
        assert!((e.pitch_deg - r.pitch).abs() < 1.0, "pitch {} vs {}", e.pitch_deg, r.pitch);
        assert!(e.roll_deg.abs() < 1.0, "roll {} (the camera has none)", e.roll_deg);
        assert!([e.width, e.depth, e.height].iter().all(|v| v.is_finite() && *v > 0.0));
        // It claims to have seen only what the photo shows, and sees what the photo shows clearly.
        let seen = e.walls_seen.iter().filter(|&&b| b).count();
        assert!(
            seen <= walls_shown && seen >= walls_clear,
            "walls seen {seen}, shown {walls_shown}, clearly {walls_clear}"
        );
        assert!(!e.ceiling_seen || shown(1), "a ceiling the photo does not show");
        assert!(e.ceiling_seen || !clearly(1), "a clearly shown ceiling not seen");
        if let Some(errs) = full_view_errors(&e, &r, 1.0) {
            full_views += 1;
            for (k, v) in errs.iter().enumerate() {
                worst[k] = worst[k].max(*v);
            }
        }
        // The same view with relative depth (affine in depth, or in inverse depth, unknown scale and shift):
        // the shift from the room's planes, the scale from the 1.5 m camera-height prior; the box's
        // proportions are what is measured.
        let (units, rel): (DepthUnits, Vec<f32>) = if cases % 2 == 0 {
            (DepthUnits::Relative, f.depth.iter().map(|&z| if z > 0.0 { 3.7 * z + 1.3 } else { 0.0 }).collect())
        } else {
            (DepthUnits::Disparity, f.depth.iter().map(|&z| if z > 0.0 { 2.0 / z + 0.4 } else { 0.0 }).collect())
        };
        let masks = [&mask("floor")[..], &mask("wall")[..], &mask("ceiling")[..]];
        let (metres, cal) = calibrate_relative_depth(&rel, units, masks, &k, 1.5, 1).unwrap();
        let er = init_room(&metres, masks[0], masks[1], masks[2], &k, &RoomInitOptions::default()).unwrap();
        let scale = 1.5 / r.cam.y;
        assert!((er.camera_height - 1.5).abs() < 0.02, "{units:?}: camera height {} (prior 1.5)", er.camera_height);
        if let Some(errs) = full_view_errors(&er, &r, scale) {
            // Ratios W/H and D/H: their relative error is at most the sum of the two sizes' errors.
            let ratios = [errs[0] + errs[2], errs[1] + errs[2]];
            eprintln!(
                "  {units:?} (shift {:.3}, residual {:.4}): ratio errors {ratios:?}",
                cal.shift, cal.manhattan_residual
            );
            relative_views += 1;
            worst_ratio = worst_ratio.max(ratios[0]).max(ratios[1]);
        }
        worst[3] = worst[3].max((e.camera_height - r.cam.y).abs());
    }
    eprintln!(
        "{full_views} of {cases} views showed all three walls and the ceiling to the estimator; worst there: width \
         {:.2} %, depth {:.2} % (less the assumed wall), height {:.2} %; camera height everywhere {:.2} cm",
        worst[0] * 100.0,
        worst[1] * 100.0,
        worst[2] * 100.0,
        worst[3] * 100.0
    );
    eprintln!("relative depth: {relative_views} full views, ratios W/H and D/H within {:.2} %", worst_ratio * 100.0);
    assert!(full_views >= 6, "too few full views to test the sizes ({full_views})");
    assert!(worst[0] < 0.03 && worst[1] < 0.03 && worst[2] < 0.03, "size errors {worst:?}");
    assert!(relative_views >= 6, "too few full views with relative depth ({relative_views})");
    assert!(worst_ratio < 0.05, "ratio errors with relative depth up to {:.2} %", worst_ratio * 100.0);
}

/// `scripts/room.rhai` end to end on a rendered room whose three walls and ceiling are in view: observation
/// files beside the photo, `psdr run`'s machinery; the box within 3 % and the soft-IoU loss no worse than at
/// the initialisation.
#[test]
fn room_script_fits_the_box_of_a_rendered_room() {
    use psdr::backend::CpuBackend;
    use psdr::script::{run_script, RunOptions, ScriptRun};
    let r =
        Room { w: 4.2, d: 5.1, h: 2.7, cam: Vec3::new(0.3, 1.5, 5.1 / 2.0 - 0.05), yaw: 5.0, pitch: -8.0, fov: 70.0 };
    let (iw, ih) = (96u32, 72u32);
    let (s, classes) = scene(&r, iw, ih);
    let mut settings = s.settings.clone();
    settings.spp = 16;
    let f = render_cpu(&SceneData::build(&s).unwrap(), &settings, &|_, _| {});
    let dir = psdr_tests::temp_dir("room-script");
    let photo = dir.join("room.png");
    psdr::output::write_png_srgb(&photo, iw, ih, &f.radiance).unwrap();
    psdr::output::write_exr_channels(&dir.join("room.depth.exr"), iw, ih, &[("Z".into(), f.depth.clone())]).unwrap();
    let ids: Vec<u16> = f.object_id.iter().map(|&o| if o == u32::MAX { 0 } else { o as u16 + 1 }).collect();
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(iw, ih, ids).unwrap().save(dir.join("room.masks.png")).unwrap();
    let labels: serde_json::Map<String, serde_json::Value> = classes
        .iter()
        .enumerate()
        .map(|(o, c)| ((o + 1).to_string(), serde_json::Value::from(c.as_str())))
        .filter(|(k, _)| f.object_id.contains(&(k.parse::<u32>().unwrap() - 1)))
        .collect();
    std::fs::write(dir.join("room.labels.json"), serde_json::to_string(&labels).unwrap()).unwrap();
    std::fs::write(dir.join("room.camera.json"), format!("{{\"fov_y_deg\": {}}}", r.fov)).unwrap();
    let out = dir.join("out");
    run_script(
        ScriptRun {
            script: std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/room.rhai"),
            photo,
            out: out.clone(),
            sets: vec!["room_iters=20".into(), "object_iters=10".into()],
            options: RunOptions { quiet: true, preview_spp: 2, ..Default::default() },
            command: "test".into(),
        },
        Box::new(CpuBackend),
    )
    .unwrap();
    let res: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    let room = &res["recorded"]["room"];
    let init = &res["recorded"]["room_init"];
    eprintln!("init {init}\nfitted {room}");
    let (mut got, mut want) =
        ([room["width"].as_f64().unwrap(), room["depth"].as_f64().unwrap()], [r.w as f64, r.d as f64]);
    got.sort_by(f64::total_cmp);
    want.sort_by(f64::total_cmp);
    for k in 0..2 {
        assert!((got[k] - want[k]).abs() / want[k] < 0.03, "footprint {got:?} vs {want:?}");
    }
    assert!((room["height"].as_f64().unwrap() - r.h as f64).abs() / (r.h as f64) < 0.03, "{room}");
    let opt = &res["stages"][0]["optimizations"][0];
    assert!(opt["final_loss"].as_f64().unwrap() <= opt["first_loss"].as_f64().unwrap() + 1e-3, "{opt}");
    assert!(out.join("scene.json").is_file() && out.join("render.png").is_file() && out.join("scene.glb").is_file());
    // result.json's room: the fitted box, its planes and the camera relative to it.
    let rr = &res["room"];
    assert!((rr["camera"]["height_above_floor"].as_f64().unwrap() - r.cam.y as f64).abs() < 0.05, "{rr}");
    assert!((rr["camera"]["pitch_deg"].as_f64().unwrap() - r.pitch as f64).abs() < 1.0, "{rr}");
    assert_eq!(rr["camera"]["fov_y_deg"].as_f64().unwrap() as f32, r.fov);
    assert_eq!(rr["planes"].as_object().unwrap().len(), 6);
    // Not mirrored: the walls on the camera's left and right (it stands 0.3 m right of the middle, turned 5
    // degrees) and ahead are where the truth has them.
    let stage_scene = psdr::scene::load_scene(&out.join("stages/01_room/scene.json")).unwrap();
    let (fitted, truth) = (psdr::stages::room_in_camera_frame(&stage_scene), psdr::stages::room_in_camera_frame(&s));
    eprintln!("in the camera's frame: fitted {fitted}\ntruth {truth}");
    for k in ["left", "right", "ahead"] {
        let (a, b) = (fitted[k].as_f64().unwrap(), truth[k].as_f64().unwrap());
        assert!((a - b).abs() / b < 0.03, "{k}: {a} vs {b}");
    }
    // The stage's scene renders and exports to Mitsuba.
    let frame = render_cpu(&SceneData::build(&stage_scene).unwrap(), &stage_scene.settings, &|_, _| {});
    assert!(frame.radiance.iter().all(|v| v.is_finite()) && frame.radiance.iter().any(|v| *v > 0.0));
    let xml = psdr::export::mitsuba::export_mitsuba(&stage_scene, &dir.join("mitsuba")).unwrap();
    assert!(std::fs::read_to_string(xml).unwrap().contains("<scene"));

    // The same photo with relative depth (disparity: 2/z + 0.4, unknown to psdr) given by flag: the box's
    // proportions come out within 5 %, its scale from the camera-height prior, and result.json says so.
    let rel: Vec<f32> = f.depth.iter().map(|&z| if z > 0.0 { 2.0 / z + 0.4 } else { 0.0 }).collect();
    let rel_path = dir.join("relative.exr");
    psdr::output::write_exr_channels(&rel_path, iw, ih, &[("Z".into(), rel)]).unwrap();
    let photo = dir.join("room.png");
    let out = dir.join("out-relative");
    run_script(
        ScriptRun {
            script: std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/room.rhai"),
            photo: photo.clone(),
            out: out.clone(),
            sets: vec!["room_iters=10".into(), "object_iters=0".into()],
            options: RunOptions {
                quiet: true,
                preview_spp: 2,
                observations: Some(psdr::vision::ObservationInputs {
                    depth: Some(rel_path),
                    depth_units: DepthUnits::Disparity,
                    ..psdr::vision::ObservationInputs::new(&photo)
                }),
                ..Default::default()
            },
            command: "test".into(),
        },
        Box::new(CpuBackend),
    )
    .unwrap();
    let res: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    let (rr, obs) = (&res["room"], &res["recorded"]["observations"]);
    eprintln!("relative: {rr}\n{obs}");
    assert!(obs["depth_calibration"]["camera_height_prior"].as_f64() == Some(1.5), "{obs}");
    assert!(obs["warnings"].as_array().unwrap().iter().any(|w| w.as_str().unwrap().contains("camera height")));
    let (h, mut got) = (rr["height"].as_f64().unwrap(), [rr["width"].as_f64().unwrap(), rr["depth"].as_f64().unwrap()]);
    got.sort_by(f64::total_cmp);
    for k in 0..2 {
        let ratio = got[k] / h / (want[k] / r.h as f64);
        assert!((ratio - 1.0).abs() < 0.05, "ratio {k}: {ratio} ({got:?} / {h} vs {want:?} / {})", r.h);
    }
    assert!((rr["camera"]["height_above_floor"].as_f64().unwrap() - 1.5).abs() < 0.05, "{rr}");
}

/// Stability where the inputs are poor: depth with 5 % multiplicative noise per pixel and a smooth 3 % bias
/// across the image, masks with 15 % of their pixels dropped at random and a ragged border, and views that show
/// no ceiling or a single wall. Stated behaviour: always a finite box that holds the camera, the camera height
/// within 5 % (measured: 2.3 % at worst over these 24 views; the floor is fitted in inverse depth, where such
/// noise does not tilt it) and the pitch within 1.5 degrees. Per-pixel noise of 5 % destroys the wall normals,
/// so walls are found as lines in the wall points' footprint on the floor instead; a wall no line covers
/// counts as unseen and the box ends just beyond the points seen that way. Where three walls and the ceiling
/// were placed, sizes within 15 % (measured: one such view of 24, 11 % off across the room).
#[test]
fn room_init_degrades_gracefully_on_noisy_depth_and_ragged_masks() {
    let mut rng = 99u64;
    let mut u = || {
        rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (rng >> 40) as f32 / (1u64 << 24) as f32
    };
    let (iw, ih) = (128u32, 96u32);
    let (mut tested, mut full, mut worst_h, mut worst_size) = (0, 0, 0.0f32, 0.0f32);
    for case in 0..24 {
        let (w, d, h) = (3.0 + 4.0 * u(), 3.0 + 4.0 * u(), 2.4 + 0.8 * u());
        // Every third view looks down and sideways: no ceiling, often a single wall.
        let (pitch, yaw) =
            if case % 3 == 0 { (-25.0, 40.0 * (u() - 0.5)) } else { (-20.0 + 25.0 * u(), (u() - 0.5) * 50.0) };
        let r = Room {
            w,
            d,
            h,
            cam: Vec3::new(0.0, 1.2 + 0.6 * u(), d / 2.0 - BEHIND),
            yaw,
            pitch,
            fov: 45.0 + 30.0 * u(),
        };
        let (s, classes) = scene(&r, iw, ih);
        let f = render_cpu(&SceneData::build(&s).unwrap(), &s.settings, &|_, _| {});
        let n = (iw * ih) as usize;
        let depth: Vec<f32> = (0..n)
            .map(|p| {
                let x = (p % iw as usize) as f32 / iw as f32;
                // Box-Muller normal noise and a left-to-right bias.
                let (a, b) = (u().max(1e-6), u());
                let g = (-2.0 * a.ln()).sqrt() * (std::f32::consts::TAU * b).cos();
                f.depth[p] * (1.0 + 0.05 * g) * (1.0 + 0.03 * (x - 0.5))
            })
            .collect();
        let mut mask = |c: &str| -> Vec<bool> {
            let m: Vec<bool> = f.object_id.iter().map(|&o| o != u32::MAX && classes[o as usize] == c).collect();
            // Holes, and a ragged border: pixels next to another class dropped at random.
            (0..n)
                .map(|p| {
                    let (x, y) = (p % iw as usize, p / iw as usize);
                    let border = [(1i32, 0i32), (-1, 0), (0, 1), (0, -1)].iter().any(|(dx, dy)| {
                        let (xx, yy) = (x as i32 + dx, y as i32 + dy);
                        xx >= 0
                            && yy >= 0
                            && (xx as u32) < iw
                            && (yy as u32) < ih
                            && !m[yy as usize * iw as usize + xx as usize]
                    });
                    m[p] && u() > 0.15 && !(border && u() < 0.5)
                })
                .collect()
        };
        let (fl, wa, ce) = (mask("floor"), mask("wall"), mask("ceiling"));
        let k = Intrinsics::new(iw as usize, ih as usize, r.fov);
        let Ok(e) = init_room(&depth, &fl, &wa, &ce, &k, &RoomInitOptions::default()) else {
            // Only a view without enough floor may fail, and then with a message.
            assert!(f.object_id.iter().filter(|&&o| o == 0).count() < 400, "a clearly visible floor was not fitted");
            continue;
        };
        tested += 1;
        assert!([e.width, e.depth, e.height, e.camera_height].iter().all(|v| v.is_finite() && *v > 0.0), "{e:?}");
        assert!(
            e.x_min <= 0.0 && e.x_min + e.width >= 0.0 && e.z_min <= 0.0 && e.z_min + e.depth >= 0.0,
            "camera outside"
        );
        worst_h = worst_h.max((e.camera_height / r.cam.y - 1.0).abs());
        assert!((e.pitch_deg - r.pitch).abs() < 1.5, "case {case}: pitch {} vs {}", e.pitch_deg, r.pitch);
        if e.walls_seen.iter().filter(|&&b| b).count() == 3 && e.ceiling_seen {
            full += 1;
            let x_measured = e.walls_seen[0] && e.walls_seen[1];
            let (measured, assumed) = if x_measured { (e.width, e.depth) } else { (e.depth, e.width) };
            let assumed = assumed + (BEHIND - 0.05);
            let errs = [(measured - w).abs() / w, (assumed - d).abs() / d, (e.height - h).abs() / h];
            eprintln!("case {case}: full view, relative errors {errs:?}");
            worst_size = worst_size.max(errs[0]).max(errs[1]).max(errs[2]);
        }
    }
    eprintln!(
        "worst camera height error {:.1} %; {full} views with three walls and the ceiling placed, sizes within {:.1} %",
        worst_h * 100.0,
        worst_size * 100.0
    );
    assert!(worst_h < 0.05, "camera height off by {:.1} %", worst_h * 100.0);
    assert!(tested >= 16, "tested {tested}");
    assert!(worst_size < 0.15, "sizes off by {:.1} %", worst_size * 100.0);
}

/// Depth as a monocular network gives it: monotone in distance but not affine in depth or inverse depth (here
/// disparity through a power of 0.6, the compression of the far range such networks show, times a smooth 4 %
/// bias across the image). The affine calibration then bends and tilts the room; the layout from the photo's
/// lines, the segmentation's floor-wall and wall-ceiling contacts and the camera-height prior does not read
/// the depth's values. Over 10 textured rendered rooms at 256x192 (lines to find, furniture on the floor, fov
/// known): the layout beats the affine box on mask IoU in at least 7 (measured: all 10), and there its pitch is
/// within 1 degree (measured: 0.80 at worst, the affine box's 6.4), the median depth error of its surfaces
/// where it measured them at most 5 % (measured 4.0 %, a view whose lines left 0.8 degrees of pitch), the
/// depth mapped onto it keeps its order (rank correlation above 0.95) and its median error over all pixels,
/// furniture included, is at most 6 % and on average below the affine calibration's (measured: 4.8 % at worst,
/// the affine 13.3 %).
#[test]
fn room_from_depth_that_is_not_affine_in_distance() {
    use psdr::stages::{box_view, BoxSurface};
    use psdr::vision::check_against_layout;
    let mut rng = SplitMix64(23);
    let (iw, ih) = (256u32, 192u32);
    let (mut used, mut cases) = (0, 0);
    let (mut worst_pitch, mut worst_affine_pitch) = (0.0f32, 0.0f32);
    let (mut worst_box, mut worst_mapped, mut worst_affine) = (0.0f32, 0.0f32, 0.0f32);
    let (mut sum_mapped, mut sum_affine) = (0.0f32, 0.0f32);
    while cases < 10 {
        let (w, d, h) = (3.0 + 4.0 * rng.next_f32(), 3.0 + 4.0 * rng.next_f32(), 2.4 + 0.8 * rng.next_f32());
        let r = Room {
            w,
            d,
            h,
            cam: Vec3::new((rng.next_f32() - 0.5) * 0.4 * w, 1.2 + 0.6 * rng.next_f32(), d / 2.0 - BEHIND),
            yaw: (rng.next_f32() - 0.5) * 50.0,
            pitch: -20.0 + 20.0 * rng.next_f32(),
            fov: 50.0 + 20.0 * rng.next_f32(),
        };
        cases += 1;
        let boxes = furniture(&r, 0.25 * rng.next_f32(), &mut rng);
        let (mut s, classes) = room_scene(&r, &boxes, true, iw, ih);
        s.settings.spp = 16;
        let f = render_cpu(&SceneData::build(&s).unwrap(), &s.settings, &|_, _| {});
        let photo = psdr::base::Image::new(iw as usize, ih as usize, 3, f.radiance.clone()).unwrap();
        let mask = |c: &str| class_mask(&f, &classes, c);
        let (floor, wall, ceiling) = (mask("floor"), mask("wall"), mask("ceiling"));
        if floor.iter().filter(|&&b| b).count() < 200 {
            continue;
        }
        let rel: Vec<f32> = f
            .depth
            .iter()
            .enumerate()
            .map(|(i, &z)| {
                let x = (i % iw as usize) as f32 / iw as f32 - 0.5;
                if z > 0.0 {
                    (1.0 / z).powf(0.6) * (1.0 + 0.08 * x)
                } else {
                    0.0
                }
            })
            .collect();
        let k = Intrinsics::new(iw as usize, ih as usize, r.fov);
        let masks = [&floor[..], &wall[..], &ceiling[..]];
        let (affine_metres, _) = calibrate_relative_depth(&rel, DepthUnits::Disparity, masks, &k, 1.5, 1).unwrap();
        let affine = init_room(&affine_metres, &floor, &wall, &ceiling, &k, &RoomInitOptions::default()).unwrap();
        worst_affine_pitch = worst_affine_pitch.max((affine.pitch_deg - r.pitch).abs());
        let l = match check_against_layout(&photo, r.fov, &rel, DepthUnits::Disparity, &affine_metres, masks, &k, 1.5) {
            Ok(l) => l,
            Err(e) => {
                eprintln!("case {cases}: no layout: {e}");
                continue;
            }
        };
        eprintln!(
            "case {cases}: pitch {:.1} yaw {:.0} fov {:.0}: affine pitch {:.1} {:.2}x{:.2}x{:.2}; check {:?}",
            r.pitch, r.yaw, r.fov, affine.pitch_deg, affine.width, affine.depth, affine.height, l.check
        );
        let Some(e) = l.room else { continue };
        used += 1;
        if used == 1 {
            // The same through the observations' files: the run's room stage starts from the layout.
            let dir = psdr_tests::temp_dir("room-layout-observations");
            let photo_path = dir.join("room.png");
            psdr::output::write_png_srgb(&photo_path, iw, ih, &f.radiance).unwrap();
            psdr::output::write_exr_channels(&dir.join("room.depth.exr"), iw, ih, &[("Z".into(), rel.clone())])
                .unwrap();
            let ids: Vec<u16> = f.object_id.iter().map(|&o| if o == u32::MAX { 0 } else { o as u16 + 1 }).collect();
            let masks_img = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(iw, ih, ids).unwrap();
            masks_img.save(dir.join("room.masks.png")).unwrap();
            let labels: serde_json::Map<String, serde_json::Value> =
                classes.iter().enumerate().map(|(o, c)| ((o + 1).to_string(), c.as_str().into())).collect();
            std::fs::write(dir.join("room.labels.json"), serde_json::to_string(&labels).unwrap()).unwrap();
            let inputs = psdr::vision::ObservationInputs {
                depth_units: DepthUnits::Disparity,
                fov_y_deg: Some(r.fov),
                models: None,
                ..psdr::vision::ObservationInputs::new(&photo_path)
            };
            let obs = psdr::vision::Observations::resolve(&inputs).unwrap();
            let layout = obs.room_layout.as_ref().expect("the observations keep the layout");
            assert!((layout.pitch_deg - r.pitch).abs() < 1.0, "{layout:?}");
            assert!(obs.depth_calibration.as_ref().unwrap().layout.as_ref().unwrap().used);
            assert!(obs.warnings.iter().any(|w| w.contains("not affine")), "{:?}", obs.warnings);
            assert!(obs.sources["depth"].contains("by its order on the room layout"), "{:?}", obs.sources);
            assert_eq!(obs.resized(128).unwrap().room_layout.as_ref(), Some(layout));
        }
        eprintln!(
            "  layout pitch {:.2} roll {:.2} {:.2}x{:.2}x{:.2} seen {:?} ceiling {} (truth {:.2}x{:.2}x{:.2}; \
             wall pixels back/left/right {:?})",
            e.pitch_deg,
            e.roll_deg,
            e.width,
            e.depth,
            e.height,
            e.walls_seen,
            e.ceiling_seen,
            r.w * 1.5 / r.cam.y,
            r.d * 1.5 / r.cam.y,
            r.h * 1.5 / r.cam.y,
            [2u32, 4, 5].map(|o| f.object_id.iter().filter(|&&x| x == o).count())
        );
        worst_pitch = worst_pitch.max((e.pitch_deg - r.pitch).abs());
        assert!((e.camera_height - 1.5).abs() < 1e-4);
        assert!(l.check.rank_correlation.unwrap() > 0.95, "{:?}", l.check);
        let metres = l.metres.unwrap();
        assert!(metres.iter().all(|v| v.is_finite() && *v >= 0.0));
        // Depth errors against the truth at the prior's scale: the box where it measured the surface, and the
        // depth mapped onto it (furniture included) against the affine calibration's.
        let scale = 1.5 / r.cam.y;
        let rel_err = |got: f32, i: usize| (got - f.depth[i] * scale).abs() / (f.depth[i] * scale);
        let view = box_view(&e, &k);
        let on_box: Vec<f32> = (0..view.len())
            .filter_map(|i| match view[i] {
                Some((z, BoxSurface::Floor)) if floor[i] => Some(rel_err(z, i)),
                Some((z, BoxSurface::Wall(s))) if wall[i] && e.walls_seen[s] => Some(rel_err(z, i)),
                Some((z, BoxSurface::Ceiling)) if ceiling[i] && e.ceiling_seen => Some(rel_err(z, i)),
                _ => None,
            })
            .collect();
        let all = |d: &[f32]| (0..d.len()).filter(|&i| f.depth[i] > 0.0).map(|i| rel_err(d[i], i)).collect::<Vec<_>>();
        let (b, m, a) = (median(on_box), median(all(&metres)), median(all(&affine_metres)));
        eprintln!("  median depth error: box {:.2} %, mapped {:.2} %, affine {:.2} %", b * 100.0, m * 100.0, a * 100.0);
        worst_box = worst_box.max(b);
        worst_mapped = worst_mapped.max(m);
        worst_affine = worst_affine.max(a);
        (sum_mapped, sum_affine) = (sum_mapped + m, sum_affine + a);
    }
    eprintln!(
        "{used} of {cases} views took the layout: worst pitch {worst_pitch:.2} degrees (affine: \
         {worst_affine_pitch:.2}); worst median depth error: box {:.2} %, mapped {:.2} %, affine {:.2} %",
        worst_box * 100.0,
        worst_mapped * 100.0,
        worst_affine * 100.0
    );
    assert!(used * 10 >= cases * 7, "the layout was kept in only {used} of {cases} views");
    assert!(worst_pitch < 1.0, "pitch off by {worst_pitch} degrees");
    assert!(worst_box < 0.05, "the box's depth off by {worst_box} (median)");
    assert!(worst_mapped < 0.06 && sum_mapped < sum_affine, "mapped depth {worst_mapped}, affine {worst_affine}");
}

fn median(mut v: Vec<f32>) -> f32 {
    v.sort_by(f32::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f32::NAN)
}
