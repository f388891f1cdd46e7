//! Without any Vulkan driver, opening a context is a typed error that says how to install one; never a panic.
//! Its own test binary: it points the loader at no drivers through the environment of this process.

use psdr_vk::{Context, VkError, INSTALL_HINT};

#[test]
fn missing_driver_is_a_clear_error() {
    // Both the old and the new loader variable: the loader then finds no ICD at all.
    std::env::set_var("VK_ICD_FILENAMES", "/nonexistent/psdr-no-icd.json");
    std::env::set_var("VK_DRIVER_FILES", "/nonexistent/psdr-no-icd.json");
    std::env::set_var("PSDR_VK_VALIDATION", "0");
    match Context::new() {
        Err(e @ (VkError::NoDevice { .. } | VkError::LoaderMissing { .. })) => {
            let message = e.to_string();
            assert!(message.contains("apt-get install mesa-vulkan-drivers libvulkan1"), "{message}");
            eprintln!("error as users see it: {message}");
        }
        Err(other) => panic!("expected NoDevice or LoaderMissing, got: {other}"),
        Ok(ctx) => panic!("a device opened without drivers: {}", ctx.capabilities().device_name),
    }
    assert!(psdr_vk::list_devices().map(|d| d.is_empty()).unwrap_or(true));
}

#[test]
fn loader_missing_message_names_the_packages() {
    let e = VkError::LoaderMissing { reason: "libvulkan.so.1: cannot open shared object file".into() };
    assert!(e.to_string().contains(INSTALL_HINT));
    assert!(INSTALL_HINT.contains("apt-get install mesa-vulkan-drivers libvulkan1"));
}
