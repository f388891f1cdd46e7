//! Direct lighting from a rectangular area light onto a Lambertian floor against the closed-form irradiance of a
//! polygonal Lambertian emitter (Lambert 1760; e.g. Arvo 1995, eq. 4):
//!
//!     E(x) = Le / 2 * | sum_i  theta_i  (n . u_i) |,   u_i = unit(r_i x r_{i+1}),  theta_i = angle(r_i, r_{i+1}),
//!
//! with r_i the unit vectors from x to the polygon's corners. The floor (albedo a, specular 0) then reflects
//! L = a / pi * E. With max_depth = 2 (Mitsuba convention: direct lighting only) a pixel's expectation is the
//! mean of L over its footprint, computed here with a 16 x 16 midpoint rule through an independently written
//! pinhole model (relative error < 1e-5 for this smooth E, well inside the bound below).
//!
//! Bound: per pixel, N = 65536 samples from the path-tracing kernel; |mean - expected| <= 5 sqrt(var / N) with var
//! the per-sample variance (normal approximation; 5 sigma: 6e-7 per pixel, < 3e-5 over the 48 pixels), plus
//! 1e-4 relative for quadrature and f32 rounding. Every bound is also asserted to be under 2 % of the value, so a
//! missing cosine, a pi or an MIS weight error cannot hide inside it.

use glam::{DVec3, Quat, Vec3};
use psdr::render::SceneData;
use psdr::scene::{rectangle_mesh, Camera, Pose, RenderSettings};
use psdr_tests::*;

const LE: f32 = 5.0;
const ALBEDO: f32 = 0.6;
/// Light: w x h rectangle centred at (cx, H, cz), facing down.
const LW: f64 = 1.0;
const LH: f64 = 0.6;
const CX: f64 = 0.3;
const CZ: f64 = -0.2;
const H: f64 = 1.5;

/// Mean of `f` over the floor points (y = 0) that pixel (px, py)'s footprint sees, by a sub x sub midpoint
/// rule through an independently written pinhole model.
fn footprint_mean(cam: &Camera, px: u32, py: u32, sub: u32, mut f: impl FnMut(DVec3) -> DVec3) -> DVec3 {
    let origin = cam.origin.as_dvec3();
    let (right, upv, fwd) = (cam.right().as_dvec3(), cam.up.as_dvec3(), cam.forward.as_dvec3());
    let mut sum = DVec3::ZERO;
    for j in 0..sub {
        for i in 0..sub {
            let xs = px as f64 + (i as f64 + 0.5) / sub as f64;
            let ys = py as f64 + (j as f64 + 0.5) / sub as f64;
            let c = pinhole_dir_camera_space(cam, xs, ys);
            let dir = right * c[0] + upv * c[1] + fwd * c[2];
            assert!(dir.y < 0.0, "pixel ({px}, {py}) must see the floor");
            sum += f(origin + dir * (-origin.y / dir.y));
        }
    }
    sum / (sub * sub) as f64
}

fn polygon_irradiance(x: DVec3, n: DVec3, corners: &[DVec3]) -> f64 {
    let mut sum = 0.0;
    for i in 0..corners.len() {
        let a = (corners[i] - x).normalize();
        let b = (corners[(i + 1) % corners.len()] - x).normalize();
        let theta = a.dot(b).clamp(-1.0, 1.0).acos();
        sum += theta * n.dot(a.cross(b).normalize());
    }
    LE as f64 * 0.5 * sum.abs()
}

#[test]
fn direct_light_on_a_lambertian_floor_matches_the_polygon_formula() {
    let (w, h) = (8u32, 6u32);
    let cam = Camera::look_at(Vec3::new(0.3, 1.2, 1.6), Vec3::new(0.3, 0.0, -0.2), Vec3::Y, 40.0, w, h);
    let settings = RenderSettings { spp: 1, max_depth: 2, rr_depth: 100, seed: 3 };
    let mut sc = empty_scene(cam.clone(), settings.clone());
    let floor_m = add_material(&mut sc, lambert("floor", Vec3::splat(ALBEDO)));
    let housing = add_material(&mut sc, lambert("housing", Vec3::splat(0.5)));
    let down = Quat::from_rotation_x(std::f32::consts::FRAC_PI_2);
    let up = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    add_object(&mut sc, "floor", rectangle_mesh(20.0, 20.0), floor_m, Pose { rotation: up, ..Pose::default() }, None);
    let light_pose = Pose { translation: Vec3::new(CX as f32, H as f32, CZ as f32), rotation: down, ..Pose::default() };
    add_object(&mut sc, "light", rectangle_mesh(LW as f32, LH as f32), housing, light_pose, emitter(Vec3::splat(LE)));
    let d = SceneData::build(&sc).unwrap();

    let corners: Vec<DVec3> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .iter()
        .map(|&(sx, sz)| DVec3::new(CX + sx * LW / 2.0, H, CZ + sz * LH / 2.0))
        .collect();
    let n = 65536;
    let mut worst: f64 = 0.0;
    for py in 0..h {
        for px in 0..w {
            // Expected: mean of a/pi E over the pixel footprint on the floor (y = 0).
            let expected = footprint_mean(&cam, px, py, 16, |hit| {
                assert!(hit.x.abs() < 10.0 && hit.z.abs() < 10.0);
                DVec3::splat(ALBEDO as f64 / std::f64::consts::PI * polygon_irradiance(hit, DVec3::Y, &corners))
            })
            .x;
            let (mean, var) = pixel_samples(&d, &settings, px, py, n);
            let se = (var.x as f64 / n as f64).sqrt();
            let bound = 5.0 * se + 1e-4 * expected;
            let err = (mean.x as f64 - expected).abs();
            worst = worst.max(err / bound);
            assert!((mean.x - mean.y).abs() < 1e-6 && (mean.x - mean.z).abs() < 1e-6, "grey in, grey out");
            assert!(bound < 0.02 * expected, "pixel ({px}, {py}): bound {bound} too loose for {expected}");
            assert!(
                err <= bound,
                "pixel ({px}, {py}): rendered {} vs closed form {expected} (|err| {err:.3e} > bound {bound:.3e})",
                mean.x
            );
        }
    }
    eprintln!("worst |err| / bound over {} pixels: {worst:.3}", w * h);
}

/// A window (an emitter on a wall, facing into the room) whose radiance grows toward the sky: a ray travelling
/// in direction d sees Le (1 + g d_y), g per channel (`Emitter::sky_gradient`), here 0.8, 0 and -0.6. No
/// closed form is at hand for the direction-weighted integral, so the truth is a midpoint rule over the
/// window, E(x) = sum Le (1 + g d_y) cos_x cos_y / r^2 dA (128 x 128 cells; checked against the polygon
/// formula above for g = 0 within 2e-5 relative at every point used, so its error is far below the bound), and
/// over each pixel's footprint (8 x 8). The floor points lie 0.3-1.7 m in front of the window, below it: every
/// ray to it travels up (d_y 0.2-0.9), so the three channels differ by up to a factor 1.8 / 0.46 and a shape
/// applied with the wrong sign or left out misses by 15 % or more. Bound as above, per channel.
#[test]
fn a_windows_sky_gradient_matches_quadrature_over_the_window() {
    const WX: f64 = 0.3; // window centre (x, y) on the wall z = WZ, size LW x LH
    const WY: f64 = 1.0;
    const WZ: f64 = -1.0;
    let g = DVec3::new(0.8, 0.0, -0.6);
    let (w, h) = (8u32, 6u32);
    let cam = Camera::look_at(Vec3::new(0.3, 1.5, 1.0), Vec3::new(0.3, 0.0, 0.2), Vec3::Y, 40.0, w, h);
    let settings = RenderSettings { spp: 1, max_depth: 2, rr_depth: 100, seed: 5 };
    let mut sc = empty_scene(cam.clone(), settings.clone());
    let floor_m = add_material(&mut sc, lambert("floor", Vec3::splat(ALBEDO)));
    let frame = add_material(&mut sc, lambert("frame", Vec3::splat(0.5)));
    let up = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    add_object(&mut sc, "floor", rectangle_mesh(20.0, 20.0), floor_m, Pose { rotation: up, ..Pose::default() }, None);
    let pose = Pose { translation: Vec3::new(WX as f32, WY as f32, WZ as f32), ..Pose::default() };
    let mut window = emitter(Vec3::splat(LE)).unwrap();
    window.sky_gradient = g.as_vec3();
    add_object(&mut sc, "window", rectangle_mesh(LW as f32, LH as f32), frame, pose, Some(window));
    let d = SceneData::build(&sc).unwrap();

    let cells = 128;
    let irradiance = |x: DVec3, g: DVec3| -> DVec3 {
        let mut e = DVec3::ZERO;
        let da = LW * LH / (cells * cells) as f64;
        for j in 0..cells {
            for i in 0..cells {
                let y = DVec3::new(
                    WX + LW * ((i as f64 + 0.5) / cells as f64 - 0.5),
                    WY + LH * ((j as f64 + 0.5) / cells as f64 - 0.5),
                    WZ,
                );
                let r = y - x;
                let r2 = r.length_squared();
                let dir = r / r2.sqrt();
                let (cos_x, cos_y) = (dir.y, dir.z.abs()); // floor normal +y, window normal +z
                e += LE as f64 * (DVec3::ONE + g * dir.y) * (cos_x * cos_y / r2 * da);
            }
        }
        e
    };
    let corners: Vec<DVec3> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .iter()
        .map(|&(sx, sy)| DVec3::new(WX + sx * LW / 2.0, WY + sy * LH / 2.0, WZ))
        .collect();
    let n = 65536;
    let mut worst: f64 = 0.0;
    for py in 0..h {
        for px in 0..w {
            let expected = footprint_mean(&cam, px, py, 8, |hit| {
                assert!(hit.z > WZ + 0.25 && hit.z < WZ + 1.9, "pixel ({px}, {py}): floor point {hit}");
                let uniform = polygon_irradiance(hit, DVec3::Y, &corners);
                let e0 = irradiance(hit, DVec3::ZERO).x;
                assert!((e0 - uniform).abs() < 2e-5 * uniform, "quadrature {e0} vs polygon formula {uniform}");
                ALBEDO as f64 / std::f64::consts::PI * irradiance(hit, g)
            });
            let (mean, var) = pixel_samples(&d, &settings, px, py, n);
            for c in 0..3 {
                let se = (var[c] as f64 / n as f64).sqrt();
                let bound = 5.0 * se + 1e-4 * expected[c];
                let err = (mean[c] as f64 - expected[c]).abs();
                worst = worst.max(err / bound);
                assert!(bound < 0.02 * expected[c], "pixel ({px}, {py}) channel {c}: bound {bound} too loose");
                assert!(
                    err <= bound,
                    "pixel ({px}, {py}) channel {c}: rendered {} vs quadrature {} (|err| {err:.3e} > bound {bound:.3e})",
                    mean[c],
                    expected[c]
                );
            }
        }
    }
    eprintln!("worst |err| / bound over {} pixels x 3 channels: {worst:.3}", w * h);
}
