//! Kernels on the device against CPU loops: saxpy (both dispatch shapes), batched passes, float atomics,
//! push constants, timestamps, the staging path, and the errors for bad dispatches.

mod common;

use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use common::{assert_no_validation_errors, context, context_with, uniform_floats};
use psdr_vk::{include_spirv, Buffer, ContextOptions, Groups, Kernel, VkError};

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct SaxpyPush {
    a: f32,
    n: u32,
}

/// A few million: past every cache, yet ~100 ms on lavapipe.
const SAXPY_N: usize = 4 << 20;

fn saxpy_cpu(a: f32, x: &[f32], y: &[f32]) -> Vec<f32> {
    x.iter().zip(y).map(|(x, y)| a * x + y).collect()
}

fn run_saxpy(test: &str, groups: impl Fn(u64) -> Groups) {
    let Some(ctx) = context(test) else { return };
    let kernel: Kernel<SaxpyPush> = Kernel::new(&ctx, "saxpy", &include_spirv!("saxpy").unwrap(), 2).unwrap();
    let x_host = uniform_floats(SAXPY_N, 1);
    let y_host = uniform_floats(SAXPY_N, 2);
    let x = Buffer::from_slice(&ctx, "x", &x_host).unwrap();
    let y = Buffer::from_slice(&ctx, "y", &y_host).unwrap();
    let push = SaxpyPush { a: 2.5, n: SAXPY_N as u32 };
    let g = groups(SAXPY_N as u64);
    let t = kernel.dispatch(&[&x, &y], &push, g).unwrap();

    let cpu_start = Instant::now();
    let expected = saxpy_cpu(push.a, &x_host, &y_host);
    let cpu_ms = cpu_start.elapsed().as_secs_f64() * 1e3;
    let got = y.download().unwrap();
    // a*x+y may be fused on one side and not the other: allow one rounding of difference.
    let worst = got.iter().zip(&expected).map(|(g, e)| (g - e).abs() / e.abs().max(1e-6)).fold(0.0f32, f32::max);
    assert!(worst <= 2.0 * f32::EPSILON, "worst relative error {worst}");
    eprintln!(
        "{test}: n = {SAXPY_N}, groups {g:?}: gpu {:.2?} ms, wall {:.2} ms, cpu loop {cpu_ms:.2} ms",
        t.gpu_ms, t.wall_ms
    );
    assert_no_validation_errors(&ctx);
}

#[test]
fn saxpy_2d_grid_matches_cpu() {
    // 2048 x 8 groups of 256 = 4M invocations: exercises the row folding that Groups::folded_2d produces
    // for more than 65535 groups, without needing 16M+ elements.
    run_saxpy("saxpy_2d_grid_matches_cpu", |n| Groups::new(2048, (n / (2048 * 256)) as u32, 1));
}

#[test]
fn saxpy_grid_stride_matches_cpu() {
    // 512 groups of 256: every invocation handles 32 items.
    run_saxpy("saxpy_grid_stride_matches_cpu", |n| Groups::grid_stride(n, 256, 512));
}

#[test]
fn batch_runs_passes_in_order() {
    let Some(ctx) = context("batch_runs_passes_in_order") else {
        return;
    };
    let kernel: Kernel<SaxpyPush> = Kernel::new(&ctx, "saxpy", &include_spirv!("saxpy").unwrap(), 2).unwrap();
    let n = 100_000;
    let x = Buffer::from_slice(&ctx, "x", &vec![1.0f32; n]).unwrap();
    let y = Buffer::from_slice(&ctx, "y", &vec![5.0f32; n]).unwrap();
    let copy = Buffer::<f32>::zeroed(&ctx, "copy", n).unwrap();
    let g = Groups::folded_2d(n as u64, 256);
    let mut batch = ctx.batch();
    // y = 0; y += 2x; y += 3x; copy = y; y += 1x  =>  copy = 5, y = 6 (only if barriers order the passes).
    batch
        .fill_zero(&y)
        .unwrap()
        .dispatch(&kernel, &[&x, &y], &SaxpyPush { a: 2.0, n: n as u32 }, g)
        .unwrap()
        .dispatch(&kernel, &[&x, &y], &SaxpyPush { a: 3.0, n: n as u32 }, g)
        .unwrap()
        .copy(&y, &copy)
        .unwrap()
        .dispatch(&kernel, &[&x, &y], &SaxpyPush { a: 1.0, n: n as u32 }, g)
        .unwrap();
    assert_eq!(batch.len(), 5);
    let t = batch.submit().unwrap();
    assert!(copy.download().unwrap().iter().all(|&v| v == 5.0));
    assert!(y.download().unwrap().iter().all(|&v| v == 6.0));
    let labels: Vec<_> = t.commands.iter().map(|c| c.label.as_str()).collect();
    assert_eq!(labels, ["fill y", "saxpy", "saxpy", "copy y -> copy", "saxpy"]);
    eprintln!("batch timings: {t:?}");
    assert_no_validation_errors(&ctx);
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct HistogramPush {
    n: u32,
    bins: u32,
}

#[test]
fn float_atomic_add_histogram_matches_cpu() {
    let test = "float_atomic_add_histogram_matches_cpu";
    let Some(ctx) = context(test) else { return };
    if !ctx.capabilities().float32_atomic_add_buffer {
        eprintln!("SKIP {test}: device lacks shaderBufferFloat32AtomicAdd");
        return;
    }
    let kernel: Kernel<HistogramPush> =
        Kernel::new(&ctx, "histogram", &include_spirv!("histogram").unwrap(), 2).unwrap();
    let (n, bins) = (1usize << 20, 1024usize);
    let values_host = uniform_floats(n, 7);
    let values = Buffer::from_slice(&ctx, "values", &values_host).unwrap();
    let hist = Buffer::<f32>::zeroed(&ctx, "hist", bins).unwrap();
    let push = HistogramPush { n: n as u32, bins: bins as u32 };
    let t = kernel.dispatch(&[&values, &hist], &push, Groups::grid_stride(n as u64, 256, 1024)).unwrap();

    // CPU in f64 (order-independent truth); the GPU sums ~1000 f32 values per bin in arbitrary order.
    let mut expected = vec![0.0f64; bins];
    for &v in &values_host {
        expected[((v * bins as f32) as usize).min(bins - 1)] += f64::from(v);
    }
    let got = hist.download().unwrap();
    for (b, (g, e)) in got.iter().zip(&expected).enumerate() {
        let rel = (f64::from(*g) - e).abs() / e.abs().max(1e-9);
        assert!(rel < 1e-4, "bin {b}: gpu {g}, cpu {e}, relative error {rel}");
    }
    let total: f64 = got.iter().map(|&g| f64::from(g)).sum();
    let expected_total: f64 = values_host.iter().map(|&v| f64::from(v)).sum();
    assert!((total - expected_total).abs() / expected_total < 1e-5);
    if let Some(ms) = t.gpu_ms {
        eprintln!("{test}: {n} atomics in {ms:.2} ms = {:.1} M atomics/s", n as f64 / ms / 1e3);
    }
    assert_no_validation_errors(&ctx);
}

/// The renderer's push block will look like this: vectors first, scalars after.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
struct EchoPush {
    u: [u32; 4],
    i: [i32; 4],
    f: [f32; 4],
    v: [f32; 3],
    w: f32,
    seed: u32,
    sample_index: u32,
    width: u32,
    height: u32,
}

#[test]
fn push_constants_round_trip() {
    let Some(ctx) = context("push_constants_round_trip") else {
        return;
    };
    let kernel: Kernel<EchoPush> = Kernel::new(&ctx, "push_echo", &include_spirv!("push_echo").unwrap(), 1).unwrap();
    let out = Buffer::<u32>::zeroed(&ctx, "echo", 20).unwrap();
    let push = EchoPush {
        u: [0, 1, 0xdead_beef, u32::MAX],
        i: [-1, i32::MIN, i32::MAX, 42],
        f: [1.5, -0.0, f32::MIN_POSITIVE, 3.0e38],
        v: [0.1, 0.2, 0.3],
        w: -7.25,
        seed: 0x1234_5678,
        sample_index: 17,
        width: 640,
        height: 480,
    };
    kernel.dispatch(&[&out], &push, Groups::linear(1)).unwrap();
    let words = out.download().unwrap();
    let echoed: EchoPush = bytemuck::pod_read_unaligned(bytemuck::cast_slice(&words));
    // Compare bits, so -0.0 and every float survive exactly.
    assert_eq!(bytemuck::bytes_of(&echoed), bytemuck::bytes_of(&push));
    assert_no_validation_errors(&ctx);
}

#[test]
fn timestamps_are_positive_when_supported() {
    let test = "timestamps_are_positive_when_supported";
    let Some(ctx) = context(test) else { return };
    let caps = ctx.capabilities().clone();
    let kernel: Kernel<SaxpyPush> = Kernel::new(&ctx, "saxpy", &include_spirv!("saxpy").unwrap(), 2).unwrap();
    let n = 1 << 20;
    let x = Buffer::from_slice(&ctx, "x", &vec![1.0f32; n]).unwrap();
    let y = Buffer::<f32>::zeroed(&ctx, "y", n).unwrap();
    let push = SaxpyPush { a: 1.0, n: n as u32 };
    let mut batch = ctx.batch();
    batch
        .dispatch(&kernel, &[&x, &y], &push, Groups::folded_2d(n as u64, 256))
        .unwrap()
        .dispatch(&kernel, &[&x, &y], &push, Groups::folded_2d(n as u64, 256))
        .unwrap();
    let t = batch.submit().unwrap();
    assert!(t.wall_ms > 0.0);
    if caps.timestamps {
        let total = t.gpu_ms.expect("timestamps supported");
        assert!(total > 0.0, "{t:?}");
        for c in &t.commands {
            assert!(c.gpu_ms.expect("per-command time") > 0.0, "{t:?}");
        }
        let sum: f64 = t.commands.iter().map(|c| c.gpu_ms.unwrap()).sum();
        assert!(sum <= total * 1.001 + 1e-3, "commands {sum} ms > total {total} ms");
        eprintln!("{test}: period {} ns, {} valid bits: {t:?}", caps.timestamp_period_ns, caps.timestamp_valid_bits);
    } else {
        assert!(t.gpu_ms.is_none() && t.commands.iter().all(|c| c.gpu_ms.is_none()));
        eprintln!("{test}: device has no timestamps (timestampValidBits == 0): times are None as promised");
    }
    assert_no_validation_errors(&ctx);
}

/// The staging path is what real discrete GPUs use; lavapipe maps everything, so force it here.
#[test]
fn staging_path_round_trips() {
    let options = ContextOptions { force_staging: true, ..Default::default() };
    let Some(ctx) = context_with("staging_path_round_trips", &options) else {
        return;
    };
    let data: Vec<u32> = (0..300_001u32).map(|i| i.wrapping_mul(2_654_435_761)).collect();
    let mut b = Buffer::from_slice(&ctx, "staged", &data).unwrap();
    assert!(!b.is_host_mapped());
    assert_eq!(b.download().unwrap(), data);
    b.upload_at(10, &[7, 8, 9]).unwrap();
    assert_eq!(b.download_range(9, 5).unwrap(), [data[9], 7, 8, 9, data[13]]);
    b.fill_zero().unwrap();
    assert!(b.download().unwrap().iter().all(|&v| v == 0));

    let kernel: Kernel<SaxpyPush> = Kernel::new(&ctx, "saxpy", &include_spirv!("saxpy").unwrap(), 2).unwrap();
    let x = Buffer::from_slice(&ctx, "x", &[1.0f32, 2.0, 3.0]).unwrap();
    let y = Buffer::from_slice(&ctx, "y", &[10.0f32, 20.0, 30.0]).unwrap();
    kernel.dispatch(&[&x, &y], &SaxpyPush { a: 2.0, n: 3 }, Groups::linear(1)).unwrap();
    assert_eq!(y.download().unwrap(), [12.0, 24.0, 36.0]);
    assert_no_validation_errors(&ctx);
}

#[test]
fn mapped_path_round_trips_and_empty_buffers_work() {
    let Some(ctx) = context("mapped_path_round_trips_and_empty_buffers_work") else {
        return;
    };
    let data: Vec<u16> = (0..1001u16).collect(); // odd byte count: rounded up to 4 inside
    let mut b = Buffer::from_slice(&ctx, "u16s", &data).unwrap();
    assert_eq!(b.size_bytes(), 2002);
    assert_eq!(b.download().unwrap(), data);
    b.upload_at(1000, &[7]).unwrap();
    assert_eq!(b.download_range(999, 2).unwrap(), [999, 7]);
    let empty = Buffer::<f32>::zeroed(&ctx, "empty", 0).unwrap();
    assert!(empty.is_empty() && empty.download().unwrap().is_empty());
    eprintln!("host-mapped: {}", b.is_host_mapped());
    assert_no_validation_errors(&ctx);
}

#[test]
fn bad_dispatches_are_errors_not_panics() {
    let Some(ctx) = context("bad_dispatches_are_errors_not_panics") else {
        return;
    };
    let caps = ctx.capabilities().clone();
    let words = include_spirv!("saxpy").unwrap();
    let kernel: Kernel<SaxpyPush> = Kernel::new(&ctx, "saxpy", &words, 2).unwrap();
    let x = Buffer::<f32>::zeroed(&ctx, "x", 4).unwrap();
    let push = SaxpyPush { a: 1.0, n: 4 };

    let e = kernel.dispatch(&[&x], &push, Groups::linear(1)).unwrap_err();
    assert!(matches!(e, VkError::BadDispatch { .. }) && e.to_string().contains("2 storage buffers"), "{e}");

    let too_many = Groups::linear(caps.max_compute_work_group_count[0].saturating_add(1));
    if too_many.x > caps.max_compute_work_group_count[0] {
        let e = kernel.dispatch(&[&x, &x], &push, too_many).unwrap_err();
        assert!(e.to_string().contains("maxComputeWorkGroupCount"), "{e}");
    }

    let e = Kernel::<SaxpyPush>::new(&ctx, "garbage", &[1, 2, 3, 4, 5, 6], 2).err().unwrap();
    assert!(matches!(e, VkError::InvalidSpirv { .. }), "{e}");
    assert!(psdr_vk::spirv_from_bytes(&[1, 2, 3]).is_err());

    #[repr(C)]
    #[derive(Clone, Copy, Pod, Zeroable)]
    struct Odd([u8; 6]);
    let e = Kernel::<Odd>::new(&ctx, "odd", &words, 2).err().unwrap();
    assert!(e.to_string().contains("multiple of 4"), "{e}");

    let too_big = caps.max_storage_buffer_range / 4 + 1;
    let e = Buffer::<f32>::zeroed(&ctx, "huge", too_big as usize).unwrap_err();
    assert!(matches!(e, VkError::BufferTooLarge { .. }) && e.to_string().contains("maxStorageBufferRange"), "{e}");

    let mut b = Buffer::<f32>::zeroed(&ctx, "b", 4).unwrap();
    assert!(matches!(b.upload(&[1.0; 3]), Err(VkError::LengthMismatch { .. })));
    assert!(b.download_range(3, 2).is_err());

    // A buffer from another context must not be bound.
    if let Some(other) = context("bad_dispatches_are_errors_not_panics (second context)") {
        let foreign = Buffer::<f32>::zeroed(&other, "foreign", 4).unwrap();
        let e = kernel.dispatch(&[&x, &foreign], &push, Groups::linear(1)).unwrap_err();
        assert!(matches!(e, VkError::ForeignObject { .. }), "{e}");
    }
    assert_no_validation_errors(&ctx);
}

/// Measured numbers for the report: upload/download bandwidth through the mapped path.
#[test]
fn transfer_rates() {
    let Some(ctx) = context("transfer_rates") else {
        return;
    };
    let n = 16 << 20; // 64 MiB of f32
    let host = vec![1.0f32; n];
    let mut b = Buffer::<f32>::zeroed(&ctx, "bandwidth", n).unwrap();
    let mut out = vec![0.0f32; n];
    let mut best = (f64::MAX, f64::MAX);
    for _ in 0..3 {
        let t = Instant::now();
        b.upload(&host).unwrap();
        best.0 = best.0.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        b.download_into(&mut out).unwrap();
        best.1 = best.1.min(t.elapsed().as_secs_f64());
    }
    assert_eq!(out[n - 1], 1.0);
    let gb = (n * 4) as f64 / 1e9;
    eprintln!(
        "transfer_rates (64 MiB, mapped = {}): upload {:.2} GB/s, download {:.2} GB/s",
        b.is_host_mapped(),
        gb / best.0,
        gb / best.1
    );
    assert_no_validation_errors(&ctx);
}
