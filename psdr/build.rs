//! Compiles the renderer's GLSL kernels (`shaders/*.comp` at the workspace root) to SPIR-V in `$OUT_DIR`;
//! `psdr_vk::include_spirv!` loads them. The compiling itself is shared with psdr-vk's build script.

include!("../vk/shader_build.rs");

fn main() {
    compile_shaders(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders"));
}
