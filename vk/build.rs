//! Compiles the test kernels in `vk/shaders` (see shader_build.rs, shared with psdr's build script), and links
//! the run-time shader compiler's static libraries.

include!("shader_build.rs");

fn main() {
    compile_shaders(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders"));
    // The run-time compiler (shaderc, `prefer-static-linking`) links Debian's libshaderc_combined.a, which needs
    // the glslang and SPIRV-Tools static libraries beside it and the C++ runtime: Debian's dynamic libshaderc does not link with the shaderc crate.
    println!("cargo:rustc-link-search=native=/usr/lib/x86_64-linux-gnu");
    for lib in [
        "glslang",
        "SPIRV",
        "MachineIndependent",
        "GenericCodeGen",
        "OSDependent",
        "OGLCompiler",
        "HLSL",
        "SPIRV-Tools-opt",
        "SPIRV-Tools",
    ] {
        println!("cargo:rustc-link-lib=static={lib}");
    }
    println!("cargo:rustc-link-lib=dylib=stdc++");
}
