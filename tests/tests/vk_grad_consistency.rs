//! The Vulkan adjoint pass (shaders/grad/interior/material_light.comp) against its CPU twin
//! (`grad::radiance_vjp`), same scene, same seed, same adjoint image: light radiances, albedo, roughness and
//! specular constants, albedo and roughness texels, procedural graph parameters and tints, uv transforms; and the
//! fused L2 estimator (shaders/grad/interior/fused_l2.comp, `grad::radiance_vjp_cross`).
//!
//! Without a Vulkan device these tests print a note and pass, unless PSDR_REQUIRE_VULKAN=1 (CI sets it).
//!
//! Bounds. Both sides trace the same paths with the same integrator (render/path_trace.glsl is the twin of
//! render::path_trace::trace_from), record them through the same observer hooks and sweep them with the same
//! operations; the GPU accumulates a pixel's terms in f32 (the CPU in f64) and the host sums pixels in f64. As
//! for the primal (tests/tests/vk_consistency.rs), sin/cos in BSDF sampling round differently on the two sides,
//! so a bounce's direction differs in its last bits and, rarely, a discrete decision flips (a BVH slab test at
//! a box edge, a roulette threshold), after which one path differs entirely. Hence:
//! (1) per path: for single-sample pixels whose rendered radiance agrees on both backends within 1e-5 relative
//!     (the path did not flip), every gradient component agrees within 1e-4 relative (+1e-9 absolute);
//! (2) whole images, direct light only (max_depth 2: one bounce direction per path): every component within
//!     1e-4 relative;
//! (3) whole images, deep paths (max_depth 5, roulette): every component within 1e-4 relative (a flipped path
//!     would move a sum by up to one path's share, about 3e-4 here; none flips in this image on lavapipe);
//! (4) the result does not depend on the pass size (bit-identical), the device is used (not the fallback), and
//!     the validation layer reports nothing.
//! Measured on lavapipe (Mesa 22.3): (1) 64 of 64 single-path pixels agree; (2) worst 4.3e-8; (3) worst 1.1e-5;
//! texture space (direct paths up to 3 vertices) worst 8.9e-9; fused 4.6e-8 (direct), 1.0e-6 (deep), 5.2e-9
//! (texture space).
//! And the interior FD checks on the device (albedo, light radiance, roughness, specular; renders and gradient
//! both on Vulkan).

use psdr::backend::{Backend, VkBackend};
use psdr::grad::{radiance_vjp, GradLayout, ParamPath};
use psdr::render::SceneData;
use psdr::scene::{Color, Scalar, Scene};
use psdr_tests::SplitMix64;

mod grad_common;
use grad_common::scenes::{planks, textured_floor_with};

fn vk() -> Option<VkBackend> {
    psdr_tests::vulkan_or_skip(|| VkBackend::new(None))
}

/// Every light radiance and every constant albedo, roughness and specular of the scene (the example room's
/// walnut, fabric and ceramic are glossy dielectrics, its metals have specular 1: every branch of the BSDF
/// derivative is taken).
fn params(s: &Scene) -> Vec<ParamPath> {
    let mut p: Vec<ParamPath> =
        s.objects.iter().filter(|o| o.emitter.is_some()).map(|o| ParamPath::LightRadiance(o.name.clone())).collect();
    for m in &s.materials {
        if matches!(m.albedo, Color::Constant(_)) {
            p.push(ParamPath::MaterialAlbedo(m.name.clone()));
        }
        if matches!(m.roughness, Scalar::Constant(_)) {
            p.push(ParamPath::MaterialRoughness(m.name.clone()));
        }
        if matches!(m.specular, Scalar::Constant(_)) {
            p.push(ParamPath::MaterialSpecular(m.name.clone()));
        }
    }
    p
}

fn random_adjoint(n: usize, seed: u64) -> Vec<f32> {
    let mut rng = SplitMix64(seed);
    (0..n).map(|_| rng.next_f32() * 2.0 - 0.5).collect()
}

fn both(vk: &mut VkBackend, s: &Scene, adjoint: &[f32]) -> (Vec<f64>, Vec<f64>, Vec<ParamPath>) {
    let p = params(s);
    let (cpu, gpu) = both_for(vk, s, &p, adjoint);
    (cpu, gpu, p)
}

fn both_for(vk: &mut VkBackend, s: &Scene, p: &[ParamPath], adjoint: &[f32]) -> (Vec<f64>, Vec<f64>) {
    let d = SceneData::build(s).unwrap();
    let layout = GradLayout::new(s, p).unwrap();
    let cpu = radiance_vjp(&d, &s.settings, &layout, adjoint).unwrap();
    let gpu = vk.radiance_vjp_on_device(&d, &s.settings, &layout, adjoint).unwrap().expect("covered by the device");
    (cpu, gpu)
}

fn worst_relative(cpu: &[f64], gpu: &[f64], absolute: f64) -> f64 {
    cpu.iter().zip(gpu).map(|(a, b)| (a - b).abs() / (a.abs() + absolute)).fold(0.0, f64::max)
}

#[test]
fn direct_light_gradients_agree_with_the_cpu() {
    let Some(mut vk) = vk() else { return };
    let mut s = psdr_tests::example_room(32, 24, 4);
    s.settings.max_depth = 2;
    let adjoint = random_adjoint(32 * 24 * 3, 3);
    let (cpu, gpu, p) = both(&mut vk, &s, &adjoint);
    assert!(p.len() >= 5 && cpu.iter().filter(|g| g.abs() > 0.0).count() >= 6, "{p:?}: {cpu:?}");
    let worst = worst_relative(&cpu, &gpu, 1e-9);
    eprintln!("direct light, {} components: worst relative difference {worst:.2e}", cpu.len());
    assert!(worst <= psdr_tests::device_agreement(&vk).relative, "cpu {cpu:?}\ngpu {gpu:?}");
    psdr_tests::assert_no_validation_errors(&vk);
}

#[test]
fn deep_path_gradients_agree_with_the_cpu() {
    let Some(mut vk) = vk() else { return };
    let mut s = psdr_tests::example_room(32, 24, 4);
    s.settings.max_depth = 5;
    // The light's radiance shaped by direction: its gradient carries the shape (emission and next-event).
    for e in s.objects.iter_mut().filter_map(|o| o.emitter.as_mut()) {
        e.sky_gradient = glam::Vec3::new(0.6, -0.3, 0.9);
    }
    let adjoint = random_adjoint(32 * 24 * 3, 4);
    let (cpu, gpu, _) = both(&mut vk, &s, &adjoint);
    let scale = cpu.iter().map(|g| g.abs()).fold(0.0, f64::max);
    let worst = worst_relative(&cpu, &gpu, 1e-6 * scale);
    eprintln!("deep paths, {} components: worst relative difference {worst:.2e}", cpu.len());
    assert!(worst <= psdr_tests::device_agreement(&vk).relative, "cpu {cpu:?}\ngpu {gpu:?}");
    psdr_tests::assert_no_validation_errors(&vk);
}

#[test]
fn paths_that_do_not_flip_give_the_same_gradient() {
    let Some(mut vk) = vk() else { return };
    let mut s = psdr_tests::example_room(16, 12, 1);
    s.settings.max_depth = 5;
    let d = SceneData::build(&s).unwrap();
    let cpu_frame = psdr::backend::CpuBackend.render(&d, &s.settings, &|_, _| {}).unwrap();
    let gpu_frame = vk.render(&d, &s.settings, &|_, _| {}).unwrap();
    let p = params(&s);
    // A path that flipped differs entirely; one that did not, by the device's rounding (1e-4 on a GPU).
    let flip = if psdr_tests::device_agreement(&vk).exact { 1e-5 } else { 1e-3 };
    let layout = GradLayout::new(&s, &p).unwrap();
    let (mut same, mut checked) = (0, 0);
    for pixel in (0..16 * 12).step_by(3) {
        let (a, b) = (&cpu_frame.radiance[3 * pixel..3 * pixel + 3], &gpu_frame.radiance[3 * pixel..3 * pixel + 3]);
        let flipped = a.iter().zip(b).any(|(x, y)| (x - y).abs() > flip * x.abs().max(1e-3));
        if flipped {
            continue;
        }
        let mut adjoint = vec![0.0f32; 16 * 12 * 3];
        adjoint[3 * pixel..3 * pixel + 3].copy_from_slice(&[1.0, 0.5, 0.25]);
        let cpu = radiance_vjp(&d, &s.settings, &layout, &adjoint).unwrap();
        let gpu = vk.radiance_vjp_on_device(&d, &s.settings, &layout, &adjoint).unwrap().unwrap();
        checked += 1;
        // On a GPU a small component carries the device's rounding of the large ones (1e-4 of the largest).
        let tol = psdr_tests::device_agreement(&vk);
        let scale = cpu.iter().map(|g| g.abs()).fold(0.0, f64::max);
        let floor = if tol.exact { 1e-9 } else { tol.absolute / tol.relative * scale };
        let worst = worst_relative(&cpu, &gpu, floor);
        same += usize::from(worst <= tol.relative);
        assert!(worst <= tol.relative, "pixel {pixel}: cpu {cpu:?}\ngpu {gpu:?}");
    }
    eprintln!("{same} of {checked} single-path pixels agree (the others' paths flipped)");
    assert!(checked >= 55, "only {checked} of 64 paths did not flip");
}

/// Texture-space parameters: the kernel writes each vertex's texture reads and the host carries them into
/// texels, whole procedural maps (then through the graph's backward) and uv transforms with the CPU's own
/// `texture_read_adjoint` and `normal_read_adjoint`. A floor with a 4x4 albedo and roughness texture (large
/// texels) and a uv transform; a glossy floor with a 4x4 normal map and a uv transform (the map's texels, and the
/// transform through both the lookup and the turning tangent frame); and a floor of procedural oak planks (its
/// graph parameters, tint, uv transform); each with the constants.
#[test]
fn texture_space_gradients_agree_with_the_cpu() {
    let Some(mut vk) = vk() else { return };
    let texel_floor = textured_floor_with(
        r#""albedo": { "texture": "checker.exr" }, "roughness": { "texture": "rough.exr" }, "specular": 0.8,
           "uv_transform": { "scale": [1.5, 1.5], "rotation_deg": 20 }"#,
    );
    let bumpy_floor = textured_floor_with(
        r#""albedo": 0.4, "specular": 0.8, "roughness": 0.5, "normal_map": "bumps.exr",
           "uv_transform": { "scale": [1.3, 0.8], "rotation_deg": 20 }"#,
    );
    let planks = planks();
    let texture_params = [
        (
            &texel_floor,
            vec!["albedo.texel[1,2]", "albedo.texel[3,0]", "roughness.texel[1,2]", "uv_scale", "uv_rotation"],
        ),
        (&bumpy_floor, vec!["normal_map.texel[1,2]", "normal_map.texel[2,2]", "uv_scale", "uv_rotation"]),
        (&planks, vec!["graph.gap", "graph.variation", "tint", "uv_scale", "uv_rotation"]),
    ];
    for (k, (s, fields)) in texture_params.into_iter().enumerate() {
        let mut p = params(s);
        let constants = p.len();
        p.extend(fields.iter().map(|f| format!("material/floor/{f}").parse::<ParamPath>().unwrap()));
        let layout = GradLayout::new(s, &p).unwrap();
        assert!(layout.device_slots().is_some_and(|d| d.texture_reads), "the device covers {p:?}");
        let adjoint = random_adjoint((s.camera.width * s.camera.height * 3) as usize, 7 + k as u64);
        let (cpu, gpu) = both_for(&mut vk, s, &p, &adjoint);
        let textured = &cpu[layout.offsets[constants]..];
        assert!(textured.iter().all(|g| g.abs() > 0.0), "every texture-space component is reached: {textured:?}");
        let scale = cpu.iter().map(|g| g.abs()).fold(0.0, f64::max);
        let worst = worst_relative(&cpu, &gpu, 1e-6 * scale);
        eprintln!("texture space ({fields:?}), {} components: worst relative difference {worst:.2e}", cpu.len());
        assert!(worst <= psdr_tests::device_agreement(&vk).relative, "cpu {cpu:?}\ngpu {gpu:?}");
    }
    psdr_tests::assert_no_validation_errors(&vk);
}

/// The fused estimator of an L2 loss (shaders/grad/interior/fused_l2.comp, twin of `radiance_vjp_cross`): the
/// same gradient and rendered image as the CPU, for the constants of the example room (direct light and deep
/// paths) and for the texture-space parameters of the planks floor; and through `analytic_gradient`.
#[test]
fn fused_estimator_agrees_with_the_cpu() {
    let Some(mut vk) = vk() else { return };
    let planks = planks();
    // The lamp's own material is seen by no path that scatters: only its radiance and the floor's parameters.
    let planks_params: Vec<ParamPath> =
        ["light/lamp/radiance", "material/floor/graph.gap", "material/floor/tint", "material/floor/uv_scale"]
            .map(|f| f.parse().unwrap())
            .to_vec();
    let mut cases = vec![];
    for max_depth in [2, 5] {
        let mut s = psdr_tests::example_room(32, 24, 4);
        s.settings.max_depth = max_depth;
        let p = params(&s);
        cases.push((format!("room, max_depth {max_depth}"), s, p));
    }
    cases.push(("planks, texture space".into(), planks, planks_params));
    for (k, (name, s, p)) in cases.into_iter().enumerate() {
        let d = SceneData::build(&s).unwrap();
        let layout = GradLayout::new(&s, &p).unwrap();
        let n = (s.camera.width * s.camera.height * 3) as usize;
        let target = random_adjoint(n, 20 + k as u64);
        let px = psdr::grad::PixelwiseAdjoint { target: &target, scale: 2.0 / n as f32 };
        let seed_b = s.settings.seed.wrapping_add(0x9e37_79b9);
        let (cpu, cpu_image) = psdr::grad::radiance_vjp_cross(&d, &s.settings, &layout, &px, seed_b).unwrap();
        let (gpu, gpu_image) =
            vk.radiance_vjp_cross_on_device(&d, &s.settings, &layout, &px, seed_b).unwrap().expect("covered");
        let scale = cpu.iter().map(|g| g.abs()).fold(0.0, f64::max);
        let worst = worst_relative(&cpu, &gpu, 1e-6 * scale);
        let image_worst =
            cpu_image.iter().zip(&gpu_image).map(|(a, b)| (a - b).abs() / a.abs().max(1e-3)).fold(0.0, f32::max);
        eprintln!("fused, {name}: {} components, worst {worst:.2e}; image worst {image_worst:.2e}", cpu.len());
        assert!(cpu.iter().filter(|g| g.abs() > 0.0).count() * 4 >= cpu.len() * 3, "{name}: {cpu:?}");
        assert!(worst <= psdr_tests::device_agreement(&vk).relative, "{name}:\ncpu {cpu:?}\ngpu {gpu:?}");
        assert!(
            f64::from(image_worst) <= psdr_tests::device_agreement(&vk).relative,
            "{name}: images differ by {image_worst}"
        );
    }
    // Through analytic_gradient (an L2 loss takes the fused path on either backend).
    let s = psdr_tests::example_room(24, 18, 4);
    let p = params(&s);
    let loss =
        psdr::grad::ImageLoss::L2To { output: psdr::grad::Output::Radiance, target: random_adjoint(24 * 18 * 3, 30) };
    let opts = psdr::grad::AdOptions { replicas: 2, edge_samples: 0, secondary_edge_samples: 0 };
    let cpu = psdr::grad::analytic_gradient(&s, &p, &loss, &opts, &mut psdr::backend::CpuBackend).unwrap();
    let gpu = psdr::grad::analytic_gradient(&s, &p, &loss, &opts, &mut vk).unwrap();
    let scale = cpu.mean.iter().map(|g| g.abs()).fold(0.0, f64::max);
    let worst = worst_relative(&cpu.mean, &gpu.mean, 1e-6 * scale);
    eprintln!("fused through analytic_gradient: worst {worst:.2e}");
    assert!(worst <= psdr_tests::device_agreement(&vk).relative, "cpu {:?}\ngpu {:?}", cpu.mean, gpu.mean);
    psdr_tests::assert_no_validation_errors(&vk);
}

#[test]
fn gradient_does_not_depend_on_the_pass_size() {
    let Some(mut vk) = vk() else { return };
    let s = psdr_tests::example_room(24, 18, 4);
    let adjoint = random_adjoint(24 * 18 * 3, 5);
    let (_, whole, _) = both(&mut vk, &s, &adjoint);
    // With texture reads too (their buffer is split with the rows).
    let planks = planks();
    let mut p = params(&planks);
    p.extend(["material/floor/graph.gap", "material/floor/uv_scale"].map(|f| f.parse::<ParamPath>().unwrap()));
    let planks_adjoint = random_adjoint(32 * 32 * 3, 9);
    let (_, whole_planks) = both_for(&mut vk, &planks, &p, &planks_adjoint);
    vk.set_pass_path_samples(4 * 50); // 50 pixels a pass (25 at the planks' 8 spp)
    let (_, split, _) = both(&mut vk, &s, &adjoint);
    assert_eq!(whole, split);
    let (_, split_planks) = both_for(&mut vk, &planks, &p, &planks_adjoint);
    assert_eq!(whole_planks, split_planks);
}

/// Through the backend interface (`psdr grad --backend vk`, the optimiser): the analytic gradient of a loss on
/// either backend agrees, so the device path is the one taken and it is wired to the right slots.
#[test]
fn analytic_gradients_agree_on_either_backend() {
    let Some(mut vk) = vk() else { return };
    let s = psdr_tests::example_room(24, 18, 4);
    let p = params(&s);
    let loss = psdr::grad::ImageLoss::Weighted {
        output: psdr::grad::Output::Radiance,
        weights: random_adjoint(24 * 18 * 3, 6),
    };
    let opts = psdr::grad::AdOptions { replicas: 2, edge_samples: 0, secondary_edge_samples: 0 };
    let cpu = psdr::grad::analytic_gradient(&s, &p, &loss, &opts, &mut psdr::backend::CpuBackend).unwrap();
    let gpu = psdr::grad::analytic_gradient(&s, &p, &loss, &opts, &mut vk).unwrap();
    let scale = cpu.mean.iter().map(|g| g.abs()).fold(0.0, f64::max);
    let worst = worst_relative(&cpu.mean, &gpu.mean, 1e-6 * scale);
    eprintln!("analytic_gradient, {} components: worst relative difference {worst:.2e}", cpu.mean.len());
    assert!(worst <= psdr_tests::device_agreement(&vk).relative, "cpu {:?}\ngpu {:?}", cpu.mean, gpu.mean);
}

/// The interior tests' finite-difference checks (tests/tests/grad_interior.rs) on the Vulkan backend: both the
/// analytic gradient and the central differences (whose renders run on the device too) for a wall albedo, the
/// light's radiance and the glossy table's roughness and specular, same bound (4 combined standard errors over 8 seeds; a t distribution with 7 degrees of
/// freedom fails a correct implementation with probability under 1 % per comparison; seeds fixed).
#[test]
fn finite_differences_on_the_device_agree_with_its_gradients() {
    let Some(mut vk) = vk() else { return };
    let room = psdr_tests::example_room(32, 24, 8);
    let planks = planks();
    // The walnut table top seen from above, large in the image (as grad_interior.rs's roughness check).
    let mut table = psdr_tests::example_room(40, 30, 8);
    table.camera.origin = glam::Vec3::new(0.2, 1.6, 0.4);
    let loss = psdr::grad::ImageLoss::Mean(psdr::grad::Output::Radiance);
    for (s, path, step, components) in [
        (&room, "material/accent_wall/albedo", 0.02f32, vec![0usize, 1, 2]),
        (&room, "light/ceiling_light/radiance", 0.5, vec![1]),
        (&table, "material/walnut/roughness", 0.04, vec![0]),
        (&table, "material/walnut/specular", 0.02, vec![0]),
        (&planks, "material/floor/tint", 0.02, vec![0, 1, 2]),
    ] {
        let p: ParamPath = path.parse().unwrap();
        let opts = psdr::grad::AdOptions { replicas: 8, edge_samples: 0, secondary_edge_samples: 0 };
        let ad = psdr::grad::analytic_gradient(s, std::slice::from_ref(&p), &loss, &opts, &mut vk).unwrap();
        let fd_opts = psdr::grad::FdOptions { step, replicas: 8, components: components.clone() };
        let fd = psdr::grad::central_difference(s, &p, &loss, &fd_opts, &mut vk).unwrap();
        for (k, &c) in components.iter().enumerate() {
            let bound = 4.0 * (ad.std_err[c].powi(2) + fd.std_err[k].powi(2)).sqrt();
            eprintln!(
                "{path}[{c}] on the device: AD {:.5e} ± {:.1e}, FD {:.5e} ± {:.1e}",
                ad.mean[c], ad.std_err[c], fd.mean[k], fd.std_err[k]
            );
            assert!(
                (ad.mean[c] - fd.mean[k]).abs() <= bound,
                "{path}[{c}]: AD {} vs FD {} (bound {bound})",
                ad.mean[c],
                fd.mean[k]
            );
            assert!(fd.mean[k].abs() > 4.0 * fd.std_err[k], "{path}[{c}]: FD is noise");
        }
    }
    psdr_tests::assert_no_validation_errors(&vk);
}
