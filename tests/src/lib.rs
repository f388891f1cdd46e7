//! Shared helpers for the cross-crate tests: scenes built in code, a pinhole camera written independently of
//! the renderer's, per-pixel sample statistics from the path-tracing kernel, temporary folders and chi-square
//! bounds.

use glam::{Vec2, Vec3};
use psdr::render::cpu::frame_params;
use psdr::render::path_trace::trace_path;
use psdr::render::{render_cpu, Frame, SceneData};
use psdr::scene::{Camera, Emitter, Material, MeshPart, Object, Pose, RenderSettings, Scene};
use std::path::PathBuf;

pub mod furniture;
pub mod known_geometry;
pub mod real_rooms;
pub mod rooms;
pub mod sweet_home;
pub mod texture_queries;

/// An empty scene seen by a look-at camera.
pub fn empty_scene(camera: Camera, settings: RenderSettings) -> Scene {
    Scene {
        camera,
        settings,
        materials: Vec::new(),
        textures: Vec::new(),
        objects: Vec::new(),
        source: None,
        requires_grad: Vec::new(),
    }
}

/// Adds a material and returns its index.
pub fn add_material(scene: &mut Scene, m: Material) -> usize {
    scene.materials.push(m);
    scene.materials.len() - 1
}

/// A diffuse (Lambertian only: specular 0) material with RGB albedo.
pub fn lambert(name: &str, albedo: Vec3) -> Material {
    Material::diffuse(name, albedo)
}

/// Adds an object made of one part with material `material`; returns its index.
pub fn add_object(
    scene: &mut Scene,
    name: &str,
    mut part: MeshPart,
    material: usize,
    pose: Pose,
    emitter: Option<Emitter>,
) -> usize {
    part.material = material;
    scene.objects.push(Object { name: name.to_string(), parts: vec![part], pose, emitter });
    scene.objects.len() - 1
}

/// The part with its shading normals removed (flat shading: shading normal = geometric normal).
pub fn flat(mut part: MeshPart) -> MeshPart {
    part.normals = None;
    part
}

/// One-sided emitter of radiance `le`.
pub fn emitter(le: Vec3) -> Option<Emitter> {
    Some(Emitter::uniform(le, false))
}

/// The shipped example room at `width` x `height` and `spp`.
pub fn example_room(width: u32, height: u32, spp: u32) -> Scene {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/room/scene.json");
    let mut s = psdr::scene::load_scene(std::path::Path::new(path)).expect("example room loads");
    (s.camera.width, s.camera.height, s.settings.spp) = (width, height, spp);
    s
}

/// Renders on the CPU backend.
pub fn render(scene: &Scene) -> Frame {
    let d = SceneData::build(scene).expect("scene builds");
    render_cpu(&d, &scene.settings, &|_, _| {})
}

/// Mean and unbiased per-sample variance of the radiance of `n` samples of pixel (px, py), drawn by the
/// path-tracing kernel with the scene's seed (sample indices 0..n).
pub fn pixel_samples(d: &SceneData, s: &RenderSettings, px: u32, py: u32, n: u32) -> (Vec3, Vec3) {
    let fp = frame_params(d, s);
    let (mut sum, mut sum2) = ([0.0f64; 3], [0.0f64; 3]);
    for k in 0..n {
        let r = trace_path(d, &fp, px, py, k).radiance;
        for c in 0..3 {
            sum[c] += r[c] as f64;
            sum2[c] += (r[c] as f64).powi(2);
        }
    }
    let nf = n as f64;
    let mean = sum.map(|x| x / nf);
    let var: Vec<f64> = (0..3).map(|c| ((sum2[c] - nf * mean[c] * mean[c]) / (nf - 1.0)).max(0.0)).collect();
    (Vec3::new(mean[0] as f32, mean[1] as f32, mean[2] as f32), Vec3::new(var[0] as f32, var[1] as f32, var[2] as f32))
}

/// Camera-space direction (x right, y up, z forward; not normalized, z = 1) through continuous image position
/// (x, y) in pixels, (0, 0) the top-left corner: the pinhole model written from its definition (vertical fov,
/// square pixels), independently of psdr::render::camera.
pub fn pinhole_dir_camera_space(cam: &Camera, x: f64, y: f64) -> [f64; 3] {
    let tan = ((cam.fov_y_deg as f64).to_radians() * 0.5).tan();
    let (w, h) = (cam.width as f64, cam.height as f64);
    let px = (2.0 * x / w - 1.0) * tan * (w / h);
    let py = (1.0 - 2.0 * y / h) * tan;
    [px, py, 1.0]
}

/// Image position (pixels) where camera-space direction (x, y, z) (z > 0) projects: the inverse of
/// `pinhole_dir_camera_space`.
pub fn project_camera_space(cam: &Camera, p: [f64; 3]) -> Vec2 {
    let tan = ((cam.fov_y_deg as f64).to_radians() * 0.5).tan();
    let (w, h) = (cam.width as f64, cam.height as f64);
    let ndc_x = p[0] / p[2] / (tan * w / h);
    let ndc_y = p[1] / p[2] / tan;
    Vec2::new(((ndc_x + 1.0) * 0.5 * w) as f32, ((1.0 - ndc_y) * 0.5 * h) as f32)
}

/// A fresh, empty folder under the system temp dir, unique to this process and `name`.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("psdr-tests-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create temp dir");
    dir
}

/// Upper quantile of the chi-square distribution with `dof` degrees of freedom at the standard-normal quantile
/// `z` (Wilson-Hilferty: accurate to about 1 % of the quantile for dof >= 10). z = 4.75 is a p-value of 1e-6.
pub fn chi2_upper_quantile(dof: f64, z: f64) -> f64 {
    let a = 2.0 / (9.0 * dof);
    dof * (1.0 - a + z * a.sqrt()).powi(3)
}

/// Pearson chi-square statistic of observed counts against expected counts, pooling bins whose expected count
/// is below `min_expected` into one bin (the usual validity condition). Returns (statistic, degrees of freedom).
pub fn chi2_pooled(observed: &[f64], expected: &[f64], min_expected: f64) -> (f64, usize) {
    let (mut stat, mut bins) = (0.0, 0usize);
    let (mut po, mut pe) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e < min_expected {
            po += o;
            pe += e;
        } else {
            stat += (o - e) * (o - e) / e;
            bins += 1;
        }
    }
    if pe > 0.0 {
        stat += (po - pe) * (po - pe) / pe;
        bins += 1;
    } else if po > 0.0 {
        // Samples where the density says none can land.
        return (f64::INFINITY, bins.max(2) - 1);
    }
    (stat, bins.max(2) - 1)
}

/// SplitMix64: a small independent generator for tests that must not depend on the renderer's sampler.
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1) with 24 bits, like the renderer's sampler (so every value is an exact f32).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / 16_777_216.0)
    }
}

/// A scene file (format psdr-scene v1) with a small camera looking at the origin from +z, and the given
/// `materials` and `shapes` JSON arrays (without brackets).
pub fn scene_json(materials: &str, shapes: &str) -> String {
    format!(
        r#"{{
  "format": "psdr-scene", "version": 1,
  "camera": {{ "origin": [0, 0, 4], "target": [0, 0, 0], "fov_y": 45, "width": 16, "height": 12 }},
  "render": {{ "spp": 2, "max_depth": 3, "seed": 1 }},
  "materials": [{materials}],
  "shapes": [{shapes}]
}}"#
    )
}

/// Writes `text` to `dir/name` and returns the path.
pub fn write_file(dir: &std::path::Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write test file");
    p
}

/// The psdr binary, when cargo has built it next to this test (`cargo test --workspace` does); None (with a
/// note) otherwise, so a test that drives the binary skips instead of failing on a partial build.
pub fn psdr_bin() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let dir = exe.parent().and_then(std::path::Path::parent)?;
    let bin = dir.join(format!("psdr{}", std::env::consts::EXE_SUFFIX));
    if !bin.is_file() {
        eprintln!("skipped: the psdr binary is not built in this target dir (run cargo test --workspace)");
        return None;
    }
    Some(bin)
}

/// Khronos' glTF validator (npm gltf-validator in ~/.cache/psdr-npm, run by node), if installed; without it a
/// test skips that check unless PSDR_REQUIRE_GLTF_VALIDATOR=1.
pub fn gltf_validator() -> Option<PathBuf> {
    let home = std::env::var_os("HOME").map(PathBuf::from)?;
    let dir = home.join(".cache/psdr-npm/node_modules/gltf-validator");
    let node = std::process::Command::new("node").arg("--version").output().is_ok_and(|o| o.status.success());
    if node && dir.join("index.js").is_file() {
        return Some(dir);
    }
    assert!(
        std::env::var_os("PSDR_REQUIRE_GLTF_VALIDATOR").is_none(),
        "PSDR_REQUIRE_GLTF_VALIDATOR is set but node or gltf-validator is missing (bash .ci/install-deps)"
    );
    eprintln!("skipping the validator: node or ~/.cache/psdr-npm/node_modules/gltf-validator missing");
    None
}

/// The validator's (errors, warnings) for a file.
pub fn validate_glb(dir: &std::path::Path, glb: &std::path::Path) -> (u64, u64, String) {
    let script = format!(
        "const v=require('{}');const d=new Uint8Array(require('fs').readFileSync('{}'));\
         v.validateBytes(d).then(r=>console.log(JSON.stringify(r.issues))).catch(e=>{{console.error(e);process.exit(1)}});",
        dir.display(),
        glb.display()
    );
    let out = std::process::Command::new("node").args(["-e", &script]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let issues: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    (issues["numErrors"].as_u64().unwrap(), issues["numWarnings"].as_u64().unwrap(), issues["messages"].to_string())
}

/// The backend the finite-difference gradient tests run on: the CPU, or the Vulkan device with
/// PSDR_TEST_BACKEND=vk (renders, analytic gradients and central differences all there; the bounds are the
/// same). CI runs the CPU; the device run is a manual check, as lavapipe would multiply CI's time.
pub fn fd_backend() -> Box<dyn psdr::backend::Backend> {
    match std::env::var("PSDR_TEST_BACKEND").as_deref() {
        Ok("vk") => Box::new(psdr::backend::VkBackend::new(None).expect("PSDR_TEST_BACKEND=vk needs a Vulkan device")),
        Ok("cpu") | Ok("") | Err(_) => Box::new(psdr::backend::CpuBackend),
        Ok(other) => panic!("PSDR_TEST_BACKEND={other}: expected cpu or vk"),
    }
}

/// A Vulkan backend from `open`, or None with a note when no device works, unless PSDR_REQUIRE_VULKAN=1 (CI
/// sets it), which turns a missing device into a failure.
pub fn vulkan_or_skip(
    open: impl FnOnce() -> psdr::Result<psdr::backend::VkBackend>,
) -> Option<psdr::backend::VkBackend> {
    match open() {
        Ok(b) => Some(b),
        Err(e) if std::env::var("PSDR_REQUIRE_VULKAN").is_ok_and(|v| v == "1") => {
            panic!("PSDR_REQUIRE_VULKAN=1 but the Vulkan backend failed: {e}")
        }
        Err(e) => {
            eprintln!("skipping: no Vulkan device ({e})");
            None
        }
    }
}

/// How closely a Vulkan device's results may differ from the CPU's in the consistency tests.
///
/// Lavapipe computes division and square roots exactly (IEEE) and keeps the kernels' NoContraction, so results
/// differ only where sin/cos (BSDF sampling) or a flipped discrete decision do: 1e-4 relative, 99.9 % of a
/// frame's values within 1e-4, and outputs without sin/cos bit-identical. A GPU driver may round division, sqrt
/// and inversesqrt by a few ulp and approximate sin/cos to 2^-11 absolute (Vulkan's precision rules), so
/// directions differ in their fourth digit. Measured on an NVIDIA H100 (driver 580.159, 2026-11-27): radiance
/// 98.8 % of values within 1e-4 (worst 3.4e-3 relative), normals 99.0 %; gradients 1.4e-4 to 3.1e-4 relative,
/// one component of 2e-4 of the largest 2.3e-3; every finite-difference check on the device passed. The bounds
/// there are about four times the worst measured: 1e-2 relative (1e-4 of the largest absolute), 97 % of a
/// frame's values within 1e-4.
pub struct DeviceAgreement {
    /// Bound on the worst relative difference of a result.
    pub relative: f64,
    /// Bound on the worst absolute difference of a gradient component, as a share of the largest.
    pub absolute: f64,
    /// Share of a frame's values that must agree within 1e-4 relative.
    pub frame_fraction: f64,
    /// Outputs that use no sin/cos are bit-identical (lavapipe).
    pub exact: bool,
}

pub fn device_agreement(vk: &psdr::backend::VkBackend) -> DeviceAgreement {
    if vk.context().capabilities().device_name.contains("llvmpipe") {
        DeviceAgreement { relative: 1e-4, absolute: 1e-6, frame_fraction: 0.999, exact: true }
    } else {
        DeviceAgreement { relative: 1e-2, absolute: 1e-4, frame_fraction: 0.97, exact: false }
    }
}

/// With the Khronos validation layer loaded (debug builds, when installed; CI installs it), no validation error
/// (missing barriers, bad descriptors, out-of-bounds setup).
pub fn assert_no_validation_errors(vk: &psdr::backend::VkBackend) {
    let ctx = vk.context();
    if std::env::var("PSDR_REQUIRE_VULKAN").is_ok_and(|v| v == "1") && cfg!(debug_assertions) {
        assert!(ctx.validation_enabled(), "CI must run the Vulkan tests with the validation layer");
    }
    let errors = ctx.validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
}
