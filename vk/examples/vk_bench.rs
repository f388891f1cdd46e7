//! Measures the plumbing on the current device: saxpy (including 16M items, which needs 65536 groups of
//! 256 and so a folded 2-D dispatch), float atomics, and upload/download bandwidth. Checks every result.
//!
//!     cargo run -p psdr-vk --release --example vk_bench

use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use psdr_vk::{include_spirv, Buffer, Context, ContextOptions, Groups, Kernel, ValidationMode};

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

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let ctx = Context::with_options(&ContextOptions { validation: Some(ValidationMode::Off), ..Default::default() })?;
    let caps = ctx.capabilities();
    println!("device: {} ({:?}, {})", caps.device_name, caps.device_kind, caps.driver_info);
    let saxpy: Kernel<SaxpyPush> = Kernel::new(&ctx, "saxpy", &include_spirv!("saxpy")?, 2)?;

    for n in [1usize << 20, 4 << 20, 16 << 20] {
        let x = Buffer::from_slice(&ctx, "x", &vec![1.0f32; n])?;
        let y = Buffer::<f32>::zeroed(&ctx, "y", n)?;
        let groups = Groups::folded_2d(n as u64, 256);
        let push = SaxpyPush { a: 1.0, n: n as u32 };
        let reps = 5;
        let mut gpu = Vec::new();
        for _ in 0..reps {
            let t = saxpy.dispatch(&[&x, &y], &push, groups)?;
            gpu.push(t.gpu_ms.unwrap_or(t.wall_ms));
        }
        let out = y.download()?;
        assert!(out.iter().all(|&v| v == reps as f32), "saxpy result wrong at n = {n}");
        let host_y: Vec<f32> = vec![0.0; n];
        let t = Instant::now();
        let cpu: Vec<f32> = host_y.iter().map(|y| 1.0f32 * 1.0 + y).collect();
        let cpu_ms = t.elapsed().as_secs_f64() * 1e3;
        std::hint::black_box(cpu);
        println!(
            "saxpy n = {n:>8} groups {:>5}x{}: gpu median {:>7.2} ms (min {:.2}), single-thread cpu loop {cpu_ms:.2} ms",
            groups.x,
            groups.y,
            median(gpu.clone()),
            gpu.iter().cloned().fold(f64::MAX, f64::min)
        );
    }

    if caps.float32_atomic_add_buffer {
        let n = 4usize << 20;
        let histogram: Kernel<HistogramPush> = Kernel::new(&ctx, "histogram", &include_spirv!("histogram")?, 2)?;
        let values = Buffer::from_slice(&ctx, "values", &vec![0.5f32; n])?;
        let hist = Buffer::<f32>::zeroed(&ctx, "hist", 1024)?;
        let t = histogram.dispatch(
            &[&values, &hist],
            &HistogramPush { n: n as u32, bins: 1024 },
            Groups::grid_stride(n as u64, 256, 4096),
        )?;
        let ms = t.gpu_ms.unwrap_or(t.wall_ms);
        println!("float atomicAdd, all into one bin (worst case): {:.1} M atomics/s", n as f64 / ms / 1e3);
        let spread: Vec<f32> = (0..n).map(|i| (i % 1024) as f32 / 1024.0 + 1e-4).collect();
        let values = Buffer::from_slice(&ctx, "spread", &spread)?;
        let t = histogram.dispatch(
            &[&values, &hist],
            &HistogramPush { n: n as u32, bins: 1024 },
            Groups::grid_stride(n as u64, 256, 4096),
        )?;
        let ms = t.gpu_ms.unwrap_or(t.wall_ms);
        println!("float atomicAdd into 1024 bins: {:.1} M atomics/s", n as f64 / ms / 1e3);
    }

    for staging in [false, true] {
        let ctx = Context::with_options(&ContextOptions {
            validation: Some(ValidationMode::Off),
            force_staging: staging,
            ..Default::default()
        })?;
        let n = 16usize << 20;
        let host = vec![1.0f32; n];
        let mut out = vec![0.0f32; n];
        let mut b = Buffer::<f32>::zeroed(&ctx, "bandwidth", n)?;
        let (mut up, mut down) = (Vec::new(), Vec::new());
        for _ in 0..5 {
            let t = Instant::now();
            b.upload(&host)?;
            up.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            b.download_into(&mut out)?;
            down.push(t.elapsed().as_secs_f64());
        }
        assert_eq!(out[n - 1], 1.0);
        let gb = (n * 4) as f64 / 1e9;
        println!(
            "64 MiB {}: upload {:.2} GB/s, download {:.2} GB/s (medians of 5)",
            if b.is_host_mapped() { "mapped" } else { "via staging" },
            gb / median(up),
            gb / median(down)
        );
    }
    Ok(())
}
