//! Shared by the integration tests: opening a context or skipping loudly when there is no Vulkan.
#![allow(dead_code)]

use std::sync::Once;

use psdr_vk::{Context, ContextOptions, VkError};

/// `PSDR_REQUIRE_VULKAN=1` turns "no Vulkan here" from a skip into a test failure (CI with lavapipe sets it).
pub fn vulkan_required() -> bool {
    std::env::var("PSDR_REQUIRE_VULKAN").is_ok_and(|v| v == "1")
}

/// Lavapipe prints noise without XDG_RUNTIME_DIR; give it a private one before any Vulkan call.
fn quiet_lavapipe() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
            let dir = std::env::temp_dir().join(format!("psdr-vk-xdg-{}", std::process::id()));
            if std::fs::create_dir_all(&dir).is_ok() {
                use std::os::unix::fs::PermissionsExt;
                let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
                std::env::set_var("XDG_RUNTIME_DIR", &dir);
            }
        }
    });
}

/// A context with default options, or `None` (after printing a SKIP line) when this machine has no Vulkan.
pub fn context(test: &str) -> Option<Context> {
    context_with(test, &ContextOptions::default())
}

pub fn context_with(test: &str, options: &ContextOptions) -> Option<Context> {
    quiet_lavapipe();
    match Context::with_options(options) {
        Ok(ctx) => Some(ctx),
        Err(e @ (VkError::LoaderMissing { .. } | VkError::NoDevice { .. })) => {
            if vulkan_required() {
                panic!("PSDR_REQUIRE_VULKAN=1 but no Vulkan device: {e}");
            }
            eprintln!("SKIP {test}: no Vulkan device ({e}); set PSDR_REQUIRE_VULKAN=1 to make this a failure");
            None
        }
        Err(e) => panic!("{test}: opening Vulkan failed: {e}"),
    }
}

/// Every test ends here: the validation layer (when loaded) must have reported no error.
pub fn assert_no_validation_errors(ctx: &Context) {
    let errors = ctx.validation_errors();
    assert!(
        errors.is_empty(),
        "{} validation error(s):\n{}",
        errors.len(),
        errors.iter().map(|m| m.to_string()).collect::<Vec<_>>().join("\n")
    );
}

/// Deterministic pseudo-random floats in [0, 1) (no rand dependency).
pub fn uniform_floats(n: usize, seed: u32) -> Vec<f32> {
    let mut state = seed.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            (state >> 8) as f32 / (1u32 << 24) as f32
        })
        .collect()
}
