//! A window's daylight shaped by direction (`stages::fit_window_skies`) on a room rendered by psdr: a ceiling
//! light and a window on the left wall whose radiance grows toward the sky (`Emitter::sky_gradient`), the photo
//! at 256 spp with every pixel at or above white clipped as an 8-bit photo records it (the window's own pixels
//! among them, so the fit sees the window only through the light it throws on the room). The fit starts from
//! a uniform window of the wrong brightness and must find the gradient, keep it, and bring the window's power
//! back (measured: g 0.797 for 0.8, radiance 4.97 for 5, the fit's relative error 9.6 -> 1.8 %); on the same
//! room with a uniform window it must leave the scene as it was (measured: g 0.007, error 1.742 -> 1.740 %).

use glam::{Quat, Vec3};
use psdr::backend::CpuBackend;
use psdr::render::{render_cpu, SceneData};
use psdr::scene::{rectangle_mesh, Emitter, Object, Pose, Scene};
use psdr::stages::{fit_window_skies, WindowSkyOptions};
use psdr_tests::rooms::{room_scene, RoomSpec};

/// The room with its window (1.2 x 1.0 m, 1 cm in front of the left wall, facing into the room) of radiance 5
/// and sky gradient `g`, and the 8-bit photo of it.
fn room_with_window(g: f32) -> (Scene, Vec<f32>) {
    let r = RoomSpec { w: 5.0, d: 6.0, h: 2.7, cam: Vec3::new(0.8, 1.5, 2.6), yaw: 15.0, pitch: -8.0, fov: 60.0 };
    let (mut room, _) = room_scene(&r, &[], false, 128, 96);
    let mut pane = rectangle_mesh(1.2, 1.0);
    pane.material = 0;
    let pose = Pose {
        translation: Vec3::new(-2.49, 1.4, -0.5),
        rotation: Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
        scale: Vec3::ONE,
    };
    let emitter = Some(Emitter { sky_gradient: Vec3::splat(g), ..Emitter::uniform(Vec3::splat(5.0), false) });
    room.objects.push(Object { name: "window".into(), parts: vec![pane], pose, emitter });
    let mut truth = room.clone();
    (truth.settings.spp, truth.settings.seed) = (256, 7);
    let photo = render_cpu(&SceneData::build(&truth).unwrap(), &truth.settings, &|_, _| {}).radiance;
    (room, photo.iter().map(|v| v.min(1.0)).collect())
}

/// The window's emitter (its normal is horizontal, so its shape averages 1 over the cosine-weighted
/// hemisphere: its power is its radiance's whatever the gradient).
fn window(s: &Scene) -> Emitter {
    s.objects.iter().find(|o| o.name == "window").unwrap().emitter.unwrap()
}

#[test]
fn a_windows_sky_gradient_is_found_from_the_light_it_throws() {
    let (truth, photo) = room_with_window(0.8);
    let mut s = truth.clone();
    for o in s.objects.iter_mut().filter_map(|o| o.emitter.as_mut()) {
        (o.radiance, o.sky_gradient) = (Vec3::splat(3.0), Vec3::ZERO);
    }
    let found =
        fit_window_skies(&mut CpuBackend, &mut s, &["window".into()], &photo, &[], &WindowSkyOptions::default())
            .unwrap();
    let w = window(&s);
    eprintln!("{found:?}\nwindow {w:?}");
    assert!(found.kept && found.relative_rms_shaped < 0.5 * found.relative_rms_as_they_were, "{found:?}");
    for c in 0..3 {
        assert!((w.sky_gradient[c] - 0.8).abs() < 0.1, "gradient {} for 0.8", w.sky_gradient);
        assert!((w.radiance[c] / 5.0 - 1.0).abs() < 0.05, "radiance {} for 5", w.radiance);
    }
}

#[test]
fn a_uniform_window_is_left_as_it_was() {
    let (truth, photo) = room_with_window(0.0);
    let mut s = truth.clone();
    let found =
        fit_window_skies(&mut CpuBackend, &mut s, &["window".into()], &photo, &[], &WindowSkyOptions::default())
            .unwrap();
    eprintln!("{found:?}");
    assert!(!found.kept, "{found:?}");
    psdr::scene::same_scene(&s, &truth).expect("the scene is left untouched");
    assert!(found.sky_gradient[0].iter().all(|g| g.abs() < 0.1), "{found:?}");
}
