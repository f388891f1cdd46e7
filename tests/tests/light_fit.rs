//! The light fit (unit render per candidate light, non-negative least squares on the downsampled photo,
//! backward elimination) on a room rendered by psdr with two true ceiling lights among six candidates, and the
//! NNLS solver against a closed-form case; an unseen ceiling's height from the light it throws.

use glam::Vec3;
use psdr::backend::CpuBackend;
use psdr::render::{render_cpu, SceneData};
use psdr::scene::Emitter;
use psdr::stages::{fit_lights, nnls, LightFitOptions};
use psdr_tests::rooms::{furniture, room_scene, RoomSpec};
use psdr_tests::SplitMix64;

#[test]
fn nnls_matches_the_constrained_optimum() {
    // b = 2 a0 + 0 a1 - 1 a2 (a negative weight): the constrained optimum sets x2 = 0 and refits the rest.
    let a = vec![vec![1.0, 0.0, 0.0, 1.0], vec![0.0, 1.0, 0.0, 1.0], vec![0.0, 0.0, 1.0, 1.0]];
    let b = vec![2.0, 0.0, -1.0, 1.0];
    let x = nnls(&a, &b);
    assert!(x.iter().all(|&v| v >= 0.0), "{x:?}");
    // With x2 = 0: minimise (x0-2)^2 + x1^2 + 1 + (x0+x1-1)^2 -> x0 = 5/3, x1 = -1/3 < 0 -> x1 = 0, x0 = 1.5.
    assert!((x[0] - 1.5).abs() < 1e-9 && x[1].abs() < 1e-12 && x[2].abs() < 1e-12, "{x:?}");
    // An unconstrained interior solution is returned as is.
    let x = nnls(&a, &[1.0, 2.0, 3.0, 6.0]);
    assert!((x[0] - 1.0).abs() < 1e-9 && (x[1] - 2.0).abs() < 1e-9 && (x[2] - 3.0).abs() < 1e-9, "{x:?}");
}

/// Six candidate lights in a 3 x 2 grid over a furnished room's ceiling, facing down, and the photo of the
/// room lit by two of them in different colours (256 spp): the candidates' scene, their names, the true
/// radiances and the photo.
type LitRoom = (psdr::scene::Scene, Vec<String>, [(&'static str, Vec3); 2], Vec<f32>);

fn two_of_six_lit() -> LitRoom {
    let r = RoomSpec { w: 5.0, d: 6.0, h: 2.7, cam: Vec3::new(0.3, 1.5, 2.6), yaw: 5.0, pitch: -12.0, fov: 60.0 };
    let boxes = furniture(&r, 0.25, &mut SplitMix64(3));
    let (base, _) = room_scene(&r, &boxes, false, 128, 96);
    let light = base.objects.iter().find(|o| o.emitter.is_some()).unwrap().clone();
    // Six candidates: a 3 x 2 grid over the ceiling, facing down.
    let mut candidates = base.clone();
    candidates.objects.retain(|o| o.emitter.is_none());
    let mut names = vec![];
    for (i, x) in [-1.5f32, 0.0, 1.5].iter().enumerate() {
        for (j, z) in [-1.5f32, 0.5].iter().enumerate() {
            let mut l = light.clone();
            l.name = format!("light_{i}{j}");
            l.pose.translation = Vec3::new(*x, r.h - 0.01, *z);
            l.emitter = Some(Emitter::uniform(Vec3::ONE, false));
            names.push(l.name.clone());
            candidates.objects.push(l);
        }
    }
    // The truth: two of them lit, with different colours.
    let truth_rad = [("light_00", Vec3::new(9.0, 8.0, 6.5)), ("light_21", Vec3::new(4.0, 4.5, 6.0))];
    let mut truth = candidates.clone();
    truth.objects.retain(|o| o.emitter.is_none() || truth_rad.iter().any(|(n, _)| *n == o.name));
    for o in truth.objects.iter_mut() {
        if let Some((_, rad)) = truth_rad.iter().find(|(n, _)| *n == o.name) {
            o.emitter = Some(Emitter::uniform(*rad, false));
        }
    }
    truth.settings.spp = 256;
    truth.settings.max_depth = 3;
    truth.settings.seed = 7;
    let photo = render_cpu(&SceneData::build(&truth).unwrap(), &truth.settings, &|_, _| {}).radiance;
    (candidates, names, truth_rad, photo)
}

#[test]
fn two_true_lights_among_six_candidates() {
    let (candidates, names, truth_rad, photo) = two_of_six_lit();
    let t = std::time::Instant::now();
    let fit = fit_lights(&mut CpuBackend, &candidates, &names, &photo, &[], &LightFitOptions::default()).unwrap();
    eprintln!("{fit:?} in {:.1} s", t.elapsed().as_secs_f32());
    let kept: Vec<&String> = fit.names.iter().zip(&fit.kept).filter(|(_, k)| **k).map(|(n, _)| n).collect();
    assert_eq!(kept, vec!["light_00", "light_21"], "backward elimination keeps the two true lights");
    for (n, rad) in truth_rad {
        let i = fit.names.iter().position(|x| x == n).unwrap();
        for c in 0..3 {
            // Independent render noise (64 spp basis against a 256 spp photo): within 5 % per channel.
            assert!((fit.radiance[i][c] / rad[c] - 1.0).abs() < 0.05, "{n}: {:?} vs {rad}", fit.radiance[i]);
        }
    }
    assert!((fit.luminance_ratio - 1.0).abs() < 0.03, "luminance ratio {}", fit.luminance_ratio);
    assert!(fit.relative_rms < 0.1 && fit.relative_rms_all <= fit.relative_rms + 1e-6);
}

/// The same photo as an 8-bit camera records it with a longer exposure: every channel clamped at 1, so the
/// brightest part of the room (about 15 % of the pixels) reads white. Those pixels only bound the light from
/// below; the fit leaves them out and finds the true radiances times the exposure, as on the unclipped photo.
/// (Kept in the fit, where a clipped pixel asks for less light than caused it, they took the brighter light
/// from 28 to 1.3 in red.)
#[test]
fn a_clipped_photo_fits_the_lights_from_what_it_recorded() {
    let (candidates, names, truth_rad, photo) = two_of_six_lit();
    let mut brightest: Vec<f32> = photo.chunks(3).map(|c| c[0].max(c[1]).max(c[2])).collect();
    brightest.sort_by(f32::total_cmp);
    let exposure = 1.0 / brightest[brightest.len() * 85 / 100];
    let clipped: Vec<f32> = photo.iter().map(|v| (v * exposure).min(1.0)).collect();
    let share = clipped.chunks(3).filter(|c| c.iter().any(|v| *v >= 1.0)).count() as f32 / brightest.len() as f32;
    assert!(share > 0.1, "only {share} of the pixels clip");
    let fit = fit_lights(&mut CpuBackend, &candidates, &names, &clipped, &[], &LightFitOptions::default()).unwrap();
    for (n, rad) in truth_rad {
        let i = fit.names.iter().position(|x| x == n).unwrap();
        for c in 0..3 {
            let want = rad[c] * exposure;
            assert!((fit.radiance[i][c] / want - 1.0).abs() < 0.05, "{n}: {:?} vs {}", fit.radiance[i], rad * exposure);
        }
    }
}

/// The room scene `room_scene` builds from an estimate of test room `r` (its box, the camera of `truth`, a
/// ceiling at `height`), 128 x 96.
fn room_estimate_scene(
    truth: &psdr::scene::Scene,
    r: &RoomSpec,
    height: f32,
    ceiling_seen: bool,
) -> psdr::scene::Scene {
    let c = &truth.camera;
    let to_world =
        glam::Mat4::from_cols(c.right().extend(0.0), c.up.extend(0.0), (-c.forward).extend(0.0), c.origin.extend(1.0));
    let estimate = psdr::stages::RoomEstimate {
        width: r.w,
        depth: r.d,
        height,
        x_min: -r.w / 2.0,
        z_min: -r.d / 2.0,
        camera_to_world: to_world.transpose().to_cols_array_2d(),
        camera_height: r.cam.y,
        pitch_deg: r.pitch,
        roll_deg: 0.0,
        walls_seen: [true; 4],
        ceiling_seen,
        floor_inliers: 0,
    };
    psdr::stages::room_scene(&estimate, r.fov, 128, 96)
}

/// Candidate lights on a room: none of the ceiling grid where the camera sees it or behind the camera, one
/// behind the camera, a window on each wall the photo does not show and none on the walls it shows; then the
/// fit on a photo lit by a light that is not among the candidates still reproduces its luminance.
#[test]
fn candidates_avoid_the_view_and_fit_a_light_they_do_not_contain() {
    let r = RoomSpec { w: 5.0, d: 6.0, h: 2.7, cam: Vec3::new(0.3, 1.5, 2.6), yaw: 5.0, pitch: -12.0, fov: 60.0 };
    let (truth, _) = room_scene(&r, &[], false, 128, 96);
    let mut room = room_estimate_scene(&truth, &r, r.h, true);
    let names = psdr::stages::init_lights(&mut room, &psdr::stages::LightInitOptions::default());
    eprintln!("{names:?}");
    let cam = &room.camera;
    let tan_y = (cam.fov_y_deg.to_radians() / 2.0).tan();
    for n in names.iter().filter(|n| n.starts_with("light_ceiling")) {
        let p = room.objects.iter().find(|o| &o.name == n).unwrap().pose.translation - cam.origin;
        let z = p.dot(cam.forward);
        let inside =
            z > 0.0 && p.dot(cam.right()).abs() <= z * tan_y * 128.0 / 96.0 && p.dot(cam.up).abs() <= z * tan_y;
        assert!(!inside && z >= 0.0, "{n} is in view or behind the camera");
    }
    assert!(names.contains(&"light_behind_camera".to_string()));
    // The camera looks at wall_z0 (the back wall) and sees both side walls; the wall behind it is unseen.
    assert!(
        names.iter().any(|n| n.starts_with("light_window_wall_z1"))
            && !names.iter().any(|n| n.starts_with("light_window_wall_z0")),
        "{names:?}"
    );
    assert!(room.objects.iter().filter(|o| o.emitter.is_some()).count() == names.len());
    // The truth's light (0.6 m square at the ceiling's centre, in view) is not a candidate; the fit still
    // matches the photo's downsampled luminance.
    let mut t = truth.clone();
    t.settings.spp = 128;
    t.settings.max_depth = 3;
    let photo = render_cpu(&SceneData::build(&t).unwrap(), &t.settings, &|_, _| {}).radiance;
    let fit =
        fit_lights(&mut CpuBackend, &room, &names, &photo, &[], &LightFitOptions { spp: 32, ..Default::default() })
            .unwrap();
    eprintln!("kept {:?}, relative RMS {:.3}, luminance ratio {:.4}", fit.kept, fit.relative_rms, fit.luminance_ratio);
    assert!((fit.luminance_ratio - 1.0).abs() < 0.05, "{}", fit.luminance_ratio);
    assert!(fit.kept.iter().filter(|k| **k).count() < names.len(), "nothing removed");
}

/// The test room seen by camera `r` (128 x 96) with an emissive 1.2 x 1.0 m pane (radiance 5) 1 cm in front of
/// its left wall (x = -2.5) centred at `at`, its ceiling light kept or not, rendered at `spp` (0: the room's
/// own): the depth, the window's instance (id 1), the photo as an 8-bit camera records it (clipped at its
/// white), and the room without emitters that the tests fit.
fn window_photo(
    r: &RoomSpec,
    at: Vec3,
    ceiling_light: bool,
    spp: u32,
) -> (Vec<f32>, psdr::vision::Instances, Vec<f32>, psdr::scene::Scene) {
    use glam::Quat;
    use psdr::scene::{rectangle_mesh, Object, Pose};
    use psdr::vision::{canonical_class, Instance, Instances};
    let (mut room, _) = room_scene(r, &[], false, 128, 96);
    if !ceiling_light {
        room.objects.retain(|o| o.emitter.is_none());
    }
    let mut pane = rectangle_mesh(1.2, 1.0);
    pane.material = 0;
    room.objects.push(Object {
        name: "window".into(),
        parts: vec![pane],
        pose: Pose { translation: at, rotation: Quat::from_rotation_y(std::f32::consts::FRAC_PI_2), scale: Vec3::ONE },
        emitter: Some(Emitter::uniform(Vec3::splat(5.0), false)),
    });
    if spp > 0 {
        room.settings.spp = spp;
    }
    let f = render_cpu(&SceneData::build(&room).unwrap(), &room.settings, &|_, _| {});
    let o = room.object_index("window").unwrap() as u32;
    let ids: Vec<u16> = f.object_id.iter().map(|&i| u16::from(i == o)).collect();
    let pixels = ids.iter().filter(|&&v| v == 1).count();
    let (class, kind) = canonical_class("window");
    let inst = Instances {
        width: 128,
        height: 96,
        ids,
        instances: vec![Instance { id: 1, label: Some("window".into()), class: class.into(), kind, pixels }],
    };
    let photo: Vec<f32> = f.radiance.iter().map(|v| v.min(1.0)).collect();
    room.objects.retain(|o| o.emitter.is_none());
    (f.depth, inst, photo, room)
}

/// A window the photo shows becomes an area light where it is: an emissive 1.2 x 1.0 m pane in the left wall of
/// a rendered room, segmented as `window`, is placed by `add_visible_windows` on that wall with its edges within
/// 5 cm from its pixels' range and within 2 cm (those the frame does not cut) with its outline fitted to the
/// photo, facing into the room, and the light placement does not move it.
#[test]
fn a_visible_window_becomes_a_light_on_its_wall() {
    use psdr::stages::add_visible_windows;
    let r = RoomSpec { w: 5.0, d: 6.0, h: 2.7, cam: Vec3::new(0.8, 1.5, 2.6), yaw: 15.0, pitch: -8.0, fov: 60.0 };
    let at = Vec3::new(-2.49, 1.4, -0.5);
    let (depth, inst, photo, mut fitted) = window_photo(&r, at, true, 0);
    let pixels = inst.instances[0].pixels;
    assert!(pixels > 200, "the window covers {pixels} pixels");
    // Its edges' errors (bottom, top, far side, near side), lying on the wall facing into the room.
    let edges_off = |s: &psdr::scene::Scene| {
        let w = s.objects.iter().find(|o| o.name == "light_window_1").unwrap();
        assert!((w.pose.rotation * Vec3::Z).dot(Vec3::X) > 0.99, "faces into the room");
        assert!(w.emitter.is_some());
        let (lo, hi) = w.parts[0]
            .positions
            .iter()
            .map(|p| w.pose.matrix().transform_point3(*p))
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| (a.min(p), b.max(p)));
        eprintln!("window placed {lo} .. {hi}");
        [lo.y - (at.y - 0.5), hi.y - (at.y + 0.5), lo.z - (at.z - 0.6), hi.z - (at.z + 0.6)].map(f32::abs)
    };
    // From the range of its pixels' points alone: within 5 cm (a pixel here is 4 cm on the wall).
    let mut coarse = fitted.clone();
    assert_eq!(add_visible_windows(&mut coarse, None, &depth, &inst, 20), ["light_window_1"]);
    let off = edges_off(&coarse);
    assert!(off.iter().all(|e| *e < 0.05), "edges off {off:?} m");
    // With its outline fitted to the photo's pixels (each pixel's covered fraction, clipped at white): within
    // half a pixel, but for its near side, which the frame cuts (kept where the pixels end). Its edges run
    // nearly along the pixel grid, where an 8-bit photo says only which pixels are covered enough to clip (the
    // outline's own test finds slanted edges to a tenth of a pixel).
    let names = add_visible_windows(&mut fitted, Some(&photo), &depth, &inst, 20);
    assert_eq!(names, ["light_window_1"]);
    let off = edges_off(&fitted);
    assert!(off[..3].iter().all(|e| *e < 0.02) && off[3] < 0.05, "edges off {off:?} m");
    // The light placement leaves its part in view where it is. In an 8-bit photo the window's pixels are
    // clipped, so the fit leaves them out, and the photo's ceiling light is missing from the fitted scene: a
    // window free to move and grow would go some way to light what the ceiling light lit (it moved 22 cm
    // before windows were held). The frame cuts its near side, so that side may grow out of view (here it
    // does, for the missing light: `a_window_the_frame_cuts_grows_out_of_view`); the other three stay.
    let before = edges_off(&fitted);
    let opts = psdr::stages::LightPlacementOptions::default();
    let placed = psdr::stages::refine_light_placement(&mut CpuBackend, &mut fitted, &photo, &[], &opts).unwrap();
    eprintln!("{placed:?}");
    let after = edges_off(&fitted);
    assert!((0..3).all(|k| (after[k] - before[k]).abs() < 0.01), "edges off {before:?} -> {after:?} m");
}

/// A window the frame cuts lights the room through all of itself, not only through its part in view: the test
/// room lit by a 1.2 x 1.0 m window in its left wall alone, the window's near half out of view. Held to its part
/// in view it had to be far brighter to light the room, and lit the wall beside it instead of the far ones
/// (real room06: 0.24 x 0.61 m for 1.2 x 1.0, the image error 14.2 % where the true scene's is 1.4 %). The
/// placement grows it out of view to within 15 cm of its size, its part in view still on the photo's window
/// pixels (its far edge within 3 cm), and the fit's error falls by half at least; without the change the window
/// stayed its part in view.
#[test]
fn a_window_the_frame_cuts_grows_out_of_view() {
    use psdr::stages::{add_visible_windows, refine_light_placement, LightPlacementOptions};
    let r = RoomSpec { w: 5.0, d: 6.0, h: 2.7, cam: Vec3::new(0.8, 1.5, 2.6), yaw: 15.0, pitch: -8.0, fov: 60.0 };
    let at = Vec3::new(-2.49, 1.4, 0.3);
    let (depth, inst, photo, mut fitted) = window_photo(&r, at, false, 256);
    let pixels = inst.instances[0].pixels;
    let window_pixels: Vec<bool> = inst.ids.iter().map(|&v| v == 1).collect();
    let names = add_visible_windows(&mut fitted, Some(&photo), &depth, &inst, 20);
    assert_eq!(names, ["light_window_1"]);
    let extent = |s: &psdr::scene::Scene| {
        let w = s.objects.iter().find(|o| o.name == names[0]).unwrap();
        w.parts[0]
            .positions
            .iter()
            .map(|p| w.pose.matrix().transform_point3(*p))
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| (a.min(p), b.max(p)))
    };
    let (lo, hi) = extent(&fitted);
    eprintln!("{pixels} window pixels; in view {lo} .. {hi}");
    assert!(hi.z - lo.z < 0.8, "the frame cuts the window: {lo} .. {hi}");
    let opts = LightPlacementOptions { window_pixels, ..Default::default() };
    let placed = refine_light_placement(&mut CpuBackend, &mut fitted, &photo, &[], &opts).unwrap();
    let (lo2, hi2) = extent(&fitted);
    eprintln!("{placed:?}\nplaced {lo2} .. {hi2}");
    assert!(((hi2.z - lo2.z) - 1.2).abs() < 0.15 && ((hi2.y - lo2.y) - 1.0).abs() < 0.15, "size {}", hi2 - lo2);
    assert!((lo2.z - (at.z - 0.6)).abs() < 0.03, "far edge {} for {}", lo2.z, at.z - 0.6);
    assert!(placed.relative_rms_after < 0.5 * placed.relative_rms_before, "{placed:?}");
}

/// Lights off their place (`refine_light_placement`): the two lights of the known-geometry room started 30-43
/// cm away from where the photo was lit and 1.5x / 0.7x their size come back, by the pattern search on the
/// unit renders' fit, with their power (radiance x area, per channel) within 15 %, the main light (light_a,
/// over the part of the room the camera sees) within 10 cm (measured 7 cm), and the fit's error falls by a
/// third at least (measured 6.7 % -> 3.8 %, the rest mostly the renders' noise: the photo has every bounce
/// and the unit renders 16-vertex paths at 256 spp per reduced pixel; at 64 spp light_a ended 16 cm off; with
/// 3-vertex paths the error went 8.7 % -> 2.4 %). Weakly determined and so reported, not asserted: a light's size at the
/// fit's 1/8 size (only penumbrae show it: 0.77x as large and 1.6x as bright fits as well), and the position
/// of the dim light over the camera's own half of the room, which lights mostly what the photo does not show
/// (measured 32 cm off).
#[test]
fn misplaced_lights_move_back_to_where_the_photo_was_lit() {
    const SPP: u32 = 256;
    use psdr::stages::{refine_light_placement, LightPlacementOptions};
    let (truth, _) = psdr_tests::known_geometry::truth_room();
    let photo = render_cpu(&SceneData::build(&truth).unwrap(), &truth.settings, &|_, _| {}).radiance;
    let mut start = truth.clone();
    start.settings.spp = 16;
    for (name, shift, size) in
        [("light_a", Vec3::new(0.35, 0.0, -0.25), 1.5f32), ("light_b", Vec3::new(-0.3, 0.0, 0.2), 0.7)]
    {
        let o = start.objects.iter_mut().find(|o| o.name == name).unwrap();
        o.pose.translation += shift;
        o.pose.scale *= Vec3::new(size, size, 1.0);
        o.emitter = Some(Emitter::uniform(Vec3::ONE, false));
    }
    let t = std::time::Instant::now();
    let opts = LightPlacementOptions {
        render: psdr::stages::LightFitOptions { spp: SPP, ..Default::default() },
        ..Default::default()
    };
    let placed = refine_light_placement(&mut CpuBackend, &mut start, &photo, &[], &opts).unwrap();
    eprintln!("{placed:?} in {:.1} s", t.elapsed().as_secs_f32());
    for name in ["light_a", "light_b"] {
        let (got, want) = (
            start.objects.iter().find(|o| o.name == name).unwrap(),
            truth.objects.iter().find(|o| o.name == name).unwrap(),
        );
        let off = (got.pose.translation - want.pose.translation).length();
        let size = got.pose.scale.x / want.pose.scale.x;
        let area = |o: &psdr::scene::Object| o.pose.scale.x * o.pose.scale.y;
        let power = got.emitter.unwrap().radiance * area(got) / (want.emitter.unwrap().radiance * area(want));
        eprintln!("{name}: {off:.3} m off, size x{size:.2}, power x{power}");
        assert!(name != "light_a" || off < 0.1, "{name}: {off} m from the truth");
        assert!(power.cmpgt(Vec3::splat(0.85)).all() && power.cmplt(Vec3::splat(1.15)).all(), "{name}: power x{power}");
    }
    assert!(placed.relative_rms_after < 0.67 * placed.relative_rms_before, "{placed:?}");
}

/// One light fitted as two (`LightPlacementOptions::merge_threshold`): the known-geometry room lit by its main
/// light alone (light_a, 0.6 m), started as two copies of it 1 m apart on either side along z (where a 1.5 m
/// candidate grid leaves a light between two cells), is placed as one light, back within 10 cm of the truth
/// (measured 1 cm) with its power within 15 % (measured 0.4 %), the fit's relative error 3.8 %. The merge is
/// allowed 1 point of relative error here (it costs 0.66, 4.6 -> 5.2 %, before the search moves the light; the
/// script's default, 0.25, is for merges the candidate grid makes, the known-geometry run's cost 0.06). Without
/// merging both copies stay, moved 40 and 30 cm by the pattern search, at about the same error (3.7 %): two
/// lights where the scene has one (94 s for the two placements in a release build while another job ran).
#[test]
fn two_lights_straddling_one_are_merged_into_it() {
    use psdr::stages::{refine_light_placement, LightPlacementOptions};
    let (mut truth, _) = psdr_tests::known_geometry::truth_room();
    truth.objects.retain(|o| o.name != "light_b");
    let photo = render_cpu(&SceneData::build(&truth).unwrap(), &truth.settings, &|_, _| {}).radiance;
    let want = truth.objects.iter().find(|o| o.name == "light_a").unwrap().clone();
    let mut start = truth.clone();
    start.settings.spp = 16;
    start.objects.retain(|o| o.emitter.is_none());
    for (name, dz) in [("near", 0.5), ("far", -0.5)] {
        let mut o = want.clone();
        o.name = name.into();
        o.pose.translation.z += dz;
        o.emitter = Some(Emitter::uniform(Vec3::ONE, false));
        start.objects.push(o);
    }
    let opts = LightPlacementOptions {
        render: LightFitOptions { spp: 256, ..Default::default() },
        merge_threshold: 0.01,
        ..Default::default()
    };
    let placed = refine_light_placement(&mut CpuBackend, &mut start, &photo, &[], &opts).unwrap();
    eprintln!("{placed:?}");
    let lights: Vec<&psdr::scene::Object> = start.objects.iter().filter(|o| o.emitter.is_some()).collect();
    assert_eq!(lights.len(), 1, "{placed:?}");
    assert_eq!((placed.merged.len(), placed.names.len()), (1, 1));
    let got = lights[0];
    let off = (got.pose.translation - want.pose.translation).length();
    let area = |o: &psdr::scene::Object| o.pose.scale.x * o.pose.scale.y;
    let power = got.emitter.unwrap().radiance * area(got) / (want.emitter.unwrap().radiance * area(&want));
    eprintln!("merged: {off:.3} m off, power x{power}");
    assert!(off < 0.1, "{off} m from the truth");
    assert!(power.cmpgt(Vec3::splat(0.85)).all() && power.cmplt(Vec3::splat(1.15)).all(), "power x{power}");
}

/// A ceiling the photo does not show (the camera pitched 15 degrees down), lit by the test room's 1.2 m light
/// hanging from it at 2.7 m: the room estimate puts the ceiling at 3.3 m (room_init's guess above the highest
/// point shown, 2.40 m here), and `search_ceiling_height` brings it back within 10 cm from the light the walls
/// and floor receive (measured 2.65 m on a 0.6 m grid of candidates; on a 1.2 m grid 2.45 m: the fit then hinges
/// on where the grid falls, hence the finer grid). The highest point shown bounds the search from below.
#[test]
fn an_unseen_ceiling_is_placed_by_the_light_it_throws() {
    use psdr::stages::{search_ceiling_height, CeilingSearchOptions};
    let r = RoomSpec { w: 4.5, d: 5.0, h: 2.7, cam: Vec3::new(0.2, 1.4, 2.0), yaw: 5.0, pitch: -15.0, fov: 55.0 };
    let (mut truth, classes) = room_scene(&r, &furniture(&r, 0.2, &mut SplitMix64(5)), false, 128, 96);
    truth.settings = psdr::scene::RenderSettings { spp: 256, max_depth: 4, rr_depth: 3, seed: 7 };
    let f = render_cpu(&SceneData::build(&truth).unwrap(), &truth.settings, &|_, _| {});
    let ceiling = classes.iter().position(|c| c == "ceiling").unwrap() as u32;
    assert!(!f.object_id.contains(&ceiling), "the photo must not show the ceiling");
    let mut room = room_estimate_scene(&truth, &r, 3.3, false);
    // The truth's boxes and grey material: the search is about the ceiling, not the furniture or the albedos.
    room.objects.extend(truth.objects.iter().filter(|o| o.name.starts_with("box")).cloned());
    room.materials.iter_mut().for_each(|m| m.albedo = psdr::scene::Color::Constant(Vec3::splat(0.6)));
    room.settings = truth.settings.clone();
    let opts = CeilingSearchOptions {
        fit: LightFitOptions { spp: 64, downsample: 4, ..Default::default() },
        lights: psdr::stages::LightInitOptions { cell: 0.6, ..Default::default() },
        ..Default::default()
    };
    let found = search_ceiling_height(&mut CpuBackend, &mut room, &f.radiance, &f.depth, None, &[], &opts).unwrap();
    eprintln!("{found:?}");
    assert!(found.lowest < r.h && found.lowest > 2.0, "highest point shown {}", found.lowest);
    assert!((found.chosen - r.h).abs() <= 0.1, "ceiling at {} for {}", found.chosen, r.h);
    let y = room.objects.iter().find(|o| o.name == "ceiling").unwrap().pose.translation.y;
    assert_eq!(y, found.chosen, "the scene's ceiling is moved to the chosen height");
    assert!((found.start - 3.3).abs() < 1e-5);
}

/// The test room's 1.2 m ceiling panel at the ceiling's centre, photographed (8-bit: clipped at 1) with the
/// camera pitched `pitch` degrees; the room estimate with the candidate grid (their names) and the lights
/// `add_visible_ceiling_lights` adds to it (their names), and the photo.
fn ceiling_panel_photo(pitch: f32) -> (RoomSpec, psdr::scene::Scene, Vec<String>, Vec<String>, Vec<f32>) {
    use psdr::stages::{add_visible_ceiling_lights, init_lights, LightInitOptions};
    let r = RoomSpec { w: 5.0, d: 6.0, h: 2.7, cam: Vec3::new(0.3, 1.5, 2.6), yaw: 5.0, pitch, fov: 60.0 };
    let (truth, _) = room_scene(&r, &[], false, 128, 96);
    let f = render_cpu(&SceneData::build(&truth).unwrap(), &truth.settings, &|_, _| {});
    let photo: Vec<f32> = f.radiance.iter().map(|v| v.min(1.0)).collect();
    let mut room = room_estimate_scene(&truth, &r, r.h, true);
    let grid = init_lights(&mut room, &LightInitOptions::default());
    let names = add_visible_ceiling_lights(&mut room, &photo, &f.depth, None, 6);
    (r, room, grid, names, photo)
}

/// World-space bounds of the light `name` of `scene`.
fn light_bounds(scene: &psdr::scene::Scene, name: &str) -> (Vec3, Vec3) {
    let l = scene.objects.iter().find(|o| o.name == name).unwrap();
    l.parts[0]
        .positions
        .iter()
        .map(|p| l.pose.matrix().transform_point3(*p))
        .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| (a.min(p), b.max(p)))
}

/// A ceiling light the photo shows becomes an area light where its pixels are: the test room's 1.2 m panel at
/// the ceiling's centre, in view and at the 8-bit photo's white, is found by `add_visible_ceiling_lights` with
/// its centre and size within 5 cm (measured 1.19 x 1.20 m, centre 1 cm off), facing down, on the room
/// estimate's ceiling; the candidate grid has no light
/// there (the camera sees that place), and the light placement leaves it where it is.
#[test]
fn a_ceiling_light_in_view_becomes_a_light_where_it_shows() {
    use psdr::stages::refine_light_placement;
    let (r, mut room, grid, names, photo) = ceiling_panel_photo(10.0);
    assert_eq!(names, ["light_panel_0"], "one panel (the grid had {grid:?})");
    let l = room.objects.iter().find(|o| o.name == names[0]).unwrap();
    let (lo, hi) = light_bounds(&room, &names[0]);
    eprintln!("panel {lo} .. {hi}");
    assert!(((lo + hi) / 2.0 - Vec3::new(0.0, r.h - 0.01, 0.0)).length() < 0.05, "centre {}", (lo + hi) / 2.0);
    assert!(((hi.x - lo.x) - 1.2).abs() < 0.05 && ((hi.z - lo.z) - 1.2).abs() < 0.05, "size {}", hi - lo);
    assert!((l.pose.rotation * Vec3::Z).dot(-Vec3::Y) > 0.99, "faces down");
    // No grid candidate where the panel is: the camera sees that place.
    for g in &grid {
        let p = room.objects.iter().find(|o| &o.name == g).unwrap().pose.translation;
        assert!(Vec3::new(p.x, 0.0, p.z).length() > 0.6 || p.y < 2.0, "{g} at {p} overlaps the panel");
    }
    let pose = l.pose;
    let placed = refine_light_placement(
        &mut CpuBackend,
        &mut room,
        &photo,
        &[],
        &psdr::stages::LightPlacementOptions::default(),
    )
    .unwrap();
    let l = room.objects.iter().find(|o| o.name == names[0]).unwrap();
    assert_eq!((l.pose.translation, l.pose.scale), (pose.translation, pose.scale), "{placed:?}");
}

/// A ceiling lit near white beside a light clips one channel, and all three in scattered pixels (real room00:
/// a 0.79 m panel with such a band along one side was fitted 1.56 x 1.30 m): the panel is taken from its
/// pixels white in every channel. The test room's panel with a band half its width painted beside it (one
/// channel at white, every third pixel white in all three): found within 5 cm of its 1.2 m as without the band;
/// taken from every light-source pixel, it was the band's width wider.
#[test]
fn a_ceiling_light_is_found_without_the_glow_beside_it() {
    use psdr::stages::add_visible_ceiling_lights;
    let (r, _, _, _, mut photo) = ceiling_panel_photo(10.0);
    let (w, h) = (128usize, 96usize);
    let white = |p: usize, photo: &[f32]| photo[3 * p..3 * p + 3].iter().all(|v| *v >= 0.999);
    let panel: Vec<usize> = (0..w * h).filter(|&p| white(p, &photo)).collect();
    let (x0, x1) = panel.iter().fold((w, 0), |(a, b), &p| (a.min(p % w), b.max(p % w)));
    let (y0, y1) = panel.iter().fold((h, 0), |(a, b), &p| (a.min(p / w), b.max(p / w)));
    let band = (x1 - x0) / 2;
    for y in y0..=y1 {
        for x in x1 + 1..=(x1 + band).min(w - 2) {
            let c = if (x + y) % 3 == 0 { [1.0, 1.0, 1.0] } else { [0.95, 0.93, 1.0] };
            photo[3 * (y * w + x)..3 * (y * w + x) + 3].copy_from_slice(&c);
        }
    }
    let (truth, _) = room_scene(&r, &[], false, 128, 96);
    let f = render_cpu(&SceneData::build(&truth).unwrap(), &truth.settings, &|_, _| {});
    let mut room = room_estimate_scene(&truth, &r, r.h, true);
    let names = add_visible_ceiling_lights(&mut room, &photo, &f.depth, None, 6);
    assert_eq!(names, ["light_panel_0"], "one panel");
    let (lo, hi) = light_bounds(&room, &names[0]);
    eprintln!("band of {band} pixels beside x {x0}..{x1}: panel {lo} .. {hi}");
    assert!(((hi.x - lo.x) - 1.2).abs() < 0.05 && ((hi.z - lo.z) - 1.2).abs() < 0.05, "size {}", hi - lo);
    assert!(((lo + hi) / 2.0 - Vec3::new(0.0, r.h - 0.01, 0.0)).length() < 0.05, "centre {}", (lo + hi) / 2.0);
}

/// A ceiling light the frame cuts: the same panel with the camera pitched down so its near part leaves the
/// top of the photo. A clipped patch at the border may also be a lit white ceiling, so it becomes a candidate
/// the fit may remove (`light_edge_0`, not a visible light), over the part in view: inside the true panel,
/// reaching its far edge. The photo needs it (the grid has no candidate in view, and its clipped pixels are a
/// lower bound on the render), so the fit keeps it.
#[test]
fn a_ceiling_light_cut_by_the_frame_becomes_a_candidate_the_fit_keeps() {
    let (_, room, grid, names, photo) = ceiling_panel_photo(-5.0);
    assert_eq!(names, ["light_edge_0"], "one cut panel (the grid had {grid:?})");
    assert!(!psdr::stages::is_visible_light(&names[0]), "a candidate, not a light the photo is known to show");
    let (lo, hi) = light_bounds(&room, &names[0]);
    eprintln!("edge light {lo} .. {hi}");
    assert!(lo.x > -0.65 && hi.x < 0.65 && lo.z > -0.65 && hi.z < 0.65, "inside the true panel: {lo} .. {hi}");
    assert!((lo.z + 0.6).abs() < 0.05, "reaches the panel's far edge: {lo}");
    assert!(hi.z < 0.5, "the part in view only: {hi}");
    let lights: Vec<String> = grid.iter().chain(&names).cloned().collect();
    let opts = LightFitOptions { spp: 64, downsample: 8, ..Default::default() };
    let fit = fit_lights(&mut CpuBackend, &room, &lights, &photo, &[], &opts).unwrap();
    let k = fit.names.iter().position(|n| n == &names[0]).unwrap();
    assert!(fit.kept[k], "the fit keeps the cut panel: {fit:?}");
}

/// The placement moves a ceiling light the frame cuts only out of view: its part in view is where the photo
/// shows it, its part beyond the frame a guess. The cut panel of the test above, alone (the true room's only
/// light), placed from its part in view: its far edge and its sides stay on the panel's within 5 cm, and its
/// near side grows out of view towards the panel's. Moved freely (before), a light like it at a real photo's
/// corner kept a quarter of its patch in view (real room10, benchmarks/README.md).
#[test]
fn a_ceiling_light_cut_by_the_frame_is_placed_out_of_view_only() {
    use psdr::stages::{refine_light_placement, LightPlacementOptions};
    let (_, mut room, grid, names, photo) = ceiling_panel_photo(-5.0);
    room.objects.retain(|o| !grid.contains(&o.name));
    let (lo0, hi0) = light_bounds(&room, &names[0]);
    let placed =
        refine_light_placement(&mut CpuBackend, &mut room, &photo, &[], &LightPlacementOptions::default()).unwrap();
    let (lo, hi) = light_bounds(&room, &names[0]);
    eprintln!("edge light {lo0} .. {hi0} -> {lo} .. {hi}: {placed:?}");
    assert!((lo.z + 0.6).abs() < 0.05, "the far edge stays on the panel's: {lo}");
    assert!((lo.x + 0.6).abs() < 0.05 && (hi.x - 0.6).abs() < 0.05, "the sides stay on the panel's: {lo} .. {hi}");
    assert!(hi.z > hi0.z + 0.05 && hi.z < 0.9, "the near side grows out of view towards 0.6: {hi0} -> {hi}");
}

/// A window the photo does not show, on a side wall near the back corner, lights the floor and the back wall
/// beside it. The candidates' one window at that wall's middle, 2 m from it, is not what the elimination keeps
/// (it keeps a ceiling light and the window behind the camera, relative error 0.195); after the choice
/// `add_unseen_window` tries a row along each unseen wall (one per 1.5 m) beside the kept lights and adds the
/// one by the corner (z -2.25 against the window's -2.0), and after the placement it is within 0.5 m of it
/// (measured 0.45: the window behind the camera, kept, shares its light) and the error is 0.056, under half the
/// choice's. In the room without the window the best of the row gains 0.3 points of error, and none is added.
#[test]
fn an_unseen_window_near_a_corner_is_found_along_its_wall() {
    use psdr::stages::{
        add_unseen_window, init_lights, refine_light_placement, LightInitOptions, LightPlacementOptions,
        UnseenWindowOptions,
    };
    // Looking right from near the left wall, which the frame leaves out; the window in it 1 m from the back.
    let r = RoomSpec { w: 5.0, d: 6.0, h: 2.7, cam: Vec3::new(-1.5, 1.5, 2.0), yaw: -35.0, pitch: -10.0, fov: 60.0 };
    let at = Vec3::new(-2.49, 1.4, -2.0);
    let (_, _, photo, mut room) = window_photo(&r, at, true, 128);
    for o in room.objects.iter_mut() {
        // The walls as the room stage names them.
        let name = ["back", "front", "left", "right"]
            .iter()
            .zip(["z0", "z1", "x0", "x1"])
            .find(|(w, _)| o.name == format!("wall_{w}"));
        if let Some((_, id)) = name {
            o.name = format!("wall_{id}");
        }
    }
    let fit_opts = LightFitOptions { spp: 32, ..Default::default() };
    let names = init_lights(&mut room, &LightInitOptions::default());
    assert!(names.contains(&"light_window_wall_x0".to_string()), "the left wall is in view: {names:?}");
    let fit = fit_lights(&mut CpuBackend, &room, &names, &photo, &[], &fit_opts).unwrap();
    let kept: Vec<&String> = fit.names.iter().zip(&fit.kept).filter(|(_, k)| **k).map(|(n, _)| n).collect();
    room.objects.retain(|o| o.emitter.is_none() || kept.contains(&&o.name));
    let unseen = UnseenWindowOptions { fit: fit_opts.clone(), ..Default::default() };
    let added = add_unseen_window(&mut CpuBackend, &mut room, &photo, &[], &unseen).unwrap();
    eprintln!("kept {kept:?} ({:.4}); {added:?}", fit.relative_rms);
    let window = added.added.clone().expect("no window added");
    assert!(window.starts_with("light_window_wall_x0_"), "{window}");
    let opts = LightPlacementOptions { render: fit_opts.clone(), ..Default::default() };
    let placed = refine_light_placement(&mut CpuBackend, &mut room, &photo, &[], &opts).unwrap();
    let got = room.objects.iter().find(|o| o.name == window).unwrap().pose.translation;
    eprintln!("{window} at {got}, {:.3} m from the window; {placed:?}", (got - at).length());
    assert!((got - at).length() < 0.5, "{window} at {got}, the window at {at}");
    assert!(placed.relative_rms_after < 0.5 * fit.relative_rms, "{placed:?} against the choice's {}", fit.relative_rms);
    // The same step in the room without the window (lit by its ceiling light alone; the pane below the floor)
    // adds none.
    let (_, _, plain_photo, _) = window_photo(&r, Vec3::new(-2.49, -5.0, -2.0), true, 128);
    let mut plain = room.clone();
    plain.objects.retain(|o| o.emitter.is_none());
    let names = init_lights(&mut plain, &LightInitOptions::default());
    let fit = fit_lights(&mut CpuBackend, &plain, &names, &plain_photo, &[], &fit_opts).unwrap();
    let kept: Vec<&String> = fit.names.iter().zip(&fit.kept).filter(|(_, k)| **k).map(|(n, _)| n).collect();
    plain.objects.retain(|o| o.emitter.is_none() || kept.contains(&&o.name));
    let none = add_unseen_window(&mut CpuBackend, &mut plain, &plain_photo, &[], &unseen).unwrap();
    eprintln!("without a window: kept {kept:?}; {none:?}");
    assert!(none.added.is_none(), "{none:?}");
}
