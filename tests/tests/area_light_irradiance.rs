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
    let origin = cam.origin.as_dvec3();
    let (right, upv, fwd) = (cam.right().as_dvec3(), cam.up.as_dvec3(), cam.forward.as_dvec3());
    let n = 65536;
    let mut worst: f64 = 0.0;
    for py in 0..h {
        for px in 0..w {
            // Expected: mean of a/pi E over the pixel footprint on the floor (y = 0).
            let mut expected = 0.0;
            let sub = 16;
            for j in 0..sub {
                for i in 0..sub {
                    let xs = px as f64 + (i as f64 + 0.5) / sub as f64;
                    let ys = py as f64 + (j as f64 + 0.5) / sub as f64;
                    let c = pinhole_dir_camera_space(&cam, xs, ys);
                    let dir = right * c[0] + upv * c[1] + fwd * c[2];
                    assert!(dir.y < 0.0, "pixel ({px}, {py}) must see the floor");
                    let hit = origin + dir * (-origin.y / dir.y);
                    assert!(hit.x.abs() < 10.0 && hit.z.abs() < 10.0);
                    expected += ALBEDO as f64 / std::f64::consts::PI * polygon_irradiance(hit, DVec3::Y, &corners);
                }
            }
            expected /= (sub * sub) as f64;
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
