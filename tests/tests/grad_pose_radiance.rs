//! Radiance gradients with respect to object poses against central finite differences: an object seen against
//! the background (primary boundary and interior), an occluder casting a shadow it does not see itself
//! (direct boundary), an occluder seen only through a bounce (indirect boundary), an occluder whose shadow the
//! camera sees directly and after a bounce off the occluder itself, and the room case of a
//! flat-shaded coloured cube resting on (and lifted off) the floor under a ceiling light.
//! Bound: see grad_common (4 combined standard errors over R seeds).

mod grad_common;

use grad_common::scenes::{
    box_in_the_dark, indirect_scene, room_with_cube, shadow_scene, shadow_seen_off_the_occluder,
};
use grad_common::{ad, check, check_components, fd};
use psdr::grad::{AdOptions, ImageLoss, Output};
use psdr::render::{render_cpu, SceneData};

const OPTS: AdOptions = AdOptions { replicas: 10, edge_samples: 1 << 16, secondary_edge_samples: 1 };

fn mean_radiance() -> ImageLoss {
    ImageLoss::Mean(Output::Radiance)
}

#[test]
fn object_against_background_translation_yaw_rotation_scale() {
    let s = box_in_the_dark();
    check(&s, "object/box/translation", &mean_radiance(), 0.01, OPTS);
    check(&s, "object/box/yaw", &mean_radiance(), 0.01, OPTS);
    check(&s, "object/box/rotation", &mean_radiance(), 0.01, OPTS);
    check(&s, "object/box/scale", &mean_radiance(), 0.01, OPTS);
}

#[test]
fn shadow_of_an_unseen_occluder() {
    let s = shadow_scene(2);
    let (a, f) = check(&s, "object/blocker/translation", &mean_radiance(), 0.01, OPTS);
    assert!(f.mean[0].abs() > 5.0 * f.std_err[0], "the shadow must move measurably: FD {:?}", f.mean);
    // Without boundary terms the (zero) interior term alone fails the same check: they matter.
    let off = ad(&s, "object/blocker/translation", &mean_radiance(), AdOptions { secondary_edge_samples: 0, ..OPTS });
    assert_eq!(off.mean, vec![0.0; 3], "the occluder is on no camera path: interior must be exactly zero");
    assert!((off.mean[0] - f.mean[0]).abs() > 5.0 * f.std_err[0] && a.mean[0] != 0.0);
}

#[test]
fn occluder_seen_only_through_a_bounce() {
    let s = indirect_scene();
    let (_, f) = check(&s, "object/blocker/translation", &mean_radiance(), 0.02, OPTS);
    assert!(f.mean[2].abs() > 4.0 * f.std_err[2], "the bounce must carry a measurable gradient: FD {:?}", f.mean);
}

/// The occluder seen by the camera: its shadow reaches the image directly and after a bounce off its own
/// faces, both sampled from the light (boundary/shadow.rs, the bounce's vertices sliding with the box).
#[test]
fn shadow_seen_after_a_bounce_off_the_moving_occluder() {
    let mut s = shadow_seen_off_the_occluder();
    s.settings.spp = 256;
    // Vertical motion is mostly the box top's silhouette (primary boundary, checked above); x and z slide the
    // shadows.
    check_components(&s, "object/blocker/translation", &mean_radiance(), 0.01, OPTS, &[0, 2]);
    check(&s, "object/blocker/yaw", &mean_radiance(), 0.01, OPTS);
}

/// A ceiling light moved along the ceiling and resized, as the material stage's joint fit moves lights
/// (`light_pose_params`): L2 to a target lit by the light 0.3 m to the side and 1.2x as large. The light is
/// sampled on its own surface, so its points move with it (interior term); its edges move the cube's shadow.
#[test]
fn a_ceiling_light_moved_along_the_ceiling_and_resized() {
    let s = room_with_cube(0.0);
    let light = s.object_index("light").unwrap();
    let mut target = s.clone();
    target.objects[light].pose.translation.x += 0.3;
    target.objects[light].pose.scale *= glam::Vec3::new(1.2, 1.2, 1.0);
    target.settings.spp = 256;
    let t = render_cpu(&SceneData::build(&target).unwrap(), &target.settings, &|_, _| {});
    let loss = ImageLoss::L2To { output: Output::Radiance, target: t.radiance };
    // In the ceiling's plane (x, z; y would push it through the ceiling) and in its own plane (scale x, y).
    let (a, f) = check_components(&s, "object/light/translation", &loss, 0.01, OPTS, &[0, 2]);
    assert!(a.mean[0] < 0.0 && f.mean[0].abs() > 4.0 * f.std_err[0], "toward the target: {:?} {:?}", a.mean, f.mean);
    let (a, _) = check_components(&s, "object/light/scale", &loss, 0.01, OPTS, &[0, 1]);
    assert!(a.mean[0] < 0.0 && a.mean[1] < 0.0, "growing toward the target lowers the loss: {:?}", a.mean);
}

/// The same light with its radiance shaped by direction (a sky gradient, per channel: 1 + g d_y for a ray
/// travelling in direction d, here up to 1.9x in blue at the zenith), moved along the ceiling: the shape
/// depends on the direction only, which the ray form holds fixed, so the interior and boundary terms need
/// nothing new; finite differences check that.
#[test]
fn a_ceiling_light_with_a_sky_gradient_moved_along_the_ceiling() {
    let mut s = room_with_cube(0.0);
    let light = s.object_index("light").unwrap();
    s.objects[light].emitter.as_mut().unwrap().sky_gradient = glam::Vec3::new(0.3, -0.5, 0.9);
    let mut target = s.clone();
    target.objects[light].pose.translation.x += 0.3;
    target.settings.spp = 256;
    let t = render_cpu(&SceneData::build(&target).unwrap(), &target.settings, &|_, _| {});
    let loss = ImageLoss::L2To { output: Output::Radiance, target: t.radiance };
    let (a, f) = check_components(&s, "object/light/translation", &loss, 0.01, OPTS, &[0, 2]);
    assert!(a.mean[0] < 0.0 && f.mean[0].abs() > 4.0 * f.std_err[0], "toward the target: {:?} {:?}", a.mean, f.mean);
}

/// The room case: L2 to a target with the cube moved, translation along the floor.
#[test]
fn cube_on_the_floor_and_lifted() {
    for lift in [0.0, 0.05] {
        let s = room_with_cube(lift);
        let mut target = s.clone();
        target.objects[1].pose.translation.x += 0.05;
        target.settings.spp = 256;
        let t = render_cpu(&SceneData::build(&target).unwrap(), &target.settings, &|_, _| {});
        let loss = ImageLoss::L2To { output: Output::Radiance, target: t.radiance };
        let (a, _) = check(&s, "object/cube/translation", &loss, 0.01, OPTS);
        assert!(a.mean[0] < 0.0, "moving toward the target must lower the loss: {:?}", a.mean);
        // The loss of the primal renders the adjoints came from, for the optimiser.
        let first = render_cpu(&SceneData::build(&s).unwrap(), &s.settings, &|_, _| {});
        let l = a.loss.expect("an L2 loss renders its primal");
        assert!(l > 0.0 && (l / loss.eval(&first).unwrap() - 1.0).abs() < 0.2, "loss {l}");
    }
}

/// A cube centred under the light and in front of a centred camera: the x gradient of the mean radiance is
/// zero by mirror symmetry (within the bound), while y is not.
#[test]
fn symmetric_configuration_has_zero_sideways_gradient() {
    let mut s = room_with_cube(0.0);
    s.objects[1].pose.rotation = glam::Quat::IDENTITY;
    s.camera = psdr::scene::Camera::look_at(
        glam::Vec3::new(0.0, 1.3, 2.2),
        glam::Vec3::new(0.0, 0.3, 0.0),
        glam::Vec3::Y,
        45.0,
        48,
        36,
    );
    let a = ad(&s, "object/cube/translation", &mean_radiance(), OPTS);
    assert!(a.mean[0].abs() <= 4.0 * a.std_err[0], "x: {} ± {}", a.mean[0], a.std_err[0]);
    assert!(a.mean[1].abs() > 4.0 * a.std_err[1], "y: {} ± {}", a.mean[1], a.std_err[1]);
}

/// Degenerate input: a cube that pokes through a wall and shares a face plane with the floor, plus a
/// zero-area triangle in the moving mesh: gradients stay finite.
#[test]
fn degenerate_configurations_give_finite_gradients() {
    let mut s = room_with_cube(-0.25);
    s.objects[1].pose.translation.x = 1.9; // through the x = 2 wall, bottom face on the floor
    let part = &mut s.objects[1].parts[0];
    let v = part.positions[0];
    part.positions.extend([v, v, v]);
    let n = part.positions.len() as u32;
    part.indices.push([n - 3, n - 2, n - 1]);
    if let Some(uvs) = part.uvs.as_mut() {
        uvs.extend([glam::Vec2::ZERO; 3]);
    }
    let a = ad(&s, "object/cube/translation", &mean_radiance(), AdOptions { replicas: 2, ..OPTS });
    assert!(a.mean.iter().all(|g| g.is_finite()), "{:?}", a.mean);
    let f = fd(&s, "object/cube/translation", &mean_radiance(), 0.01, 2);
    assert!(f.mean.iter().all(|g| g.is_finite()));
}

/// The box with a bumpy tangent-space normal map (8x8 texels, tilts up to ~10°): its shading normals turn with
/// the box and slide over its faces with the hit points, and the lamp straddles the horizon of its front face
/// (horizon boundary). The box only turns about the vertical and no visible face is seen within 10° of grazing:
/// there the renderer turns shading normals that face away toward the viewer (README, "Terminator"), which keeps
/// the integrand continuous (no boundary term is missing) but not smooth, and central differences across the
/// turn's kink need small steps and many seeds (`normal_mapped_face_near_grazing` covers it).
#[test]
fn normal_mapped_object_translation_and_rotation() {
    let mut s = box_in_the_dark();
    s.objects[0].pose.rotation = glam::Quat::from_rotation_y(30f32.to_radians());
    s.objects[0].pose.translation.y = 0.0;
    let (w, h) = (8u32, 8u32);
    let mut texels = vec![];
    for y in 0..h {
        for x in 0..w {
            let (a, b) = (x as f32 / w as f32 * std::f32::consts::TAU, y as f32 / h as f32 * std::f32::consts::TAU);
            let n = glam::Vec3::new(0.12 * a.sin(), 0.12 * b.cos(), 1.0).normalize();
            texels.extend((n * 0.5 + glam::Vec3::splat(0.5)).to_array());
        }
    }
    s.textures.push(psdr::scene::Texture { path: None, width: w, height: h, channels: 3, texels });
    let red = s.material_index("red").unwrap();
    s.materials[red].normal_map = Some(s.textures.len() - 1);
    check(&s, "object/box/translation", &mean_radiance(), 0.005, OPTS);
    check(&s, "object/box/rotation", &mean_radiance(), 0.005, OPTS);
}

/// The box with a constant 19° normal-map tilt, its top face seen near grazing: there the mapped normal faces
/// away from the camera and `surface_point` turns it toward the viewer (cosine 0.01), which keeps the BSDF
/// continuous in the view direction, so no boundary term is missing. The turn is continuous but not smooth,
/// and the rotated loss has a |h|·h term: FD at h = 0.002, 0.005, 0.01 gives 3.09e-4, 3.49e-4, 4.05e-4 for
/// rotation x (AD 3.10e-4), hence the small step and more seeds.
#[test]
fn normal_mapped_face_near_grazing() {
    let mut s = box_in_the_dark();
    let n = glam::Vec3::new(0.35, 0.0, 1.0).normalize();
    let texels: Vec<f32> = (0..4).flat_map(|_| (n * 0.5 + glam::Vec3::splat(0.5)).to_array()).collect();
    s.textures.push(psdr::scene::Texture { path: None, width: 2, height: 2, channels: 3, texels });
    let red = s.material_index("red").unwrap();
    s.materials[red].normal_map = Some(s.textures.len() - 1);
    check(&s, "object/box/rotation", &mean_radiance(), 0.002, AdOptions { replicas: 20, ..OPTS });
}
