//! Gradients with respect to whole-mesh vertex positions (`object/NAME/vertices`, welded vertices in object
//! space) for radiance, depth and masks, checked two independent ways:
//! - an exact invariant: moving every vertex by the same object-space offset is a translation, so for any loss
//!   Σ_k dL/dv_k = (R S)ᵀ dL/dT, where T is the object's translation and R S its linear pose. With the same
//!   seeds both sides sample the same paths and edge points, so they agree to float rounding (relative 1e-3);
//!   this checks that every term (interior, primary, direct and indirect boundary, depth interior) hands each
//!   vertex its share;
//! - central finite differences for single vertices, within 4 combined standard errors over R seeds (see
//!   grad_common: a correct implementation fails one comparison with probability < 0.3 %). Where a moved
//!   corner folds a quad whose plane passes through lit, visible points (faces seen edge-on from the floor), the
//!   loss has a |h|·h term and central differences a first-order bias; there FD(h) is extrapolated to h = 0 as
//!   2 FD(h) − FD(2h) (standard error combined as if independent, which overstates it: both use the same seeds).

mod grad_common;

use glam::{Mat3, Vec3};
use grad_common::scenes::{box_in_the_dark, room_with_cube, shadow_scene};
use grad_common::{ad, check_components};
use psdr::grad::{central_difference, AdOptions, FdOptions, ImageLoss, Output, ParamPath};
use psdr::render::{render_cpu, SceneData};
use psdr::scene::{weld, Scene};

const OPTS: AdOptions = AdOptions { replicas: 10, edge_samples: 1 << 16, secondary_edge_samples: 1 };

/// Welded vertex ids of object `o` sorted by `key` of their world positions, largest first.
fn vertices_by(s: &Scene, o: usize, key: impl Fn(Vec3) -> f32) -> Vec<usize> {
    let m = s.objects[o].pose.matrix();
    let world: Vec<Vec3> = weld(&s.objects[o]).positions.iter().map(|&p| m.transform_point3(p)).collect();
    let mut ids: Vec<usize> = (0..world.len()).collect();
    ids.sort_by(|&a, &b| key(world[b]).total_cmp(&key(world[a])));
    ids
}

/// The components (3 per vertex) of the given welded vertices.
fn components(vertices: &[usize]) -> Vec<usize> {
    vertices.iter().flat_map(|&v| [3 * v, 3 * v + 1, 3 * v + 2]).collect()
}

/// Σ_k dL/dv_k against (R S)ᵀ dL/dT, one replica, same seeds.
fn assert_vertices_sum_to_translation(s: &Scene, name: &str, loss: &ImageLoss, opts: AdOptions) {
    let o = s.object_index(name).unwrap();
    let opts = AdOptions { replicas: 1, ..opts };
    let gv = ad(s, &format!("object/{name}/vertices"), loss, opts).mean;
    let gt = ad(s, &format!("object/{name}/translation"), loss, opts).mean;
    let pose = s.objects[o].pose;
    let rs = Mat3::from_quat(pose.rotation) * Mat3::from_diagonal(pose.scale);
    let want = rs.transpose() * Vec3::new(gt[0] as f32, gt[1] as f32, gt[2] as f32);
    let mut sum = [0.0f64; 3];
    gv.chunks_exact(3).for_each(|g| (0..3).for_each(|a| sum[a] += g[a]));
    eprintln!("{name} {:?}: Σ dL/dv = {sum:?}, (RS)ᵀ dL/dT = {want}", loss.output());
    let scale = want.abs().max_element().max(1e-12) as f64;
    for a in 0..3 {
        assert!(gv.iter().all(|g| g.is_finite()));
        assert!((sum[a] - want[a] as f64).abs() <= 1e-3 * scale, "axis {a}: {} vs {}", sum[a], want[a]);
    }
    assert!(want.length() > 0.0, "the invariant must not hold trivially");
}

#[test]
fn vertex_gradients_sum_to_the_translation_gradient() {
    let room = room_with_cube(0.0);
    // Radiance with every term on: interior, primary, direct and indirect boundaries.
    assert_vertices_sum_to_translation(&room, "cube", &ImageLoss::Mean(Output::Radiance), OPTS);
    let shadow = shadow_scene(3);
    assert_vertices_sum_to_translation(&shadow, "blocker", &ImageLoss::Mean(Output::Radiance), OPTS);
    let dark = box_in_the_dark();
    for output in [Output::Depth, Output::Mask(0)] {
        assert_vertices_sum_to_translation(&dark, "box", &ImageLoss::Mean(output), OPTS);
    }
}

/// The two corners nearest the camera of a box seen against the background: their silhouette edges, the
/// creases between its faces and the shading of the faces they tilt.
#[test]
fn box_corners_match_finite_differences() {
    let s = box_in_the_dark();
    let near = vertices_by(&s, 0, |p| p.z);
    let comps = components(&near[..2]);
    check_components(&s, "object/box/vertices", &ImageLoss::Mean(Output::Radiance), 0.01, OPTS, &comps);
    let aov = AdOptions { edge_samples: 1 << 17, secondary_edge_samples: 0, ..OPTS };
    for output in [Output::Depth, Output::Mask(0)] {
        check_components(&s, "object/box/vertices", &ImageLoss::Mean(output), 0.01, aov, &comps);
    }
}

/// AD against FD extrapolated to zero step (see the header) for the listed components; returns the FD means.
fn check_extrapolated(s: &Scene, path: &str, loss: &ImageLoss, h: f32, comps: &[usize]) -> Vec<f64> {
    let a = ad(s, path, loss, OPTS);
    let p: ParamPath = path.parse().unwrap();
    let at = |step| {
        let opts = FdOptions { step, replicas: OPTS.replicas, components: comps.to_vec() };
        central_difference(s, &p, loss, &opts, psdr_tests::fd_backend().as_mut()).unwrap()
    };
    let (f1, f2) = (at(h), at(2.0 * h));
    let mut out = vec![];
    for (k, &c) in comps.iter().enumerate() {
        let f = 2.0 * f1.mean[k] - f2.mean[k];
        let se = (4.0 * f1.std_err[k].powi(2) + f2.std_err[k].powi(2)).sqrt();
        let bound = 4.0 * (a.std_err[c].powi(2) + se.powi(2)).sqrt();
        eprintln!(
            "{path}[{c}]: AD {:+.4e} ± {:.1e}, FD(h→0) {f:+.4e} ± {se:.1e} (FD(h) {:+.4e}, FD(2h) {:+.4e}; bound {bound:.1e})",
            a.mean[c], a.std_err[c], f1.mean[k], f2.mean[k]
        );
        assert!((a.mean[c] - f).abs() <= bound, "{path}[{c}]: AD {} vs extrapolated FD {f}", a.mean[c]);
        out.push(f);
    }
    out
}

/// A lower corner of an occluder that the camera never sees: only the shadow moves (direct boundary). The
/// blocker's side faces are vertical, so floor points below it see them edge-on (measured: FD 0.0103, 0.0111,
/// 0.0123 at h = 0.003, 0.01, 0.02 for x, linear toward 0.0098 at h = 0; AD 0.00995).
#[test]
fn occluder_corner_moves_its_shadow() {
    let s = shadow_scene(2);
    let low = vertices_by(&s, 1, |p| -p.y - p.x);
    let f = check_extrapolated(
        &s,
        "object/blocker/vertices",
        &ImageLoss::Mean(Output::Radiance),
        0.005,
        &components(&low[..1]),
    );
    assert!(f[0].abs() > 1e-3, "the shadow must move measurably: FD {f:?}");
}

/// The room case: a top corner of the flat-shaded cube resting on the floor, L2 to the image with that corner
/// raised; the cube's faces tilt, creases and shadows move, the contact edges stay.
#[test]
fn cube_top_corner_in_the_room() {
    let s = room_with_cube(0.0);
    let top = vertices_by(&s, 1, |p| p.y + p.z);
    let mut target = s.clone();
    let path = "object/cube/vertices".parse::<ParamPath>().unwrap();
    let mut v = path.get(&target).unwrap();
    v[3 * top[0] + 1] += 0.05;
    path.set(&mut target, &v).unwrap();
    target.settings.spp = 256;
    let t = render_cpu(&SceneData::build(&target).unwrap(), &target.settings, &|_, _| {});
    let loss = ImageLoss::L2To { output: Output::Radiance, target: t.radiance };
    // The cube's vertical faces are seen edge-on from the floor along the contact edges.
    let f = check_extrapolated(&s, "object/cube/vertices", &loss, 0.005, &components(&top[..1]));
    assert!(f[1] < 0.0, "raising the corner toward the target must lower the loss: {f:?}");
}

/// Gradients are sums over blocks of pixels and edge samples fixed independently of the thread count, so every
/// term (interior, primary and secondary boundaries, material sweep) is bit-identical on 1, 2 and 3
/// threads.
#[test]
fn gradients_are_identical_on_any_thread_count() {
    let mut s = room_with_cube(0.0);
    s.camera.width = 24;
    s.camera.height = 18;
    s.settings.spp = 4;
    let opts = AdOptions { replicas: 1, edge_samples: 1 << 12, secondary_edge_samples: 1 };
    let run = |threads| {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| {
            ["object/cube/vertices", "object/cube/rotation", "material/wall/albedo"]
                .map(|p| ad(&s, p, &ImageLoss::Mean(Output::Radiance), opts).mean)
        })
    };
    let one = run(1);
    assert!(one.iter().flatten().any(|g| *g != 0.0));
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
}
