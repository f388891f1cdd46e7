//! Compiles the test kernels in `vk/shaders` (see shader_build.rs, shared with psdr's build script).

include!("shader_build.rs");

fn main() {
    compile_shaders(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders"));
}
