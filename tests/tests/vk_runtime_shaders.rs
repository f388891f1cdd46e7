//! Kernels compiled at run time from a folder of GLSL (`PSDR_SHADER_DIR`, `VkBackend::with_shader_dir`), so a
//! researcher edits a kernel and reruns without rebuilding Rust: a copy of shaders/ renders exactly what the
//! build's SPIR-V renders; an edit takes effect; a compile error names the file and the line.
//! Without a Vulkan device these tests print a note and pass, unless PSDR_REQUIRE_VULKAN=1 (CI sets it).

use psdr::backend::{Backend, VkBackend};
use psdr::render::SceneData;
use std::path::{Path, PathBuf};

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let target = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_dir(&p, &target);
        } else {
            std::fs::copy(&p, &target).unwrap();
        }
    }
}

fn shaders_copy(name: &str) -> PathBuf {
    let dir = psdr_tests::temp_dir(name).join("shaders");
    copy_dir(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders"), &dir);
    dir
}

fn backend(dir: Option<&Path>) -> Option<VkBackend> {
    psdr_tests::vulkan_or_skip(|| VkBackend::with_shader_dir(None, dir))
}

#[test]
fn a_copy_of_the_shaders_renders_what_the_build_renders_and_edits_take_effect() {
    let Some(mut built) = backend(None) else { return };
    let dir = shaders_copy("runtime-shaders");
    let mut runtime = backend(Some(&dir)).unwrap();
    let s = psdr_tests::example_room(24, 18, 4);
    let d = SceneData::build(&s).unwrap();
    let a = built.render(&d, &s.settings, &|_, _| {}).unwrap();
    let b = runtime.render(&d, &s.settings, &|_, _| {}).unwrap();
    assert_eq!(a.radiance, b.radiance, "the same source compiled at run time renders the same image");
    // An edit: the kernel writes twice the radiance.
    let kernel = dir.join("render/path_trace.comp");
    let src = std::fs::read_to_string(&kernel).unwrap();
    let edited = src.replace("radiance += ps.radiance;", "radiance += 2.0 * ps.radiance;");
    assert_ne!(edited, src, "the kernel's accumulation line moved; update this test");
    std::fs::write(&kernel, edited).unwrap();
    let mut doubled = backend(Some(&dir)).unwrap();
    let c = doubled.render(&d, &s.settings, &|_, _| {}).unwrap();
    for (x, y) in a.radiance.iter().zip(&c.radiance) {
        assert!((2.0 * x - y).abs() <= 1e-6 * y.abs().max(1.0), "{x} doubled is not {y}");
    }
}

#[test]
fn a_compile_error_names_the_file_and_the_line() {
    if backend(None).is_none() {
        return;
    }
    let dir = shaders_copy("runtime-shaders-error");
    // The error sits in an included file (the sweep the adjoint kernels share): its name and line are reported.
    let include = dir.join("grad/interior/material_light.glsl");
    let src = std::fs::read_to_string(&include).unwrap();
    let line = src.lines().position(|l| l.contains("vec3 r_next = vec3(0.0);")).unwrap() + 1;
    std::fs::write(&include, src.replace("vec3 r_next = vec3(0.0);", "vec3 r_next = vec3(0.0) undefined_name;"))
        .unwrap();
    let err = VkBackend::with_shader_dir(None, Some(&dir)).err().expect("a broken kernel is refused").to_string();
    assert!(err.contains("material_light.glsl") && err.contains(&format!(":{line}:")), "{err}");
}
