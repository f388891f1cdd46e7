//! CPU backend against the Vulkan backend (whatever device psdr-vk picks: lavapipe here, a GPU where one exists)
//! on the same scenes and seeds: the primal render; the adjoint pass of light radiances and albedo, roughness
//! and specular constants (`Backend::radiance_vjp`, a random adjoint image); and the depth-and-mask adjoint of
//! poses (`Backend::aovs_vjp`). Seconds per pass (best of 3 after a warm-up), Mpaths/s (pixels x spp per
//! second; for the AOV adjoint camera rays per second), Mrays/s for the primal, plus the backends' agreement
//! (the images' mean, the gradients' worst component), written to benchmarks/results/backends.csv and .svg.
//! `cargo run -p psdr-benchmarks --release --bin bench_backends [-- OUT.csv]`

use psdr::backend::{Backend, CpuBackend, VkBackend};
use psdr::grad::{aovs_vjp_on, radiance_vjp_on, AovAdjoints, GradLayout, ParamPath, PoseLayout};
use psdr::render::{Frame, SceneData};
use psdr::scene::{load_scene, sphere_mesh, Object, Pose, Scene};
use psdr::scene::{Color, Scalar};
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

/// Seconds of the adjoint pass (best of `reps` after a warm-up) and its gradient: every light radiance and
/// constant albedo, a fixed random adjoint image.
fn adjoint_best_of(
    backend: &mut dyn Backend,
    d: &SceneData,
    s: &Scene,
    reps: usize,
) -> anyhow::Result<(f64, Vec<f64>)> {
    let mut params: Vec<ParamPath> =
        s.objects.iter().filter(|o| o.emitter.is_some()).map(|o| ParamPath::LightRadiance(o.name.clone())).collect();
    for m in &s.materials {
        if matches!(m.albedo, Color::Constant(_)) {
            params.push(ParamPath::MaterialAlbedo(m.name.clone()));
        }
        if matches!(m.roughness, Scalar::Constant(_)) {
            params.push(ParamPath::MaterialRoughness(m.name.clone()));
        }
        if matches!(m.specular, Scalar::Constant(_)) {
            params.push(ParamPath::MaterialSpecular(m.name.clone()));
        }
    }
    let layout = GradLayout::new(s, &params)?;
    let n = (s.camera.width * s.camera.height * 3) as usize;
    let adjoint: Vec<f32> = (0..n).map(|i| ((i * 7919 % 1000) as f32 / 1000.0 - 0.3) / n as f32).collect();
    let mut grad = radiance_vjp_on(backend, d, &s.settings, &layout, &adjoint)?; // warm-up
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        grad = radiance_vjp_on(backend, d, &s.settings, &layout, &adjoint)?;
        best = best.min(t.elapsed().as_secs_f64());
    }
    Ok((best, grad))
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
    /// Adds the sizes of real photos' working images, 512x384 at 16 and 64 spp (on a GPU; minutes on lavapipe).
    #[arg(long)]
    large: bool,
}

/// Edge samples of the AOV adjoint's silhouette term (the optimiser's default).
const AOV_EDGE_SAMPLES: u32 = 1 << 14;

/// Seconds of the depth-and-mask adjoint (`Backend::aovs_vjp`, best of `reps` after a warm-up) and its
/// gradient: every pose component of the table, the chair and the vase, a random depth adjoint and random
/// adjoints of the table's and chair's masks, both terms (depth interior, silhouettes).
fn aov_adjoint_best_of(
    backend: &mut dyn Backend,
    d: &SceneData,
    s: &Scene,
    reps: usize,
) -> anyhow::Result<(f64, Vec<f64>)> {
    let mut params = vec![];
    for o in ["table", "chair", "vase"] {
        for c in ["translation", "yaw", "rotation", "scale"] {
            params.push(format!("object/{o}/{c}").parse::<ParamPath>()?);
        }
    }
    let pose = PoseLayout::new(s, &params)?;
    let n = (s.camera.width * s.camera.height) as usize;
    let image =
        |k: usize| -> Vec<f32> { (0..n).map(|i| ((i * 7919 + k * 104729) % 1000) as f32 / 1000.0 - 0.3).collect() };
    let (depth, mask_t, mask_c) = (image(0), image(1), image(2));
    let (table, chair) = (s.object_index("table").unwrap_or(0), s.object_index("chair").unwrap_or(0));
    let masks = [(table, mask_t.as_slice()), (chair, mask_c.as_slice())];
    let adjoints = AovAdjoints { depth: Some(&depth), masks: &masks };
    let mut grad = aovs_vjp_on(backend, s, d, &s.settings, &pose, &adjoints, AOV_EDGE_SAMPLES)?; // warm-up
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        grad = aovs_vjp_on(backend, s, d, &s.settings, &pose, &adjoints, AOV_EDGE_SAMPLES)?;
        best = best.min(t.elapsed().as_secs_f64());
    }
    Ok((best, grad))
}

fn main() -> anyhow::Result<()> {
    let args = <Args as clap::Parser>::parse();
    let out = args.out;
    let mut vk = VkBackend::new(None)?;
    let mut cpu = CpuBackend;
    let mut csv = String::from(
        "scene,width,height,spp,triangles,pass,backend,device,seconds,mpaths_per_s,mrays_per_s,\
         rel_diff_vs_other_backend,load_avg_1m\n",
    );
    let mut bars = vec![];
    let mut cases: Vec<(&str, Scene)> = vec![
        ("room", room(128, 96, 16)?),
        ("room", room(256, 192, 16)?),
        ("room_large_mesh", room_large_mesh(128, 96, 16)?),
        ("room_large_mesh", room_large_mesh(256, 192, 16)?),
    ];
    if args.large {
        cases.push(("room", room(512, 384, 16)?));
        cases.push(("room", room(512, 384, 64)?));
        cases.push(("room_large_mesh", room_large_mesh(512, 384, 64)?));
    }
    for (name, s) in cases {
        let d = SceneData::build(&s)?;
        let (t_cpu, f_cpu) = best_of(&mut cpu, &d, &s, 3)?;
        let (t_vk, f_vk) = best_of(&mut vk, &d, &s, 3)?;
        let mean = |f: &Frame| f.radiance.iter().map(|&x| x as f64).sum::<f64>() / f.radiance.len() as f64;
        let rel = ((mean(&f_cpu) - mean(&f_vk)) / mean(&f_cpu)).abs();
        let (w, h, spp, tris) = (s.camera.width, s.camera.height, s.settings.spp, s.triangle_count());
        let paths = f64::from(w * h * spp);
        for (backend, t, f, device) in [("cpu", t_cpu, &f_cpu, cpu.name()), ("vk", t_vk, &f_vk, vk.name())] {
            let (mrays, mpaths) = (f.rays as f64 / t / 1e6, paths / t / 1e6);
            println!(
                "{name:<16} {w}x{h} {spp:>3} spp  primal  {backend:<3} {t:8.3} s  {mrays:7.2} Mrays/s  ({device})"
            );
            let load = load_average();
            csv += &format!(
                "{name},{w},{h},{spp},{tris},primal,{backend},\"{device}\",{t:.4},{mpaths:.3},{mrays:.3},{rel:.2e},{load}\n"
            );
            bars.push((format!("primal {name} {w}x{h} {spp} spp"), backend, mpaths));
        }
        let (t_cpu, g_cpu) = adjoint_best_of(&mut cpu, &d, &s, 3)?;
        let (t_vk, g_vk) = adjoint_best_of(&mut vk, &d, &s, 3)?;
        let scale = g_cpu.iter().map(|g| g.abs()).fold(0.0, f64::max);
        let rel = g_cpu.iter().zip(&g_vk).map(|(a, b)| (a - b).abs() / (a.abs() + 1e-6 * scale)).fold(0.0, f64::max);
        for (backend, t, device) in [("cpu", t_cpu, cpu.name()), ("vk", t_vk, vk.name())] {
            let mpaths = paths / t / 1e6;
            println!(
                "{name:<16} {w}x{h} {spp:>3} spp  adjoint {backend:<3} {t:8.3} s  {mpaths:7.3} Mpaths/s  ({device})"
            );
            let load = load_average();
            csv += &format!(
                "{name},{w},{h},{spp},{tris},adjoint,{backend},\"{device}\",{t:.4},{mpaths:.3},,{rel:.2e},{load}\n"
            );
            bars.push((format!("adjoint {name} {w}x{h} {spp} spp"), backend, mpaths));
        }
        // Depth and masks for poses: camera rays per second (pixel samples plus two per edge sample).
        let (t_cpu, g_cpu) = aov_adjoint_best_of(&mut cpu, &d, &s, 3)?;
        let (t_vk, g_vk) = aov_adjoint_best_of(&mut vk, &d, &s, 3)?;
        let scale = g_cpu.iter().map(|g| g.abs()).fold(0.0, f64::max);
        let rel = g_cpu.iter().zip(&g_vk).map(|(a, b)| (a - b).abs() / (a.abs() + 1e-6 * scale)).fold(0.0, f64::max);
        let rays = paths + 2.0 * f64::from(AOV_EDGE_SAMPLES);
        for (backend, t, device) in [("cpu", t_cpu, cpu.name()), ("vk", t_vk, vk.name())] {
            let mpaths = rays / t / 1e6;
            println!(
                "{name:<16} {w}x{h} {spp:>3} spp  aov_adj {backend:<3} {t:8.3} s  {mpaths:7.3} Mrays/s  ({device})"
            );
            let load = load_average();
            csv += &format!(
                "{name},{w},{h},{spp},{tris},aov_adjoint,{backend},\"{device}\",{t:.4},{mpaths:.3},,{rel:.2e},{load}\n"
            );
            bars.push((format!("aov adjoint {name} {w}x{h} {spp} spp"), backend, mpaths));
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

/// Grouped horizontal bars: Mpaths/s of each backend per pass, scene and size.
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
        title: "Mpaths/s of the primal render and the adjoint passes (AOV adjoint: camera rays/s), same scenes and seeds (higher is better)".into(),
        unit: "Mpaths/s".into(),
        series: vec![format!("cpu: {cpu}"), format!("vk: {vk}")],
        rows,
        stacked: false,
    }
    .svg()
}
