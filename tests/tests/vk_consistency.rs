//! The Vulkan backend against the CPU reference on the same scenes and seeds, and the shared struct layouts.
//!
//! Without a Vulkan device these tests print a note and pass, unless PSDR_REQUIRE_VULKAN=1 (CI sets it), which
//! turns a missing device into a failure.
//!
//! Bounds. Both backends draw the same random numbers (the sampler is integer arithmetic) and run the same
//! operations in the same order; psdr/build.rs marks every float operation of the kernels NoContraction, so the
//! driver may neither fuse multiply-adds nor reassociate (Rust does neither). What remains is sin/cos: Rust calls
//! libm, GLSL the driver's approximation, which differ in the last bits. Only BSDF sampling uses them (the
//! direction of every bounce), so (a) paths of one segment (max_depth 1: camera rays, BVH, shading, textures,
//! normal maps, emitters seen directly) and every primary-hit AOV are bit-identical on lavapipe, and (b) longer
//! paths agree to float rounding except where a last-bit difference flips a discrete decision (a BVH slab test at
//! a box edge, a shadow ray grazing an edge, a roulette threshold), after which that one path differs entirely.
//! (Measured: replacing sin/cos by one shared polynomial on both sides made every output bit-identical.)
//! So the bounds for radiance are: (1) the images' means agree within 1e-4 relative; (2) at least 99.9 % of
//! values agree within 1e-4 relative (+1e-6 absolute); (3) every pixel agrees within the largest contribution one
//! path can make to it (its own value times spp, plus 1e-3), i.e. disagreement is confined to single paths. The
//! AOVs (depth, normal, albedo, coverage) must meet the same bounds everywhere and be bit-identical on lavapipe;
//! object ids agree on at least 99.9 % of pixels (exactly on lavapipe). Measured on lavapipe (Mesa 22.3): AOVs
//! and ids bit-identical; radiance 99.96 % within 1e-4, worst value 2.1e-4 relative (2.1e-5 absolute).

use psdr::backend::{
    create_backend, create_backend_on, layout_check_spirv, Backend, BackendKind, CpuBackend, VkBackend,
};
use psdr::render::layout::*;
use psdr::render::{Frame, SceneData};
use psdr::scene::{sphere_mesh, Emitter, Material, MeshPart, Object, Pose, Scene};
use psdr_vk::{Buffer, Groups, Kernel, StorageBinding};

fn vk() -> Option<VkBackend> {
    psdr_tests::vulkan_or_skip(|| VkBackend::new(None))
}

fn room(width: u32, height: u32, spp: u32) -> Scene {
    psdr_tests::example_room(width, height, spp)
}

/// The room with a large smooth sphere (about 100k triangles, vertex normals and uvs), a second, two-sided
/// light with a sky gradient, and an EXR-textured material on it.
fn room_with_large_mesh_and_lights() -> Scene {
    let mut s = room(48, 36, 4);
    let dir = std::env::temp_dir().join(format!("psdr_vk_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let _cleanup = RemoveOnDrop(dir.clone());
    let exr = dir.join("ramp.exr");
    let ramp: Vec<f32> = (0..64).map(|i| i as f32 / 64.0).collect();
    psdr::output::write_exr_channels(
        &exr,
        8,
        8,
        &[("R".into(), ramp.clone()), ("G".into(), ramp.clone()), ("B".into(), ramp)],
    )
    .unwrap();
    let tex = psdr::scene::Texture::load(&exr, psdr::scene::TextureEncoding::Linear, 3).unwrap();
    s.textures.push(tex);
    let mut m = Material::diffuse("ramp", glam::Vec3::splat(0.5));
    m.albedo = psdr::scene::Color::Texture(s.textures.len() - 1);
    m.uv_transform.scale = glam::Vec2::new(3.0, 2.0);
    s.materials.push(m);
    let mut sphere: MeshPart = sphere_mesh(0.35, 160, 320, false);
    sphere.material = s.materials.len() - 1;
    assert!(sphere.indices.len() > 90_000, "the large mesh has {} triangles", sphere.indices.len());
    let pose = Pose { translation: glam::Vec3::new(0.9, 0.6, -1.2), ..Default::default() };
    s.objects.push(Object { name: "big_sphere".into(), parts: vec![sphere], pose, emitter: None });
    let mut lamp = psdr::scene::rectangle_mesh(0.3, 0.3);
    lamp.material = 0;
    let pose = Pose { translation: glam::Vec3::new(-1.2, 1.5, -1.0), ..Default::default() };
    // A window-like lamp on the wall, its radiance shaped by direction (the sky gradient, per channel).
    let emitter = Some(Emitter {
        sky_gradient: glam::Vec3::new(0.7, -0.4, 0.2),
        ..Emitter::uniform(glam::Vec3::new(3.0, 4.0, 6.0), true)
    });
    s.objects.push(Object { name: "wall_lamp".into(), parts: vec![lamp], pose, emitter });
    s.settings.max_depth = 4;
    s
}

struct RemoveOnDrop(std::path::PathBuf);

impl Drop for RemoveOnDrop {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// What a scene exercises, so each test's claim about its coverage is checked rather than assumed.
#[derive(Debug, Default)]
struct Features {
    triangles: usize,
    emitters: usize,
    normal_mapped: bool,
    textured_from: Vec<String>,
}

fn features(s: &Scene, d: &SceneData) -> Features {
    let mut textured_from: Vec<String> =
        s.textures.iter().filter_map(|t| t.path.as_ref()?.extension()?.to_str().map(str::to_ascii_lowercase)).collect();
    textured_from.sort();
    textured_from.dedup();
    Features {
        triangles: d.triangles.len(),
        emitters: d.emitters.len(),
        normal_mapped: d.materials.iter().any(|m| m.normal_tex != NONE),
        textured_from,
    }
}

fn render_both(vk: &mut VkBackend, s: &Scene) -> (Frame, Frame) {
    let d = SceneData::build(s).unwrap();
    let cpu = CpuBackend.render(&d, &s.settings, &|_, _| {}).unwrap();
    let gpu = vk.render(&d, &s.settings, &|_, _| {}).unwrap();
    psdr_tests::assert_no_validation_errors(vk);
    (cpu, gpu)
}

/// Fraction of values within 1e-4 relative (+1e-6 absolute), the worst relative and the worst absolute difference.
fn agreement(cpu: &[f32], gpu: &[f32]) -> (f64, f64, f64) {
    assert_eq!(cpu.len(), gpu.len());
    let mut ok = 0;
    let (mut worst_rel, mut worst_abs) = (0.0f64, 0.0f64);
    for (&c, &g) in cpu.iter().zip(gpu) {
        let diff = (c - g).abs() as f64;
        worst_rel = worst_rel.max(diff / (c.abs() as f64).max(1e-6));
        worst_abs = worst_abs.max(diff);
        if diff <= 1e-4 * c.abs() as f64 + 1e-6 {
            ok += 1;
        }
    }
    (ok as f64 / cpu.len().max(1) as f64, worst_rel, worst_abs)
}

fn check_frames(name: &str, cpu: &Frame, gpu: &Frame, spp: u32, tol: &psdr_tests::DeviceAgreement) {
    assert_eq!((cpu.width, cpu.height, cpu.object_count), (gpu.width, gpu.height, gpu.object_count));
    let (n, m) = (cpu.radiance.len() as f64, |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>());
    let (mc, mg) = (m(&cpu.radiance) / n, m(&gpu.radiance) / n);
    eprintln!("{name}: mean radiance cpu {mc:.6} gpu {mg:.6}");
    assert!((mc - mg).abs() <= tol.relative * mc.abs() + 1e-7, "{name}: image means differ: {mc} vs {mg}");
    for (aov, c, g) in [
        ("radiance", &cpu.radiance, &gpu.radiance),
        ("depth", &cpu.depth, &gpu.depth),
        ("normal", &cpu.normal, &gpu.normal),
        ("albedo", &cpu.albedo, &gpu.albedo),
        ("coverage", &cpu.coverage, &gpu.coverage),
    ] {
        let (frac, rel, abs) = agreement(c, g);
        eprintln!(
            "{name}: {aov}: {:.4} % within 1e-4, worst difference {rel:.2e} relative, {abs:.2e} absolute",
            100.0 * frac
        );
        assert!(frac >= tol.frame_fraction, "{name}: only {:.3} % of {aov} values agree within 1e-4", 100.0 * frac);
    }
    // Any disagreement is confined to single paths: no pixel differs by more than one path could contribute.
    for (i, (&c, &g)) in cpu.radiance.iter().zip(&gpu.radiance).enumerate() {
        let one_path = c.max(g) * spp as f32 + 1e-3;
        assert!((c - g).abs() <= one_path, "{name}: pixel {} channel {}: {c} vs {g}", i / 3, i % 3);
    }
    let same_ids = cpu.object_id.iter().zip(&gpu.object_id).filter(|(a, b)| a == b).count();
    let frac = same_ids as f64 / cpu.object_id.len() as f64;
    eprintln!("{name}: ids {:.4} % identical", 100.0 * frac);
    assert!(frac >= tol.frame_fraction, "{name}: only {:.3} % of object ids agree", 100.0 * frac);
    assert!(gpu.is_finite(), "{name}: the GPU frame has non-finite values");
    if tol.exact {
        assert_eq!(cpu.depth, gpu.depth, "{name}: depth not bit-identical");
        assert_eq!(cpu.normal, gpu.normal, "{name}: normal not bit-identical");
        assert_eq!(cpu.albedo, gpu.albedo, "{name}: albedo not bit-identical");
        assert_eq!(cpu.coverage, gpu.coverage, "{name}: coverage not bit-identical");
        assert_eq!(cpu.object_id, gpu.object_id, "{name}: object ids not identical");
    }
    // Rays differ only where a path does.
    let ray_diff = cpu.rays.abs_diff(gpu.rays);
    assert!(ray_diff as f64 <= 1e-3 * cpu.rays as f64, "{name}: ray counts {} vs {}", cpu.rays, gpu.rays);
}

#[test]
fn example_room_agrees_with_the_cpu() {
    let Some(mut vk) = vk() else { return };
    let s = room(64, 48, 8);
    let f = features(&s, &SceneData::build(&s).unwrap());
    assert!(f.normal_mapped && f.textured_from.contains(&"png".to_string()), "{f:?}");
    let (cpu, gpu) = render_both(&mut vk, &s);
    check_frames("room", &cpu, &gpu, 8, &psdr_tests::device_agreement(&vk));
}

#[test]
fn large_mesh_several_lights_exr_texture_and_deep_paths_agree() {
    let Some(mut vk) = vk() else { return };
    let s = room_with_large_mesh_and_lights();
    let f = features(&s, &SceneData::build(&s).unwrap());
    assert!(f.triangles > 50_000 && f.emitters >= 2 && f.textured_from.contains(&"exr".to_string()), "{f:?}");
    assert!(s.settings.max_depth >= 4, "deep paths");
    let (cpu, gpu) = render_both(&mut vk, &s);
    check_frames("large mesh", &cpu, &gpu, s.settings.spp, &psdr_tests::device_agreement(&vk));
}

/// The materials stage renders on the run's backend: its light-scale search (albedo divisions and scored
/// renders) ends at the same scale and albedos on the device as on the CPU. Its renders agree to float rounding
/// (above) and the search's choices are continuous in them, so the device's bound holds for both (measured:
/// 1e-7 on lavapipe and on an H100).
#[test]
fn light_scale_search_on_the_device_matches_the_cpu() {
    use psdr::scene::Color;
    use psdr::stages::{LightFitOptions, LightScaleOptions, Segment};
    let Some(mut vk) = vk() else { return };
    // A second, warmer lamp across the room: two lights whose split the search refits.
    let two_lamps = |mut s: Scene| {
        let mut lamp = s.objects.iter().find(|o| o.emitter.is_some()).unwrap().clone();
        lamp.name = "second_lamp".into();
        lamp.pose.translation = glam::Vec3::new(1.1, 1.9, 0.4);
        lamp.emitter = Some(Emitter::uniform(glam::Vec3::new(6.0, 4.0, 2.5), true));
        s.objects.push(lamp);
        s
    };
    let mut truth = two_lamps(room(48, 36, 8));
    for o in truth.objects.iter_mut() {
        if let Some(e) = o.emitter.as_mut() {
            e.radiance *= 1.3;
        }
    }
    let photo = CpuBackend.render(&SceneData::build(&truth).unwrap(), &truth.settings, &|_, _| {}).unwrap();
    // A segment per constant-albedo material: the pixels of the objects made of it alone.
    let constant = |m: usize| matches!(truth.materials[m].albedo, Color::Constant(_));
    let segments: Vec<Segment> = (0..truth.materials.len())
        .filter(|&m| constant(m))
        .map(|m| {
            let ids: Vec<u32> = (0..truth.objects.len() as u32)
                .filter(|&o| truth.objects[o as usize].parts.iter().all(|p| p.material == m))
                .collect();
            Segment {
                material: m,
                mask: photo.object_id.iter().map(|i| f32::from(u8::from(ids.contains(i)))).collect(),
            }
        })
        .filter(|s| s.mask.iter().sum::<f32>() >= 8.0)
        .collect();
    assert!(segments.len() >= 3, "only {} segments", segments.len());
    let mut start = two_lamps(room(48, 36, 8));
    for s in &segments {
        start.materials[s.material].albedo = Color::Constant(glam::Vec3::splat(0.5));
    }
    let opts = LightScaleOptions {
        range: (0.5, 2.0),
        steps: 5,
        rounds: 2,
        spp: 8,
        tolerance: 0.02,
        direct_spp: 4,
        downsample: 4,
        per_channel: true,
        // Each channel its own best: a gain near the threshold could choose differently on either backend.
        channel_min_gain: 0.0,
        extend: 0,
        resolution: 1.19,
        // The lights' split refitted at each factor: the unit renders and their fit on each backend too.
        split: Some(LightFitOptions { spp: 16, downsample: 4, ..Default::default() }),
        split_rounds: 1,
        ..Default::default()
    };
    // The render-per-factor search, then the one from renders kept by bounce (those renders on the CPU either
    // way, the divisions and the split's unit renders on each backend).
    for opts in [opts.clone(), LightScaleOptions { bounce_spp: 8, bounce_l1: true, ..opts }] {
        scale_search_agrees(&mut vk, &start, &photo.radiance, &segments, &opts);
    }
}

fn scale_search_agrees(
    vk: &mut VkBackend,
    start: &Scene,
    photo: &[f32],
    segments: &[psdr::stages::Segment],
    opts: &psdr::stages::LightScaleOptions,
) {
    use psdr::scene::Color;
    use psdr::stages::search_light_scale;
    let (mut on_cpu, mut on_vk) = (start.clone(), start.clone());
    let a = search_light_scale(&mut CpuBackend, &mut on_cpu, photo, segments, opts).unwrap();
    let b = search_light_scale(vk, &mut on_vk, photo, segments, opts).unwrap();
    psdr_tests::assert_no_validation_errors(vk);
    eprintln!("chosen scale cpu {:?} vk {:?}", a.chosen, b.chosen);
    let tol = psdr_tests::device_agreement(vk);
    for c in 0..3 {
        let rel = (a.chosen[c] - b.chosen[c]).abs() / a.chosen[c];
        assert!(
            f64::from(rel) <= tol.relative,
            "channel {c}: scale {} on the CPU, {} on the device",
            a.chosen[c],
            b.chosen[c]
        );
    }
    for s in segments {
        let (Color::Constant(x), Color::Constant(y)) =
            (on_cpu.materials[s.material].albedo, on_vk.materials[s.material].albedo)
        else {
            unreachable!("the division keeps albedos constant")
        };
        let rel = ((x - y).abs() / x.max(glam::Vec3::splat(1e-3))).max_element();
        assert!(
            f64::from(rel) <= tol.relative,
            "{}: albedo {x} on the CPU, {y} on the device",
            on_cpu.materials[s.material].name
        );
    }
}

/// Every kernel's pipeline is created by this device's driver (a driver may refuse what lavapipe accepts), but
/// the secondary boundary's 64-entry kernel, which a driver may refuse where it builds the 16-entry twin
/// (NVIDIA's, H100, driver 580.159: VK_ERROR_UNKNOWN for the large one).
#[test]
fn every_kernel_is_built_by_the_driver() {
    let Some(vk) = vk() else { return };
    let made = vk.create_kernels();
    for (name, built) in &made {
        eprintln!("{name}: {}", built.as_ref().map_or_else(|e| e.to_string(), |_| "built".into()));
    }
    assert!(made.len() >= 6, "{} kernels", made.len());
    let small_built = made.iter().any(|(n, b)| *n == "radiance_pose_secondary_small_vjp" && b.is_ok());
    let refused: Vec<&str> = made
        .iter()
        .filter(|(n, b)| b.is_err() && !(*n == "radiance_pose_secondary_vjp" && small_built))
        .map(|(n, _)| *n)
        .collect();
    assert!(refused.is_empty(), "the driver of {} refused {refused:?}", vk.name());
}

/// Paths of one segment use no sin/cos: on lavapipe the whole frame, radiance included, is bit-identical (this
/// catches any drift of the camera, BVH, shading, texture and emitter twins, however rare the affected pixels).
#[test]
fn one_segment_paths_are_bit_identical_on_lavapipe() {
    let Some(mut vk) = vk() else { return };
    for (name, mut s) in [("room", room(64, 48, 4)), ("large mesh", room_with_large_mesh_and_lights())] {
        s.settings.max_depth = 1;
        let (cpu, gpu) = render_both(&mut vk, &s);
        assert!(cpu.radiance.iter().any(|&x| x > 0.0), "{name}: the lights are in view");
        let tol = psdr_tests::device_agreement(&vk);
        if tol.exact {
            assert_eq!(cpu, gpu, "{name}: one-segment frames differ");
        } else {
            check_frames(name, &cpu, &gpu, s.settings.spp, &tol);
        }
    }
}

/// Passes of samples add into running sums in sample order: the pass size must not change a single bit.
#[test]
fn gpu_result_does_not_depend_on_the_pass_size() {
    let Some(mut vk) = vk() else { return };
    let s = room(32, 24, 6);
    let d = SceneData::build(&s).unwrap();
    let whole = vk.render(&d, &s.settings, &|_, _| {}).unwrap();
    vk.set_pass_path_samples(1); // one sample per pass
    let passes = vk.render(&d, &s.settings, &|_, _| {}).unwrap();
    assert_eq!(whole, passes, "one pass and six passes of the same seed differ");
    psdr_tests::assert_no_validation_errors(&vk);
}

#[test]
fn shared_struct_layouts_round_trip_through_a_kernel() {
    let Some(vk) = vk() else { return };
    let ctx = vk.context();
    // Distinct values in every field (element 1 of each array; element 0 is zero).
    let mut k = 0u32;
    let mut f = || {
        k += 1;
        k as f32 + 0.25
    };
    let mut node: BvhNode = bytemuck::Zeroable::zeroed();
    node.p = glam::Vec3::new(f(), f(), f());
    node.e = [101, 102, 103];
    node.imask = 104;
    node.child_base_idx = 7;
    node.primitive_base_idx = 11;
    // Distinct bytes in every [u8; 8] field, so a swapped word or byte order shows.
    for (k, field) in [
        &mut node.child_meta,
        &mut node.child_min_x,
        &mut node.child_max_x,
        &mut node.child_min_y,
        &mut node.child_max_y,
        &mut node.child_min_z,
        &mut node.child_max_z,
    ]
    .into_iter()
    .enumerate()
    {
        *field = std::array::from_fn(|i| (k * 8 + i + 1) as u8);
    }
    let tri = TriangleGeom {
        v0: [f(), f(), f()],
        material: 3,
        e1: [f(), f(), f()],
        object: 4,
        e2: [f(), f(), f()],
        light: 5,
    };
    let sh = TriangleShading {
        n0: [f(), f(), f()],
        flags: 6,
        n1: [f(), f(), f()],
        emitter: 8,
        n2: [f(), f(), f()],
        _pad0: 9,
        uv0: [f(), f()],
        uv1: [f(), f()],
        uv2: [f(), f()],
        _pad1: [10, 12],
        ng: [f(), f(), f()],
        _pad2: 41,
        dpdu: [f(), f(), f()],
        _pad3: 42,
        dpdv: [f(), f(), f()],
        _pad4: 43,
    };
    let mat = MaterialGpu {
        albedo: [f(), f(), f()],
        albedo_tex: 13,
        roughness: f(),
        roughness_tex: 14,
        specular: f(),
        specular_tex: 15,
        normal_tex: 16,
        _pad: [17, 18, 19],
        uv_row0: [f(), f(), f(), f()],
        uv_row1: [f(), f(), f(), f()],
    };
    let tex = TextureGpu { offset: 20, width: 21, height: 22, channels: 23 };
    let em = EmitterGpu { radiance: [f(), f(), f()], two_sided: 24, sky_gradient: [f(), f(), f()], _pad0: f() };
    let light = LightGpu { triangle: 25, emitter: 26, cdf: f(), pmf: f() };
    let cam = CameraGpu {
        origin: [f(), f(), f()],
        tan_half_fov: f(),
        forward: [f(), f(), f()],
        aspect: f(),
        right: [f(), f(), f()],
        width: 27,
        up: [f(), f(), f()],
        height: 28,
    };
    let fp = FrameParams {
        seed: 29,
        spp: 30,
        max_depth: 31,
        rr_depth: 32,
        light_count: 33,
        object_count: 34,
        sample_begin: 35,
        sample_count: 36,
    };
    fn two<T: bytemuck::Pod>(x: T) -> [T; 2] {
        [bytemuck::Zeroable::zeroed(), x]
    }
    let words = |v: &[u8]| -> Vec<u32> { bytemuck::cast_slice::<u8, u32>(v).to_vec() };
    // Expected: each struct's own bytes (its fields in memory order, padding included), then the push constants.
    let mut expected = vec![];
    expected.extend(words(bytemuck::bytes_of(&node)));
    expected.extend(words(bytemuck::bytes_of(&tri)));
    expected.extend(words(bytemuck::bytes_of(&sh)));
    expected.extend(words(bytemuck::bytes_of(&mat)));
    expected.extend(words(bytemuck::bytes_of(&tex)));
    expected.extend(words(bytemuck::bytes_of(&em)));
    expected.extend(words(bytemuck::bytes_of(&light)));
    expected.extend(words(bytemuck::bytes_of(&cam)));
    expected.extend(words(bytemuck::bytes_of(&fp)));
    let bufs: (Buffer<BvhNode>, Buffer<TriangleGeom>, Buffer<TriangleShading>, Buffer<MaterialGpu>) = (
        Buffer::from_slice(ctx, "nodes", &two(node)).unwrap(),
        Buffer::from_slice(ctx, "triangles", &two(tri)).unwrap(),
        Buffer::from_slice(ctx, "shading", &two(sh)).unwrap(),
        Buffer::from_slice(ctx, "materials", &two(mat)).unwrap(),
    );
    let textures = Buffer::from_slice(ctx, "textures", &two(tex)).unwrap();
    let emitters = Buffer::from_slice(ctx, "emitters", &two(em)).unwrap();
    let lights = Buffer::from_slice(ctx, "lights", &two(light)).unwrap();
    let cams = Buffer::from_slice(ctx, "camera", &two(cam)).unwrap();
    let out = Buffer::<u32>::zeroed(ctx, "out", expected.len()).unwrap();
    let kernel: Kernel<FrameParams> = Kernel::new(ctx, "layout_check", &layout_check_spirv().unwrap(), 9).unwrap();
    let bindings: [&dyn StorageBinding; 9] =
        [&bufs.0, &bufs.1, &bufs.2, &bufs.3, &textures, &emitters, &lights, &cams, &out];
    kernel.dispatch(&bindings, &fp, Groups::new(1, 1, 1)).unwrap();
    let got = out.download().unwrap();
    psdr_tests::assert_no_validation_errors(&vk);
    for (i, (g, e)) in got.iter().zip(&expected).enumerate() {
        assert_eq!(g, e, "word {i}: kernel read {g:#x}, Rust wrote {e:#x}");
    }
}

/// The device can be picked by a part of its name; a wrong name, or a name given to the CPU backend, is an error
/// that says what was asked for.
#[test]
fn the_device_is_picked_by_name() {
    let Some(vk) = vk() else { return };
    let name = vk.context().capabilities().device_name.clone();
    let part = name.split_whitespace().next().unwrap().to_uppercase();
    match create_backend_on(BackendKind::Vk, Some(&part)) {
        Ok(b) => assert!(b.name().contains(&name), "asked for {part}, got {}", b.name()),
        Err(e) => panic!("asked for {part} (of {name}): {e}"),
    }
    let Err(e) = create_backend_on(BackendKind::Vk, Some("no-such-gpu-3f9a")) else { panic!("a device was invented") };
    assert!(e.to_string().contains("no-such-gpu-3f9a"), "{e}");
    let Err(e) = create_backend_on(BackendKind::Cpu, Some("llvmpipe")) else { panic!("the cpu backend took a device") };
    assert!(e.to_string().contains("cpu"), "{e}");
}

/// Without any Vulkan driver the vk backend is an error that says what to install, never a panic. Runs in a child
/// process of this test binary (with no driver visible to the loader) so the other tests keep their device.
#[test]
fn no_vulkan_driver_is_an_error_naming_the_package() {
    const CHILD: &str = "PSDR_VK_TEST_NO_DRIVER_CHILD";
    if std::env::var_os(CHILD).is_some() {
        match create_backend(BackendKind::Vk) {
            Ok(b) => panic!("got a backend with no driver: {}", b.name()),
            Err(e) => {
                assert!(e.to_string().contains("mesa-vulkan-drivers"), "the error does not say what to install: {e}")
            }
        }
        return;
    }
    let no_icd = "/nonexistent/psdr-no-icd.json";
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "no_vulkan_driver_is_an_error_naming_the_package", "--nocapture", "--test-threads=1"])
        .env(CHILD, "1")
        .env("VK_ICD_FILENAMES", no_icd)
        .env("VK_DRIVER_FILES", no_icd)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).to_string() + String::from_utf8_lossy(&out.stderr).as_ref();
    assert!(out.status.success(), "child failed:\n{text}");
    assert!(text.contains("1 passed"), "the child ran no test:\n{text}");
}
