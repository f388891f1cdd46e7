//! Depth, coverage-mask and id AOVs against geometry known exactly in camera space.
//!
//! The camera sits at the origin looking down -z (camera space = world space with z negated), so a plane and a
//! square can be placed at exact screen positions with an independently written pinhole model.
//!
//! - Depth is the pixel mean of the camera-space z of the primary hits. For a plane facing the camera at
//!   distance Z it is Z in every pixel; for a tilted plane each sample's z is c / (n . d) for its jittered ray d,
//!   so the pixel mean is computed from the same jitter (the sampler's DIM_PIXEL_X / DIM_PIXEL_Y values). Both
//!   must agree to 1e-5 relative (f32 ray-plane intersection).
//! - The coverage mask of a screen-space square with edges at known sub-pixel positions: pixels entirely inside
//!   are exactly 1 and pixels entirely outside exactly 0. In the edge pixels the mask is the fraction of samples
//!   whose jittered position falls in the square: it must equal that count predicted from the jitter (samples
//!   within 1e-4 px of an edge may go either way), and it must match the pixel's area fraction f within the
//!   binomial bound 5 sqrt(f (1 - f) / spp) + 1 / spp (spp = 256; 5 sigma plus one sample of discreteness).
//! - The id AOV is the object under the pixel centre: exact.

use glam::{Quat, Vec2, Vec3};
use psdr::render::sampler::{sample_1d, DIM_PIXEL_X, DIM_PIXEL_Y};
use psdr::scene::{rectangle_mesh, Camera, Pose, RenderSettings, Scene};
use psdr_tests::*;

const W: u32 = 32;
const H: u32 = 24;
const SPP: u32 = 256;
const SEED: u32 = 17;

fn camera() -> Camera {
    Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), Vec3::Y, 50.0, W, H)
}

fn scene() -> Scene {
    let settings = RenderSettings { spp: SPP, max_depth: 1, rr_depth: 100, seed: SEED };
    let mut sc = empty_scene(camera(), settings);
    add_material(&mut sc, lambert("grey", Vec3::splat(0.5)));
    sc
}

/// Jittered image position of sample k of pixel (px, py).
fn jitter(px: u32, py: u32, k: u32) -> (f64, f64) {
    let pixel = py * W + px;
    (
        px as f64 + sample_1d(SEED, pixel, k, DIM_PIXEL_X) as f64,
        py as f64 + sample_1d(SEED, pixel, k, DIM_PIXEL_Y) as f64,
    )
}

#[test]
fn depth_of_a_fronto_parallel_plane_is_exact() {
    let z = 3.25f32;
    let mut sc = scene();
    let pose = Pose { translation: Vec3::new(0.0, 0.0, -z), ..Pose::default() };
    add_object(&mut sc, "wall", rectangle_mesh(100.0, 100.0), 0, pose, None);
    let f = render(&sc);
    for (i, &d) in f.depth.iter().enumerate() {
        assert!(((d - z) / z).abs() < 1e-5, "pixel {i}: depth {d} vs {z}");
        assert_eq!(f.coverage[i], 1.0);
        assert_eq!(f.object_id[i], 0);
    }
}

#[test]
fn depth_of_a_tilted_plane_is_the_mean_of_exact_per_sample_depths() {
    // Plane through (0, 0, -4) with world normal tilted 35 degrees about y and 20 about x.
    let rot = Quat::from_rotation_y(35f32.to_radians()) * Quat::from_rotation_x(20f32.to_radians());
    let p0 = Vec3::new(0.0, 0.0, -4.0);
    let mut sc = scene();
    add_object(
        &mut sc,
        "tilted",
        rectangle_mesh(200.0, 200.0),
        0,
        Pose { translation: p0, rotation: rot, ..Pose::default() },
        None,
    );
    let f = render(&sc);
    let cam = camera();
    // Camera space (x right, y up, z forward) = world (x, y, -z) for this camera.
    let nw = (rot * Vec3::Z).as_dvec3();
    let n = [nw.x, nw.y, -nw.z];
    let c = nw.dot(p0.as_dvec3());
    let mut worst: f64 = 0.0;
    for py in 0..H {
        for px in 0..W {
            let mut mean = 0.0;
            for k in 0..SPP {
                let (x, y) = jitter(px, py, k);
                let d = pinhole_dir_camera_space(&cam, x, y);
                mean += c / (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]);
            }
            mean /= SPP as f64;
            let got = f.depth[(py * W + px) as usize] as f64;
            let rel = (got - mean).abs() / mean;
            worst = worst.max(rel);
            assert!(rel < 1e-5, "pixel ({px}, {py}): depth {got} vs exact {mean} (rel {rel:.2e})");
        }
    }
    eprintln!("tilted plane: worst relative depth error {worst:.2e}");
}

/// Overlap of [a, a+1] with [lo, hi].
fn overlap(a: f64, lo: f64, hi: f64) -> f64 {
    ((a + 1.0).min(hi) - a.max(lo)).max(0.0)
}

#[test]
fn coverage_mask_of_a_screen_space_square_matches_its_area_fraction() {
    let cam = camera();
    let z = 2.0f64;
    // Square edges in pixels: left, right, top, bottom (sub-pixel positions, none at a pixel centre).
    let (x0, x1, y0, y1) = (5.3f64, 17.75, 4.6, 13.2);
    let corner = |x: f64, y: f64| {
        let d = pinhole_dir_camera_space(&cam, x, y);
        Vec2::new((d[0] * z) as f32, (d[1] * z) as f32)
    };
    let (a, b) = (corner(x0, y1), corner(x1, y0));
    let size = b - a;
    let centre = (a + b) * 0.5;
    let mut sc = scene();
    let pose = Pose { translation: Vec3::new(centre.x, centre.y, -z as f32), ..Pose::default() };
    add_object(&mut sc, "square", rectangle_mesh(size.x, size.y), 0, pose, None);
    let back = Pose { translation: Vec3::new(0.0, 0.0, -6.0), ..Pose::default() };
    add_object(&mut sc, "background", rectangle_mesh(100.0, 100.0), 0, back, None);
    // The square's edges as the renderer's f32 geometry places them, projected back (must be where we put them).
    let check = project_camera_space(&cam, [a.x as f64, a.y as f64, z]);
    assert!((check.x as f64 - x0).abs() < 1e-4 && (check.y as f64 - y1).abs() < 1e-4);

    let f = render(&sc);
    let n = f.object_count as usize;
    let (mut edge_px, mut worst) = (0, 0.0f64);
    for py in 0..H {
        for px in 0..W {
            let p = (py * W + px) as usize;
            let cov = f.coverage[p * n] as f64;
            let frac = overlap(px as f64, x0, x1) * overlap(py as f64, y0, y1);
            assert!((f.coverage[p * n] + f.coverage[p * n + 1] - 1.0).abs() < 1e-6, "pixel ({px}, {py}) covered once");
            if frac == 1.0 || frac == 0.0 {
                assert_eq!(cov, frac, "pixel ({px}, {py}): interior/exterior must be exact");
            } else {
                edge_px += 1;
                // Count predicted from the jitter, with samples within 1e-4 px of an edge ambiguous.
                let (mut sure, mut maybe) = (0u32, 0u32);
                for k in 0..SPP {
                    let (x, y) = jitter(px, py, k);
                    let dist = (x - x0).abs().min((x - x1).abs()).min((y - y0).abs()).min((y - y1).abs());
                    let inside = x > x0 && x < x1 && y > y0 && y < y1;
                    if dist < 1e-4 {
                        maybe += 1;
                    } else if inside {
                        sure += 1;
                    }
                }
                let count = cov * SPP as f64;
                assert!(
                    count >= sure as f64 && count <= (sure + maybe) as f64,
                    "pixel ({px}, {py}): {count} samples covered, jitter predicts {sure} (+{maybe} ambiguous)"
                );
                let bound = 5.0 * (frac * (1.0 - frac) / SPP as f64).sqrt() + 1.0 / SPP as f64;
                worst = worst.max((cov - frac).abs() / bound);
                assert!(
                    (cov - frac).abs() <= bound,
                    "pixel ({px}, {py}): coverage {cov} vs area {frac} (bound {bound})"
                );
            }
            let centre_inside =
                (px as f64 + 0.5) > x0 && (px as f64 + 0.5) < x1 && (py as f64 + 0.5) > y0 && (py as f64 + 0.5) < y1;
            assert_eq!(f.object_id[p], if centre_inside { 0 } else { 1 }, "id at ({px}, {py})");
        }
    }
    assert!(edge_px >= 40, "the square has {edge_px} edge pixels");
    eprintln!("{edge_px} edge pixels, worst |coverage - area| / bound = {worst:.3}");
}
