//! Choosing a device by name, and the error that lists the devices when the name matches none.

mod common;

use common::{context, context_with};
use psdr_vk::{list_devices, ContextOptions, VkError};

#[test]
fn unknown_device_name_lists_available_devices() {
    let Some(ctx) = context("unknown_device_name_lists_available_devices") else {
        return;
    };
    let real_name = ctx.capabilities().device_name.clone();
    drop(ctx);
    let options = ContextOptions { device: Some("no-such-gpu-9000".into()), ..Default::default() };
    let e = psdr_vk::Context::with_options(&options).err().expect("must not open a device");
    match &e {
        VkError::DeviceNotFound { wanted, available } => {
            assert_eq!(wanted, "no-such-gpu-9000");
            assert!(available.iter().any(|a| a.contains(&real_name)), "{available:?}");
        }
        other => panic!("expected DeviceNotFound, got {other}"),
    }
    let message = e.to_string();
    assert!(message.contains("no-such-gpu-9000") && message.contains(&real_name), "{message}");
    eprintln!("error as users see it: {message}");
}

#[test]
fn device_is_chosen_by_case_insensitive_substring() {
    let test = "device_is_chosen_by_case_insensitive_substring";
    let Some(devices) = list_devices().ok().filter(|d| !d.is_empty()) else {
        // Let the common helper decide between skip and failure.
        assert!(context(test).is_none());
        return;
    };
    for d in &devices {
        eprintln!("{test}: found {d:?}");
    }
    let usable = devices.iter().find(|d| d.unusable_because.is_none()).expect("a usable device");
    // A middle slice of the name, upper-cased, still selects it.
    let chars: Vec<char> = usable.name.chars().collect();
    let wanted: String = chars[..chars.len().min(6)].iter().collect::<String>().to_uppercase();
    let options = ContextOptions { device: Some(wanted.clone()), ..Default::default() };
    let ctx = context_with(test, &options).expect("device listed but not opened");
    assert!(ctx.capabilities().device_name.to_uppercase().contains(&wanted));
    eprintln!("{test}: capabilities {:#?}", ctx.capabilities());
}
