//! Compiles the renderer's GLSL kernels (`shaders/**/*.comp` at the workspace root: `render/` the primal,
//! `grad/` the adjoint passes, mirroring psdr/src) to SPIR-V in `$OUT_DIR`;
//! `psdr_vk::include_spirv!` loads them. The compiling itself is shared with psdr-vk's build script.
//!
//! Then every float arithmetic result is decorated NoContraction (vk/src/no_contraction.rs says why).

include!("../vk/shader_build.rs");

use std::path::{Path, PathBuf};

fn main() {
    // Read at run time (not env!): the build script binary may outlive a move of the checkout.
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let shaders = manifest.join("../shaders");
    compile_shaders(&shaders);
    println!("cargo:rerun-if-changed={}", manifest.join("../vk/src/no_contraction.rs").display());
    println!("cargo:rerun-if-changed={}", manifest.join("../vk/shader_build.rs").display());
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    for path in shader_files(&shaders).iter().filter(|p| p.extension().is_some_and(|e| e == "comp")) {
        let rel = path.strip_prefix(&shaders).expect("under shaders/").with_extension("spv");
        decorate_no_contraction_file(&out.join(rel));
    }
}

include!("../vk/src/no_contraction.rs");

/// Decorates one compiled kernel in place (see vk/src/no_contraction.rs).
fn decorate_no_contraction_file(spv: &Path) {
    let bytes = std::fs::read(spv).unwrap_or_else(|e| panic!("cannot read {}: {e}", spv.display()));
    let words: Vec<u32> = bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let patched = decorate_no_contraction(&words).unwrap_or_else(|e| panic!("{}: {e}", spv.display()));
    let bytes: Vec<u8> = patched.iter().flat_map(|w| w.to_le_bytes()).collect();
    std::fs::write(spv, bytes).unwrap_or_else(|e| panic!("cannot write {}: {e}", spv.display()));
}
