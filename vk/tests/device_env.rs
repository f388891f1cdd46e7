//! `PSDR_VK_DEVICE` and `PSDR_VK_VALIDATION` from the environment. Own test binary with one test, because it
//! changes this process's environment.

mod common;

use psdr_vk::{Context, ContextOptions, ValidationMode, VkError};

#[test]
fn environment_picks_device_and_validation() {
    let Some(ctx) = common::context("environment_picks_device_and_validation") else {
        return;
    };
    let name = ctx.capabilities().device_name.clone();
    drop(ctx);

    std::env::set_var("PSDR_VK_DEVICE", "no-such-gpu-from-env");
    let e = Context::new().err().expect("unknown device name must fail");
    assert!(matches!(e, VkError::DeviceNotFound { .. }), "{e}");
    assert!(e.to_string().contains(&name), "{e}");
    // The API parameter wins over the environment.
    let options = ContextOptions { device: Some(name.clone()), ..Default::default() };
    assert_eq!(Context::with_options(&options).unwrap().capabilities().device_name, name);

    std::env::set_var("PSDR_VK_DEVICE", &name);
    std::env::set_var("PSDR_VK_VALIDATION", "0");
    assert_eq!(ValidationMode::from_env(), ValidationMode::Off);
    let ctx = Context::new().unwrap();
    assert!(!ctx.validation_enabled());
    std::env::set_var("PSDR_VK_VALIDATION", "1");
    assert_eq!(ValidationMode::from_env(), ValidationMode::Required);
}
