// Shared by the build scripts of psdr-vk (its test kernels) and psdr (the renderer's kernels), which pull it in
// with `include!`: compiles every `*.comp` under a folder (subfolders included, with their `*.glsl` includes)
// to `$OUT_DIR/<relative path without .comp>.spv` with glslangValidator, for `psdr_vk::include_spirv!`
// (`shaders/render/path_trace.comp` -> `include_spirv!("render/path_trace")`). Includes resolve against the
// including file's folder, then the root folder.

/// The `.comp` and `.glsl` files under `dir`, sorted.
pub fn shader_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display())) {
        let path = entry.expect("readable directory entry").path();
        if path.is_dir() {
            out.extend(shader_files(&path));
        } else if path.extension().is_some_and(|e| e == "comp" || e == "glsl") {
            out.push(path);
        }
    }
    out.sort();
    out
}

/// Compiles every `*.comp` under `shader_dir`; panics with the compiler's messages (a build error) when one
/// fails.
pub fn compile_shaders(shader_dir: &std::path::Path) {
    use std::path::PathBuf;
    use std::process::Command;

    let out_dir = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    let compiler = std::env::var("GLSLANG_VALIDATOR").unwrap_or_else(|_| "glslangValidator".into());
    println!("cargo:rerun-if-env-changed=GLSLANG_VALIDATOR");
    println!("cargo:rerun-if-changed={}", shader_dir.display());

    let shaders = shader_files(shader_dir);
    for path in &shaders {
        println!("cargo:rerun-if-changed={}", path.display());
    }

    let mut failures = Vec::new();
    for path in shaders.iter().filter(|p| p.extension().is_some_and(|e| e == "comp")) {
        let rel = path.strip_prefix(shader_dir).expect("under the shader folder").with_extension("spv");
        let spv = out_dir.join(rel);
        std::fs::create_dir_all(spv.parent().expect("a file has a folder")).expect("OUT_DIR is writable");
        let output = Command::new(&compiler)
            .args(["-V", "--target-env", "vulkan1.2"])
            .arg(format!("-I{}", shader_dir.display()))
            .arg("-o")
            .arg(&spv)
            .arg(path)
            .output()
            .unwrap_or_else(|e| {
                panic!(
                    "cannot run `{compiler}` ({e}); it compiles the GLSL kernels to SPIR-V. \
                     Install it with `apt-get install glslang-tools`, or point GLSLANG_VALIDATOR at it."
                )
            });
        if !output.status.success() {
            failures.push(format!(
                "{}:\n{}{}",
                path.display(),
                String::from_utf8_lossy(&output.stdout),
                String::from_utf8_lossy(&output.stderr)
            ));
        }
    }
    if !failures.is_empty() {
        panic!("shader compilation failed:\n{}", failures.join("\n"));
    }
}
