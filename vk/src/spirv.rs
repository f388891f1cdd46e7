//! SPIR-V words from bytes (e.g. `include_bytes!` of a `.spv` that build.rs compiled).

use crate::error::{Result, VkError};

/// The first word of every SPIR-V module.
pub const SPIRV_MAGIC: u32 = 0x0723_0203;

/// Converts SPIR-V bytes (any alignment, either endianness) to words, checking the magic number.
pub fn spirv_from_bytes(bytes: &[u8]) -> Result<Vec<u32>> {
    ash::util::read_spv(&mut std::io::Cursor::new(bytes))
        .map_err(|e| VkError::InvalidSpirv { name: "<bytes>".into(), reason: e.to_string() })
}

/// Embeds `$OUT_DIR/<name>.spv` compiled by the including crate's build.rs, as `Result<Vec<u32>>`.
///
/// ```ignore
/// let words = psdr_vk::include_spirv!("saxpy")?;
/// ```
#[macro_export]
macro_rules! include_spirv {
    ($name:literal) => {
        $crate::spirv_from_bytes(include_bytes!(concat!(env!("OUT_DIR"), "/", $name, ".spv")))
    };
}

/// Checks that `words` look like a SPIR-V module (header present, magic number right).
pub(crate) fn check_spirv(name: &str, words: &[u32]) -> Result<()> {
    let reason = if words.len() < 5 {
        "shorter than the 5-word header".to_string()
    } else if words[0] != SPIRV_MAGIC {
        format!("magic number is {:#010x}, expected {SPIRV_MAGIC:#010x}", words[0])
    } else {
        return Ok(());
    };
    Err(VkError::InvalidSpirv { name: name.into(), reason })
}
