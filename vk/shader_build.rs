// Shared by the build scripts of psdr-vk (its test kernels) and psdr (the renderer's kernels), which pull it in
// with `include!`: compiles every `*.comp` of a folder (with its `*.glsl` includes) to
// `$OUT_DIR/<name>.spv` with glslangValidator, for `psdr_vk::include_spirv!`.

/// Compiles `shader_dir/*.comp`; panics with the compiler's messages (a build error) when one fails.
pub fn compile_shaders(shader_dir: &std::path::Path) {
    use std::path::PathBuf;
    use std::process::Command;

    let out_dir = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    let compiler = std::env::var("GLSLANG_VALIDATOR").unwrap_or_else(|_| "glslangValidator".into());
    println!("cargo:rerun-if-env-changed=GLSLANG_VALIDATOR");
    println!("cargo:rerun-if-changed={}", shader_dir.display());

    let mut shaders: Vec<PathBuf> = std::fs::read_dir(shader_dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", shader_dir.display()))
        .map(|entry| entry.expect("readable directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "comp" || e == "glsl"))
        .collect();
    shaders.sort();
    for path in &shaders {
        println!("cargo:rerun-if-changed={}", path.display());
    }

    let mut failures = Vec::new();
    for path in shaders.iter().filter(|p| p.extension().is_some_and(|e| e == "comp")) {
        let stem = path.file_stem().expect("file name").to_string_lossy();
        let spv = out_dir.join(format!("{stem}.spv"));
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
