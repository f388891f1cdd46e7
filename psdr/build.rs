//! Compiles the renderer's GLSL kernels (`shaders/*.comp` at the workspace root) to SPIR-V in `$OUT_DIR`;
//! `psdr_vk::include_spirv!` loads them. The compiling itself is shared with psdr-vk's build script.
//!
//! Then every float arithmetic result is decorated NoContraction: Rust never fuses or reassociates float
//! operations, and without the decoration drivers may (Mesa's NIR rewrites a*b + a*c to a*(b + c), GPUs fuse
//! multiply-adds), which would break the bit-for-bit twinning of the CPU reference.

include!("../vk/shader_build.rs");

use std::path::{Path, PathBuf};

fn main() {
    // Read at run time (not env!): the build script binary may outlive a move of the checkout.
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let shaders = manifest.join("../shaders");
    compile_shaders(&shaders);
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    for entry in std::fs::read_dir(&shaders).expect("shaders/ was just compiled") {
        let path = entry.expect("readable directory entry").path();
        if path.extension().is_some_and(|e| e == "comp") {
            let stem = path.file_stem().expect("file name").to_string_lossy().to_string();
            decorate_no_contraction(&out.join(format!("{stem}.spv")));
        }
    }
}

/// Adds `OpDecorate %result NoContraction` for the result of every float arithmetic instruction of a module.
fn decorate_no_contraction(spv: &Path) {
    const OP_DECORATE: u32 = 71;
    const OP_MEMBER_DECORATE: u32 = 72;
    const NO_CONTRACTION: u32 = 42;
    // OpFNegate, OpFAdd, OpFSub, OpFMul, OpFDiv, OpFRem, OpFMod, OpVectorTimesScalar, OpMatrixTimesScalar,
    // OpVectorTimesMatrix, OpMatrixTimesVector, OpMatrixTimesMatrix, OpOuterProduct, OpDot: [op, type, result, ..].
    const ARITHMETIC: [u32; 14] = [127, 129, 131, 133, 136, 140, 141, 142, 143, 144, 145, 146, 147, 148];
    let bytes = std::fs::read(spv).unwrap_or_else(|e| panic!("cannot read {}: {e}", spv.display()));
    let words: Vec<u32> = bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let (mut decorations, mut annotations_at) = (Vec::new(), None);
    let mut i = 5; // after the header
    while i < words.len() {
        let (count, op) = ((words[i] >> 16) as usize, words[i] & 0xffff);
        assert!(count > 0 && i + count <= words.len(), "{}: malformed instruction at word {i}", spv.display());
        if (op == OP_DECORATE || op == OP_MEMBER_DECORATE) && annotations_at.is_none() {
            annotations_at = Some(i);
        }
        if ARITHMETIC.contains(&op) {
            decorations.extend([(3 << 16) | OP_DECORATE, words[i + 2], NO_CONTRACTION]);
        }
        i += count;
    }
    // Decorations belong in the annotation section; every kernel has one (its buffer bindings).
    let at = annotations_at.unwrap_or_else(|| panic!("{}: no annotation section", spv.display()));
    let patched: Vec<u32> = words[..at].iter().chain(&decorations).chain(&words[at..]).copied().collect();
    let bytes: Vec<u8> = patched.iter().flat_map(|w| w.to_le_bytes()).collect();
    std::fs::write(spv, bytes).unwrap_or_else(|e| panic!("cannot write {}: {e}", spv.display()));
}
