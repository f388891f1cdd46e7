//! The Vulkan adjoints with respect to poses against their CPU twins, same scene, seed and adjoint images: the
//! depth and mask AOVs (shaders/grad/vjp/aov.comp, `grad::aovs_vjp`), each term separately (the depth's interior
//! term alone, the silhouette boundary alone) and together; the radiance's primary boundary and ray-form
//! interior term (shaders/grad/vjp/radiance_pose.comp, `grad::radiance_primary_boundary`, the interior of
//! `grad::radiance_pose_vjp`); and FD checks run on the device (renders and gradient there).
//!
//! Without a Vulkan device these tests print a note and pass, unless PSDR_REQUIRE_VULKAN=1 (CI sets it).
//!
//! Bounds. Both sides trace the same camera rays (the same sampler, `camera_ray` and BVH traversal, bit-identical
//! on lavapipe, tests/tests/vk_consistency.rs) and sample the same edges from the host's edge list; the
//! velocity fields differ in rounding only (the device evaluates the affine form a + G (x − t), proven equal to
//! the CPU's in velocity.rs's tests), and the device sums each row in f32. So every gradient component agrees
//! within 1e-4 relative (+1e-6 of the largest component absolute). Measured on lavapipe (Mesa 22.3), 30
//! components: depth interior 5.2e-6, silhouettes 2.8e-7, both 1.6e-7. The radiance boundary's two side paths
//! per sample run the integrator on each backend; for direct light (max_depth 2) they agree but for the
//! rounding of the BSDF-sampled direction, so the same bound holds.

use psdr::backend::VkBackend;
use psdr::grad::{aovs_vjp, radiance_primary_boundary, AovAdjoints, ParamPath, PoseLayout};
use psdr::render::SceneData;
use psdr::scene::Scene;
use psdr_tests::SplitMix64;

mod grad_common;

fn vk() -> Option<VkBackend> {
    psdr_tests::vulkan_or_skip(|| VkBackend::new(None))
}

/// The example room with the table lifted off the floor (so its legs' silhouettes are free edges) and every
/// pose component of the table, the chair and the vase.
fn room() -> (Scene, Vec<ParamPath>) {
    let mut s = psdr_tests::example_room(48, 36, 4);
    let t = s.object_index("table").unwrap();
    s.objects[t].pose.translation.y = 0.05;
    let v = s.object_index("vase").unwrap();
    s.objects[v].pose.translation.y += 0.05;
    let mut p = vec![];
    for o in ["table", "chair", "vase"] {
        for c in ["translation", "yaw", "rotation", "scale"] {
            p.push(format!("object/{o}/{c}").parse().unwrap());
        }
    }
    (s, p)
}

fn random_image(n: usize, seed: u64) -> Vec<f32> {
    let mut rng = SplitMix64(seed);
    (0..n).map(|_| rng.next_f32() * 2.0 - 0.5).collect()
}

fn worst_relative(cpu: &[f64], gpu: &[f64]) -> f64 {
    let scale = cpu.iter().map(|g| g.abs()).fold(0.0, f64::max);
    cpu.iter().zip(gpu).map(|(a, b)| (a - b).abs() / (a.abs() + 1e-6 * scale)).fold(0.0, f64::max)
}

/// The worst relative difference over the components at least 1e-3 of the largest, and the worst absolute
/// difference over all of them as a share of the largest: components that cancel to ~1e-8 of the largest (flat
/// faces translated in ray form) carry the backends' f32 rounding, so they are held to the absolute bound.
fn split_worst(cpu: &[f64], gpu: &[f64]) -> (f64, f64) {
    let scale = cpu.iter().map(|g| g.abs()).fold(0.0, f64::max);
    let pairs = || cpu.iter().zip(gpu);
    let worst =
        pairs().filter(|(a, _)| a.abs() >= 1e-3 * scale).map(|(a, b)| (a - b).abs() / a.abs()).fold(0.0, f64::max);
    let worst_abs = pairs().map(|(a, b)| (a - b).abs() / scale).fold(0.0, f64::max);
    (worst, worst_abs)
}

#[test]
fn every_term_agrees_with_the_cpu() {
    let Some(mut vk) = vk() else { return };
    let tol = psdr_tests::device_agreement(&vk);
    let (s, p) = room();
    let d = SceneData::build(&s).unwrap();
    let pose = PoseLayout::new(&s, &p).unwrap();
    let n = 48 * 36;
    let depth = random_image(n, 1);
    let (table, chair) = (s.object_index("table").unwrap(), s.object_index("chair").unwrap());
    let (mask_t, mask_c) = (random_image(n, 2), random_image(n, 3));
    let masks = [(table, mask_t.as_slice()), (chair, mask_c.as_slice())];
    let cases = [
        ("depth interior", AovAdjoints { depth: Some(&depth), masks: &[] }, 0),
        ("silhouettes, masks", AovAdjoints { depth: None, masks: &masks }, 1 << 14),
        ("depth and masks, both terms", AovAdjoints { depth: Some(&depth), masks: &masks }, 1 << 14),
    ];
    for (name, adjoints, edge_samples) in cases {
        let cpu = aovs_vjp(&s, &d, &s.settings, &pose, &adjoints, edge_samples).unwrap();
        let gpu = vk.aovs_vjp_on_device(&s, &d, &s.settings, &pose, &adjoints, edge_samples).unwrap().unwrap();
        let nonzero = cpu.iter().filter(|g| g.abs() > 0.0).count();
        let worst = worst_relative(&cpu, &gpu);
        eprintln!("{name}: {nonzero} of {} components nonzero, worst relative difference {worst:.2e}", cpu.len());
        assert!(nonzero >= cpu.len() * 3 / 4, "{name}: the test exercises too little: {cpu:?}");
        assert!(worst <= tol.relative, "{name}:\ncpu {cpu:?}\ngpu {gpu:?}");
    }
    psdr_tests::assert_no_validation_errors(&vk);
}

#[test]
fn radiance_primary_boundary_agrees_with_the_cpu() {
    let Some(mut vk) = vk() else { return };
    let tol = psdr_tests::device_agreement(&vk);
    let (mut s, p) = room();
    s.settings.max_depth = 2;
    let d = SceneData::build(&s).unwrap();
    let pose = PoseLayout::new(&s, &p).unwrap();
    let adjoint = random_image(48 * 36 * 3, 5);
    let cpu = radiance_primary_boundary(&s, &d, &s.settings, &pose, &adjoint, 1 << 13);
    let gpu = vk.radiance_primary_on_device(&s, &d, &s.settings, &pose, &adjoint, 1 << 13).unwrap().unwrap();
    let nonzero = cpu.iter().filter(|g| g.abs() > 0.0).count();
    let worst = worst_relative(&cpu, &gpu);
    eprintln!("radiance primary boundary: {nonzero} of {} nonzero, worst relative difference {worst:.2e}", cpu.len());
    assert!(nonzero >= cpu.len() * 3 / 4, "the test exercises too little: {cpu:?}");
    assert!(worst <= tol.relative, "cpu {cpu:?}\ngpu {gpu:?}");
    // Pass-size independence.
    vk.set_pass_path_samples(2 * 1000);
    let split = vk.radiance_primary_on_device(&s, &d, &s.settings, &pose, &adjoint, 1 << 13).unwrap().unwrap();
    assert_eq!(gpu, split);
    psdr_tests::assert_no_validation_errors(&vk);
}

/// The ray-form interior term of radiance: each pixel's paths recorded and replayed in dual numbers along every
/// pose component that touches them, on the example room (textured, normal-mapped floor; glossy table) with
/// direct light (max_depth 2) and with one more bounce (max_depth 3, where a rare path may flip: the bound is the
/// same and held with margin, see the printed differences).
#[test]
fn radiance_interior_agrees_with_the_cpu() {
    let Some(mut vk) = vk() else { return };
    let tol = psdr_tests::device_agreement(&vk);
    for max_depth in [2, 3] {
        let (mut s, p) = room();
        s.settings.max_depth = max_depth;
        let d = SceneData::build(&s).unwrap();
        let pose = PoseLayout::new(&s, &p).unwrap();
        let adjoint = random_image(48 * 36 * 3, 6);
        let off = psdr::grad::BoundarySamples { primary: 0, secondary: 0 };
        let cpu =
            psdr::grad::radiance_pose_vjp(&s, &d, &s.settings, &pose, &adjoint, off, &mut psdr::backend::CpuBackend)
                .unwrap();
        let gpu = vk.radiance_pose_interior_on_device(&s, &d, &s.settings, &pose, &adjoint, 0).unwrap().unwrap();
        let nonzero = cpu.iter().filter(|g| g.abs() > 0.0).count();
        // Translations and scales of flat-faced objects move little in ray form (the rays are fixed, the faces
        // planar; only later bounces slide): those components are sums that cancel to 1e-8 of the largest, where
        // f32 rounding of the two backends' dual arithmetic shows. So: every component at least 1e-3 of the
        // largest within 1e-4 relative, and every component within 1e-6 of the largest absolute.
        let (worst, worst_abs) = split_worst(&cpu, &gpu);
        eprintln!(
            "radiance interior, max_depth {max_depth}: {nonzero} of {} nonzero, worst relative {worst:.2e} (components \
             >= 1e-3 of the largest), worst absolute {worst_abs:.2e} of the largest",
            cpu.len()
        );
        assert!(nonzero >= cpu.len() * 3 / 4, "the test exercises too little: {cpu:?}");
        assert!(worst <= tol.relative && worst_abs <= tol.absolute, "cpu {cpu:?}\ngpu {gpu:?}");
        vk.set_pass_path_samples(4 * 100);
        let split = vk.radiance_pose_interior_on_device(&s, &d, &s.settings, &pose, &adjoint, 0).unwrap().unwrap();
        assert_eq!(gpu, split, "pass-size independence");
        vk.set_pass_path_samples(1 << 20);
    }
    psdr_tests::assert_no_validation_errors(&vk);
}

/// The secondary boundary (shadows and indirect occluders of moving objects, horizons of turning smooth
/// surfaces) with the interior it feeds on, on the example room with direct light (max_depth 2) and one more
/// bounce (3), through `radiance_pose_vjp` on each backend (the light-side shadow samples run on the host for
/// both): the same edge draws on both sides (trees built on the host, the descent in double precision on both)
/// and the same side paths. Bound as for the interior (components >= 1e-3 of the largest within 1e-4 relative,
/// all within 1e-6 of the largest absolute); measured 3.3e-7 and 1.1e-5.
#[test]
fn secondary_boundary_agrees_with_the_cpu() {
    let Some(mut vk) = vk() else { return };
    let tol = psdr_tests::device_agreement(&vk);
    // The 64-entry kernel with every pose component (30), then the 16-entry one (what NVIDIA's driver builds)
    // with the table's and the chair's translation, yaw and scale (14).
    for small in [false, true] {
        vk.set_small_secondary_only(small);
        for max_depth in [2, 3] {
            let (mut s, mut p) = room();
            if small {
                let wanted = |o: &str, c: &str| format!("object/{o}/{c}").parse::<ParamPath>().unwrap();
                p = ["table", "chair"]
                    .iter()
                    .flat_map(|o| ["translation", "yaw", "scale"].map(|c| wanted(o, c)))
                    .collect();
            }
            s.settings.max_depth = max_depth;
            let d = SceneData::build(&s).unwrap();
            let pose = PoseLayout::new(&s, &p).unwrap();
            let adjoint = random_image(48 * 36 * 3, 7);
            // The device's kernel takes the term (not the CPU reference it falls back to), except the large one
            // on a driver that refuses it.
            let on_device = vk.radiance_pose_interior_on_device(&s, &d, &s.settings, &pose, &adjoint, 1).unwrap();
            if on_device.is_none() && !small && !tol.exact {
                eprintln!("secondary: {} refuses the 64-entry kernel", psdr::backend::Backend::name(&vk));
                continue;
            }
            assert!(on_device.is_some(), "small {small}, max_depth {max_depth}: the device left the term to the CPU");
            let samples = psdr::grad::BoundarySamples { primary: 0, secondary: 1 };
            let mut cpu_backend = psdr::backend::CpuBackend;
            let cpu =
                psdr::grad::radiance_pose_vjp(&s, &d, &s.settings, &pose, &adjoint, samples, &mut cpu_backend).unwrap();
            // Through the backend: the device's interior and path-vertex secondary term, plus the light-side
            // shadow term both backends compute on the host.
            let gpu = psdr::grad::radiance_pose_vjp(&s, &d, &s.settings, &pose, &adjoint, samples, &mut vk).unwrap();
            let off = psdr::grad::BoundarySamples { primary: 0, secondary: 0 };
            let interior =
                psdr::grad::radiance_pose_vjp(&s, &d, &s.settings, &pose, &adjoint, off, &mut cpu_backend).unwrap();
            let scale = cpu.iter().map(|g| g.abs()).fold(0.0, f64::max);
            let moved = cpu.iter().zip(&interior).filter(|(a, b)| (*a - *b).abs() > 1e-3 * scale).count();
            let (worst, worst_abs) = split_worst(&cpu, &gpu);
            eprintln!(
                "secondary, small kernel {small}, max_depth {max_depth}: the term moves {moved} of {} components; \
                 worst relative {worst:.2e}, worst absolute {worst_abs:.2e} of the largest",
                cpu.len()
            );
            assert!(moved >= cpu.len() / 3, "the secondary term must matter here: {cpu:?} vs interior {interior:?}");
            assert!(worst <= tol.relative && worst_abs <= tol.absolute, "cpu {cpu:?}\ngpu {gpu:?}");
        }
    }
    psdr_tests::assert_no_validation_errors(&vk);
}

/// grad_pose_radiance.rs's shadow of an occluder the camera never sees, on the Vulkan backend: the whole
/// gradient is the secondary boundary, here computed on the device (with the interior it feeds on and the
/// primary term), against central differences of device renders; grad_common's bound (8 seeds here).
#[test]
fn shadow_finite_differences_on_the_device_agree_with_its_gradients() {
    let Some(mut vk) = vk() else { return };
    let s = grad_common::scenes::shadow_scene(2);
    let p: ParamPath = "object/blocker/translation".parse().unwrap();
    let loss = psdr::grad::ImageLoss::Mean(psdr::grad::Output::Radiance);
    let opts = psdr::grad::AdOptions { replicas: 8, edge_samples: 1 << 14, secondary_edge_samples: 1 };
    let ad = psdr::grad::analytic_gradient(&s, std::slice::from_ref(&p), &loss, &opts, &mut vk).unwrap();
    let fd_opts = psdr::grad::FdOptions { step: 0.01, replicas: 8, components: vec![] };
    let fd = psdr::grad::central_difference(&s, &p, &loss, &fd_opts, &mut vk).unwrap();
    let mut clear_of_zero = 0;
    for c in 0..3 {
        let bound = 4.0 * (ad.std_err[c].powi(2) + fd.std_err[c].powi(2)).sqrt();
        eprintln!(
            "blocker translation[{c}] on the device: AD {:.5e} ± {:.1e}, FD {:.5e} ± {:.1e}",
            ad.mean[c], ad.std_err[c], fd.mean[c], fd.std_err[c]
        );
        assert!((ad.mean[c] - fd.mean[c]).abs() <= bound, "translation[{c}]: bound {bound}");
        clear_of_zero += usize::from(fd.mean[c].abs() > 4.0 * fd.std_err[c]);
    }
    assert!(clear_of_zero >= 1, "the shadow must move measurably");
}

/// grad_vertices.rs's box corners on the Vulkan backend: the two corners nearest the camera of a box against
/// the background, their mask and depth gradients (silhouette edges moving with their ends, the depth of the
/// faces they tilt) against central differences of device renders; grad_common's bound (8 seeds here).
#[test]
fn vertex_finite_differences_on_the_device_agree_with_its_gradients() {
    let Some(mut vk) = vk() else { return };
    let s = grad_common::scenes::box_in_the_dark();
    let m = s.objects[0].pose.matrix();
    let world: Vec<glam::Vec3> =
        psdr::scene::weld(&s.objects[0]).positions.iter().map(|&p| m.transform_point3(p)).collect();
    let mut ids: Vec<usize> = (0..world.len()).collect();
    ids.sort_by(|&a, &b| world[b].z.total_cmp(&world[a].z));
    let comps: Vec<usize> = ids[..2].iter().flat_map(|&v| [3 * v, 3 * v + 1, 3 * v + 2]).collect();
    let p: ParamPath = "object/box/vertices".parse().unwrap();
    let opts = psdr::grad::AdOptions { replicas: 8, edge_samples: 1 << 16, secondary_edge_samples: 0 };
    let (mut compared, mut clear_of_zero) = (0, 0);
    for output in [psdr::grad::Output::Mask(0), psdr::grad::Output::Depth] {
        let loss = psdr::grad::ImageLoss::Mean(output.clone());
        let ad = psdr::grad::analytic_gradient(&s, std::slice::from_ref(&p), &loss, &opts, &mut vk).unwrap();
        let fd_opts = psdr::grad::FdOptions { step: 0.01, replicas: 8, components: comps.clone() };
        let fd = psdr::grad::central_difference(&s, &p, &loss, &fd_opts, &mut vk).unwrap();
        for (k, &c) in comps.iter().enumerate() {
            let bound = 4.0 * (ad.std_err[c].powi(2) + fd.std_err[k].powi(2)).sqrt();
            eprintln!(
                "{output:?} vertices[{c}] on the device: AD {:.5e} ± {:.1e}, FD {:.5e} ± {:.1e}",
                ad.mean[c], ad.std_err[c], fd.mean[k], fd.std_err[k]
            );
            assert!((ad.mean[c] - fd.mean[k]).abs() <= bound, "{output:?} vertices[{c}]: bound {bound}");
            compared += 1;
            clear_of_zero += usize::from(fd.mean[k].abs() > 4.0 * fd.std_err[k]);
        }
    }
    assert!(clear_of_zero * 2 >= compared, "only {clear_of_zero} of {compared} FD estimates are clear of noise");
    psdr_tests::assert_no_validation_errors(&vk);
}

/// The interior term's FD check on the device: a floor with a 4x4 checker texture under a lamp, seen from above
/// (its borders outside the image), translated within its own plane. Camera rays and light samples then meet
/// the same points, only the texture slides under them: no silhouette, shadow or emitter edge moves, and the
/// whole gradient is the ray-form interior term, computed on the device (`secondary_edge_samples` 0), against
/// central differences of device renders. Loss: a fixed random weighting of the image (the mean would barely
/// see a sliding texture). Bound: grad_common's (4 combined standard errors, 8 seeds here).
#[test]
fn radiance_finite_differences_on_the_device_agree_with_its_gradients() {
    let Some(mut vk) = vk() else { return };
    let s = grad_common::scenes::textured_floor_with(r#""albedo": { "texture": "checker.exr" }, "specular": 0"#);
    let n = (s.camera.width * s.camera.height * 3) as usize;
    let loss = psdr::grad::ImageLoss::Weighted { output: psdr::grad::Output::Radiance, weights: random_image(n, 8) };
    let opts = psdr::grad::AdOptions { replicas: 8, edge_samples: 1 << 14, secondary_edge_samples: 0 };
    let p: ParamPath = "object/floor/translation".parse().unwrap();
    let ad = psdr::grad::analytic_gradient(&s, std::slice::from_ref(&p), &loss, &opts, &mut vk).unwrap();
    let fd_opts = psdr::grad::FdOptions { step: 0.01, replicas: 8, components: vec![0, 2] };
    let fd = psdr::grad::central_difference(&s, &p, &loss, &fd_opts, &mut vk).unwrap();
    for (k, c) in [0, 2].into_iter().enumerate() {
        let bound = 4.0 * (ad.std_err[c].powi(2) + fd.std_err[k].powi(2)).sqrt();
        eprintln!(
            "floor translation[{c}] on the device: AD {:.5e} ± {:.1e}, FD {:.5e} ± {:.1e}",
            ad.mean[c], ad.std_err[c], fd.mean[k], fd.std_err[k]
        );
        assert!((ad.mean[c] - fd.mean[k]).abs() <= bound, "translation[{c}]: bound {bound}");
        assert!(fd.mean[k].abs() > 4.0 * fd.std_err[k], "translation[{c}]: FD is noise");
    }
}

#[test]
fn gradient_does_not_depend_on_the_pass_size() {
    let Some(mut vk) = vk() else { return };
    let (s, p) = room();
    let d = SceneData::build(&s).unwrap();
    let pose = PoseLayout::new(&s, &p).unwrap();
    let depth = random_image(48 * 36, 4);
    let adjoints = AovAdjoints { depth: Some(&depth), masks: &[] };
    let whole = vk.aovs_vjp_on_device(&s, &d, &s.settings, &pose, &adjoints, 4096).unwrap().unwrap();
    vk.set_pass_path_samples(300);
    let split = vk.aovs_vjp_on_device(&s, &d, &s.settings, &pose, &adjoints, 4096).unwrap().unwrap();
    assert_eq!(whole, split);
}

/// Vertex parameters (the vase's welded vertices, with the table's translation beside them): their velocity
/// depends on where on the mesh a point lies (corner weights, edge ends), which the kernels read per vertex
/// block. Depth and masks (both terms), the radiance's primary boundary and interior agree with the CPU, with
/// direct light (max_depth 2): measured 4.7e-9, 9e-16 and exactly. (With one more bounce the interior differs by
/// up to 8e-5: the vase's small triangles amplify the rounding of the BSDF-sampled bounce direction.) And the
/// secondary boundary with vertex parameters at max_depth 3: measured 8.0e-5 (the same rounding), and 3.3e-8
/// for an unseen occluder's vertices.
#[test]
fn vertex_parameters_agree_with_the_cpu() {
    let Some(mut vk) = vk() else { return };
    let tol = psdr_tests::device_agreement(&vk);
    let (mut s, _) = room();
    s.settings.max_depth = 2;
    let d = SceneData::build(&s).unwrap();
    let p: Vec<ParamPath> = ["object/vase/vertices", "object/table/translation"].map(|p| p.parse().unwrap()).to_vec();
    let pose = PoseLayout::new(&s, &p).unwrap();
    let n = 48 * 36;
    let (depth, mask_v) = (random_image(n, 11), random_image(n, 12));
    let vase = s.object_index("vase").unwrap();
    let masks = [(vase, mask_v.as_slice())];
    let adjoints = AovAdjoints { depth: Some(&depth), masks: &masks };
    let radiance = random_image(n * 3, 13);
    let off = psdr::grad::BoundarySamples { primary: 0, secondary: 0 };
    let mut cpu_backend = psdr::backend::CpuBackend;
    let cases = [
        (
            "depth and masks",
            aovs_vjp(&s, &d, &s.settings, &pose, &adjoints, 1 << 14).unwrap(),
            vk.aovs_vjp_on_device(&s, &d, &s.settings, &pose, &adjoints, 1 << 14).unwrap().unwrap(),
        ),
        (
            "radiance primary boundary",
            radiance_primary_boundary(&s, &d, &s.settings, &pose, &radiance, 1 << 13),
            vk.radiance_primary_on_device(&s, &d, &s.settings, &pose, &radiance, 1 << 13).unwrap().unwrap(),
        ),
        (
            "radiance interior",
            psdr::grad::radiance_pose_vjp(&s, &d, &s.settings, &pose, &radiance, off, &mut cpu_backend).unwrap(),
            vk.radiance_pose_interior_on_device(&s, &d, &s.settings, &pose, &radiance, 0).unwrap().unwrap(),
        ),
    ];
    for (name, cpu, gpu) in cases {
        let nonzero = cpu.iter().filter(|g| g.abs() > 0.0).count();
        let (worst, worst_abs) = split_worst(&cpu, &gpu);
        eprintln!(
            "vertices, {name}: {nonzero} of {} components nonzero, worst relative {worst:.2e}, absolute {worst_abs:.2e}",
            cpu.len()
        );
        // (The vase has 2084 welded vertices; those on its silhouette, or hit by paths, have gradients.)
        assert!(nonzero >= 50, "{name}: the test exercises too little");
        assert!(worst <= tol.relative && worst_abs <= tol.absolute, "{name}:\ncpu {cpu:?}\ngpu {gpu:?}");
    }
    // The secondary boundary with vertex parameters (and the interior it feeds on), with one more bounce: with
    // direct light only, the device's path-vertex term leaves every camera-visible shadow to the host's
    // light-side samples and would be compared with nothing.
    s.settings.max_depth = 3;
    let d = SceneData::build(&s).unwrap();
    let samples = psdr::grad::BoundarySamples { primary: 0, secondary: 1 };
    let cpu = psdr::grad::radiance_pose_vjp(&s, &d, &s.settings, &pose, &radiance, samples, &mut cpu_backend).unwrap();
    let gpu = psdr::grad::radiance_pose_vjp(&s, &d, &s.settings, &pose, &radiance, samples, &mut vk).unwrap();
    // Lavapipe builds the 64-entry secondary kernel, which takes a vertex block's paths; a driver with only the
    // 16-entry one leaves them to the CPU (the comparison then holds trivially).
    let on_device = vk.radiance_pose_interior_on_device(&s, &d, &s.settings, &pose, &radiance, 1).unwrap().is_some();
    eprintln!("vertices, secondary: on the device: {on_device}");
    assert!(on_device || !tol.exact, "lavapipe left the vertices' secondary term to the CPU");
    let (worst, worst_abs) = split_worst(&cpu, &gpu);
    let nonzero = cpu.iter().filter(|g| g.abs() > 0.0).count();
    eprintln!("vertices, secondary: {nonzero} nonzero, worst relative {worst:.2e}, absolute {worst_abs:.2e}");
    assert!(worst <= tol.relative && worst_abs <= tol.absolute, "secondary:\ncpu {cpu:?}\ngpu {gpu:?}");
    // An occluder the camera never sees: its vertices' whole gradient is the secondary boundary (its shadow: the
    // host's light-side samples, and the device's for the light bounced once more).
    let s = grad_common::scenes::shadow_scene(3);
    let d = SceneData::build(&s).unwrap();
    let pose = PoseLayout::new(&s, &["object/blocker/vertices".parse().unwrap()]).unwrap();
    let radiance = random_image((s.camera.width * s.camera.height * 3) as usize, 14);
    let cpu = psdr::grad::radiance_pose_vjp(&s, &d, &s.settings, &pose, &radiance, samples, &mut cpu_backend).unwrap();
    let gpu = psdr::grad::radiance_pose_vjp(&s, &d, &s.settings, &pose, &radiance, samples, &mut vk).unwrap();
    let scale = cpu.iter().map(|g| g.abs()).fold(0.0, f64::max);
    let worst = cpu.iter().zip(&gpu).map(|(a, b)| (a - b).abs() / (a.abs() + 1e-6 * scale)).fold(0.0, f64::max);
    let nonzero = cpu.iter().filter(|g| g.abs() > 0.0).count();
    eprintln!("vertices, shadow only: {nonzero} of {} nonzero, worst relative {worst:.2e}", cpu.len());
    assert!(nonzero >= cpu.len() / 2 && worst <= tol.relative, "shadow:\ncpu {cpu:?}\ngpu {gpu:?}");
    psdr_tests::assert_no_validation_errors(&vk);
}

/// grad_pose_aov.rs's FD checks of a box's mask and depth on the Vulkan backend: the analytic gradient
/// (through `analytic_gradient`, so the backend's own routing) and the central differences both there. Bound:
/// 4 combined standard errors over 12 seeds (see grad_common; the seeds are fixed). Most components' FD must
/// also stand 4 standard errors clear of zero, or the check would prove little.
#[test]
fn finite_differences_on_the_device_agree_with_its_gradients() {
    let Some(mut vk) = vk() else { return };
    let json = r#"{ "format": "psdr-scene", "version": 1,
      "camera": { "origin": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov_y": 40, "width": 64, "height": 48 },
      "render": { "spp": 64, "max_depth": 2 },
      "materials": [ { "name": "w", "albedo": 0.5, "specular": 0 } ],
      "shapes": [
        { "name": "box", "type": "box", "size": [0.6, 0.5, 0.7], "material": "w",
          "transform": { "translation": [0.2, 0.1, -3], "rotation_deg": [20, 30, 0] } },
        { "name": "lamp", "type": "rectangle", "size": [1, 1], "material": "w",
          "transform": { "translation": [0, 3, -3], "rotation_deg": [90, 0, 0] }, "emitter": { "radiance": 1 } } ] }"#;
    let dir = psdr_tests::temp_dir("vk-aov-fd");
    let s = psdr::scene::load_scene(&psdr_tests::write_file(&dir, "scene.json", json)).unwrap();
    let opts = psdr::grad::AdOptions { replicas: 12, edge_samples: 1 << 15, secondary_edge_samples: 0 };
    let (mut compared, mut clear_of_zero) = (0, 0);
    for output in [psdr::grad::Output::Mask(0), psdr::grad::Output::Depth] {
        let loss = psdr::grad::ImageLoss::Mean(output.clone());
        for path in ["object/box/translation", "object/box/yaw", "object/box/scale"] {
            let p: ParamPath = path.parse().unwrap();
            let ad = psdr::grad::analytic_gradient(&s, std::slice::from_ref(&p), &loss, &opts, &mut vk).unwrap();
            let fd_opts = psdr::grad::FdOptions { step: 0.01, replicas: 12, components: vec![] };
            let fd = psdr::grad::central_difference(&s, &p, &loss, &fd_opts, &mut vk).unwrap();
            for c in 0..ad.mean.len() {
                let bound = 4.0 * (ad.std_err[c].powi(2) + fd.std_err[c].powi(2)).sqrt();
                eprintln!(
                    "{output:?} {path}[{c}] on the device: AD {:.5e} ± {:.1e}, FD {:.5e} ± {:.1e}",
                    ad.mean[c], ad.std_err[c], fd.mean[c], fd.std_err[c]
                );
                assert!((ad.mean[c] - fd.mean[c]).abs() <= bound, "{output:?} {path}[{c}]: bound {bound}");
                compared += 1;
                clear_of_zero += usize::from(fd.mean[c].abs() > 4.0 * fd.std_err[c]);
            }
        }
    }
    assert!(clear_of_zero * 4 >= compared * 3, "only {clear_of_zero} of {compared} FD estimates are clear of noise");
    psdr_tests::assert_no_validation_errors(&vk);
}
