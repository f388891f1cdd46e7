//! CPU backend against the Vulkan backend (whatever device psdr-vk picks: lavapipe here, a GPU where one exists)
//! on the same scenes and seeds: seconds per frame (best of 3 after a warm-up) and Mrays/s, plus the
//! images' agreement, written to benchmarks/results/backends.csv and backends.svg.
//! `cargo run -p psdr-benchmarks --release --bin bench_backends [-- OUT.csv]`

use psdr::backend::{Backend, CpuBackend, VkBackend};
use psdr::render::{Frame, SceneData};
use psdr::scene::{load_scene, sphere_mesh, Object, Pose, Scene};
use std::time::Instant;

fn room(width: u32, height: u32, spp: u32) -> anyhow::Result<Scene> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/room/scene.json");
    let mut s = load_scene(std::path::Path::new(path))?;
    s.camera.width = width;
    s.camera.height = height;
    s.settings.spp = spp;
    Ok(s)
}

/// The room plus a 100k-triangle sphere: deeper BVH, more divergent traversal.
fn room_large_mesh(width: u32, height: u32, spp: u32) -> anyhow::Result<Scene> {
    let mut s = room(width, height, spp)?;
    let mut sphere = sphere_mesh(0.35, 160, 320, false);
    sphere.material = 0;
    let pose = Pose { translation: glam::Vec3::new(0.9, 0.6, -1.2), ..Default::default() };
    s.objects.push(Object { name: "big_sphere".into(), parts: vec![sphere], pose, emitter: None });
    Ok(s)
}

fn best_of(backend: &mut dyn Backend, d: &SceneData, s: &Scene, reps: usize) -> anyhow::Result<(f64, Frame)> {
    let mut frame = backend.render(d, &s.settings, &|_, _| {})?; // warm-up
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        frame = backend.render(d, &s.settings, &|_, _| {})?;
        best = best.min(t.elapsed().as_secs_f64());
    }
    Ok((best, frame))
}

/// The Vulkan backend against the CPU backend (CSV + SVG under benchmarks/results).
#[derive(clap::Parser)]
struct Args {
    /// Output CSV (the SVG goes next to it).
    #[arg(default_value_os_t = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("results/backends.csv"))]
    out: std::path::PathBuf,
}

fn main() -> anyhow::Result<()> {
    let out = <Args as clap::Parser>::parse().out;
    let mut vk = VkBackend::new(None)?;
    let mut cpu = CpuBackend;
    let mut csv = String::from(
        "scene,width,height,spp,triangles,backend,device,seconds,mrays_per_s,image_mean_rel_diff_vs_other_backend,\
         load_avg_1m\n",
    );
    let mut bars = vec![];
    let cases: Vec<(&str, Scene)> = vec![
        ("room", room(128, 96, 16)?),
        ("room", room(256, 192, 16)?),
        ("room_large_mesh", room_large_mesh(128, 96, 16)?),
        ("room_large_mesh", room_large_mesh(256, 192, 16)?),
    ];
    for (name, s) in cases {
        let d = SceneData::build(&s)?;
        let (t_cpu, f_cpu) = best_of(&mut cpu, &d, &s, 3)?;
        let (t_vk, f_vk) = best_of(&mut vk, &d, &s, 3)?;
        let mean = |f: &Frame| f.radiance.iter().map(|&x| x as f64).sum::<f64>() / f.radiance.len() as f64;
        let rel = ((mean(&f_cpu) - mean(&f_vk)) / mean(&f_cpu)).abs();
        let (w, h, spp, tris) = (s.camera.width, s.camera.height, s.settings.spp, s.triangle_count());
        for (backend, t, f, device) in [("cpu", t_cpu, &f_cpu, cpu.name()), ("vk", t_vk, &f_vk, vk.name())] {
            let mrays = f.rays as f64 / t / 1e6;
            println!("{name:<16} {w}x{h} {spp:>3} spp  {backend:<3} {t:8.3} s  {mrays:7.2} Mrays/s  ({device})");
            let load = load_average();
            csv += &format!("{name},{w},{h},{spp},{tris},{backend},\"{device}\",{t:.4},{mrays:.3},{rel:.2e},{load}\n");
            bars.push((format!("{name} {w}x{h}"), backend, mrays));
        }
    }
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(&out, csv)?;
    std::fs::write(out.with_extension("svg"), chart(&bars, &vk.name(), &cpu.name()))?;
    println!("wrote {} and {}", out.display(), out.with_extension("svg").display());
    Ok(())
}

/// The 1-minute load average (Linux), so timings taken on a busy machine can be recognised; empty elsewhere.
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_string))
        .unwrap_or_default()
}

/// Grouped horizontal bars: Mrays/s of each backend per scene and size.
fn chart(bars: &[(String, &str, f64)], vk: &str, cpu: &str) -> String {
    // One row per scene and size, a bar per backend.
    let mut rows: Vec<(String, Vec<f64>)> = vec![];
    for (label, backend, v) in bars {
        let k = usize::from(*backend != "cpu");
        match rows.iter_mut().find(|r| &r.0 == label) {
            Some(r) => r.1[k] = *v,
            None => {
                let mut values = vec![f64::NAN; 2];
                values[k] = *v;
                rows.push((label.clone(), values));
            }
        }
    }
    psdr::report::chart::BarChart {
        title: "Mrays/s, same scenes and seeds (higher is better)".into(),
        unit: "Mrays/s".into(),
        series: vec![format!("cpu: {cpu}"), format!("vk: {vk}")],
        rows,
        stacked: false,
    }
    .svg()
}
