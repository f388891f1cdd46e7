//! With the Khronos validation layer loaded, a few kernels must produce zero validation errors; and the
//! message collection itself must work (otherwise "zero errors" would prove nothing).

mod common;

use bytemuck::{Pod, Zeroable};
use common::context_with;
use psdr_vk::{include_spirv, Buffer, ContextOptions, Groups, Kernel, Severity, ValidationMode};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SaxpyPush {
    a: f32,
    n: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct HistogramPush {
    n: u32,
    bins: u32,
}

#[test]
fn kernels_run_without_validation_errors() {
    let test = "kernels_run_without_validation_errors";
    // PSDR_VK_VALIDATION=1 makes a missing layer an error; otherwise use it when installed.
    let mode = match ValidationMode::from_env() {
        ValidationMode::Required => ValidationMode::Required,
        _ => ValidationMode::IfAvailable,
    };
    let options = ContextOptions { validation: Some(mode), ..Default::default() };
    let Some(ctx) = context_with(test, &options) else {
        return;
    };
    if !ctx.validation_enabled() {
        eprintln!(
            "SKIP {test}: VK_LAYER_KHRONOS_validation is not installed (apt-get install vulkan-validationlayers)"
        );
        return;
    }

    // The collector works: an injected error shows up, and clearing forgets it.
    ctx.emit_test_validation_message(Severity::Error);
    assert_eq!(ctx.validation_errors().len(), 1, "{:?}", ctx.validation_messages());
    ctx.clear_validation_messages();
    assert!(ctx.validation_messages().is_empty());

    let saxpy: Kernel<SaxpyPush> = Kernel::new(&ctx, "saxpy", &include_spirv!("saxpy").unwrap(), 2).unwrap();
    let n = 50_000usize;
    let x = Buffer::from_slice(&ctx, "x", &vec![1.0f32; n]).unwrap();
    let y = Buffer::<f32>::zeroed(&ctx, "y", n).unwrap();
    let copy = Buffer::<f32>::zeroed(&ctx, "copy", n).unwrap();
    let mut batch = ctx.batch();
    batch
        .fill_u32(&y, 1.0f32.to_bits())
        .unwrap()
        .dispatch(&saxpy, &[&x, &y], &SaxpyPush { a: 2.0, n: n as u32 }, Groups::folded_2d(n as u64, 256))
        .unwrap()
        .copy(&y, &copy)
        .unwrap();
    batch.submit().unwrap();
    assert!(copy.download().unwrap().iter().all(|&v| v == 3.0));

    if ctx.capabilities().float32_atomic_add_buffer {
        let histogram: Kernel<HistogramPush> =
            Kernel::new(&ctx, "histogram", &include_spirv!("histogram").unwrap(), 2).unwrap();
        let hist = Buffer::<f32>::zeroed(&ctx, "hist", 16).unwrap();
        histogram.dispatch(&[&copy, &hist], &HistogramPush { n: n as u32, bins: 16 }, Groups::linear(64)).unwrap();
        // All values are 3.0 -> the last bin; 50 000 * 3 is exact in f32.
        assert_eq!(hist.download().unwrap()[15], 3.0 * n as f32);
    }

    // Creating and dropping everything is also checked: drop before reading the log.
    drop((saxpy, x, y, copy));
    let messages = ctx.validation_messages();
    for m in &messages {
        eprintln!("{test}: {m}");
    }
    let errors: Vec<_> = messages.iter().filter(|m| m.severity == Severity::Error).collect();
    assert!(errors.is_empty(), "{} validation errors: {errors:#?}", errors.len());

    // And the layer really checks: a buffer with no usage flags violates a VUID (the driver accepts it anyway).
    let device = ctx.raw_device();
    let info = psdr_vk::ash::vk::BufferCreateInfo::default().size(64);
    // SAFETY: a valid device; the buffer is destroyed right away and never bound or used.
    unsafe {
        if let Ok(b) = device.create_buffer(&info, None) {
            device.destroy_buffer(b, None);
        }
    }
    let errors = ctx.validation_errors();
    assert!(!errors.is_empty(), "the validation layer did not flag a buffer without usage flags");
    eprintln!("{test}: deliberate misuse was caught: {}", errors[0]);
    ctx.clear_validation_messages();
}
