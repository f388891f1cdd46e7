//! GLSL compiled at run time with shaderc, so that a researcher can edit a kernel and rerun without rebuilding
//! Rust (psdr reads `PSDR_SHADER_DIR`). Same rules as the build-time compilation (vulkan1.2 target,
//! `#include` resolved against the including file's folder, then the root folder), then the same NoContraction
//! decoration, so a kernel compiled either way computes the same thing. Errors keep the compiler's
//! `file:line: error: ...` lines.

use crate::error::{Result, VkError};
use std::path::{Path, PathBuf};

include!("no_contraction.rs");

/// Compiles the compute shader `root/rel` (e.g. `render/path_trace.comp`) to SPIR-V words, decorated
/// NoContraction.
pub fn compile_glsl_file(root: &Path, rel: &str) -> Result<Vec<u32>> {
    let path = root.join(rel);
    let file = path.display().to_string();
    let err = |message: String| VkError::ShaderCompile { file: file.clone(), message };
    let source = std::fs::read_to_string(&path).map_err(|e| err(format!("cannot read it: {e}")))?;
    let compiler = shaderc::Compiler::new().map_err(|e| err(format!("shaderc could not start: {e}")))?;
    let mut options = shaderc::CompileOptions::new().map_err(|e| err(format!("shaderc options: {e}")))?;
    options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_2 as u32);
    let root = root.to_path_buf();
    options.set_include_callback(move |requested, _kind, requester, _depth| {
        let from = Path::new(requester).parent().map(Path::to_path_buf).unwrap_or_default();
        let candidates: [PathBuf; 2] = [from.join(requested), root.join(requested)];
        for c in &candidates {
            if let Ok(content) = std::fs::read_to_string(c) {
                return Ok(shaderc::ResolvedInclude { resolved_name: c.display().to_string(), content });
            }
        }
        Err(format!("cannot find include \"{requested}\" (looked in {} and {})", from.display(), root.display()))
    });
    let artifact = compiler
        .compile_into_spirv(&source, shaderc::ShaderKind::Compute, &file, "main", Some(&options))
        .map_err(|e| err(e.to_string()))?;
    decorate_no_contraction(artifact.as_binary()).map_err(|reason| VkError::InvalidSpirv { name: file, reason })
}
