//! The secondary boundary at scale: seconds per pose gradient on the furnished room of Sweet Home 3D models
//! (tests/src/sweet_home.rs: armchair, sofa, oak table, 28k triangles), the armchair's translation and yaw, L2 to
//! a target with the armchair moved 5 cm, by term: interior + primary alone, then all terms (secondary boundary,
//! direct and indirect, 1 edge sample per scattering vertex). Flat-shaded as the libraries ship the models (96 %
//! of the armchair's edges are creases) and auto-smoothed at 30 degrees (`scene::auto_smooth`). Per row: best
//! of 3 timed single-replica gradients, and the standard error of the translation's x component over 8
//! replicas (the estimator's noise at that cost).
//! Then the cost's scaling: a flat-shaded sphere (its tessellation from 1k to 200k triangles, every edge a
//! crease) moving in the example room, seconds per translation gradient with and without the secondary
//! boundary, and Mitsuba 3's `prb_projective` on the same job when benchmarks/setup_mitsuba.sh has been run
//! (results/secondary_scaling.csv, .svg).
//! `cargo run -p psdr-benchmarks --release --bin bench_secondary [-- WIDTH HEIGHT SPP]` writes
//! benchmarks/results/secondary.csv and .svg.

use psdr::backend::CpuBackend;
use psdr::grad::{analytic_gradient, AdOptions, ImageLoss, Output, ParamPath};
use psdr::render::{render_cpu, SceneData};
use psdr::report::chart::BarChart;
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<u32> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let (w, h, spp) = (*args.first().unwrap_or(&256), *args.get(1).unwrap_or(&192), *args.get(2).unwrap_or(&4));
    let mut csv = String::from("shading,triangles,width,height,spp,terms,seconds,grad_x,grad_x_std_err_8\n");
    let mut rows = vec![];
    for (shading, angle) in [("flat", None), ("smooth 30 deg", Some(30.0))] {
        let s = psdr_tests::sweet_home::sweet_home_room_smoothed(w, h, spp, angle)
            .ok_or_else(|| anyhow::anyhow!("the Sweet Home 3D libraries are not installed"))?;
        let mut target = s.clone();
        let a = target.object_index("armchair").unwrap();
        target.objects[a].pose.translation.x += 0.05;
        target.settings.spp = 64;
        let t = render_cpu(&SceneData::build(&target)?, &target.settings, &|_, _| {});
        let loss = ImageLoss::L2To { output: Output::Radiance, target: t.radiance };
        let params: Vec<ParamPath> = vec!["object/armchair/translation".parse()?, "object/armchair/yaw".parse()?];
        let mut times = vec![];
        for (terms, sppse) in [("interior + primary", 0), ("all terms", 1)] {
            let opts = AdOptions { replicas: 1, edge_samples: w * h, secondary_edge_samples: sppse };
            let best = best_of_3(|| analytic_gradient(&s, &params, &loss, &opts, &mut CpuBackend).map(|_| ()))?;
            let g = analytic_gradient(&s, &params, &loss, &AdOptions { replicas: 8, ..opts }, &mut CpuBackend)?;
            println!(
                "{shading:<14} {terms:<20} {best:7.3} s  d/dx {:+.3e} ± {:.1e}  ({} triangles, {w}x{h}, {spp} spp)",
                g.mean[0],
                g.std_err[0],
                s.triangle_count()
            );
            csv += &format!(
                "{shading},{},{w},{h},{spp},{terms},{best:.4},{:.5e},{:.2e}\n",
                s.triangle_count(),
                g.mean[0],
                g.std_err[0]
            );
            times.push(best);
        }
        rows.push((shading.to_string(), times));
    }
    let chart = BarChart {
        title: format!("Seconds per armchair pose gradient, furnished room, {w}x{h}, {spp} spp (lower is better)"),
        unit: "s".into(),
        series: vec!["interior + primary".into(), "all terms (secondary boundary, 1 sample per vertex)".into()],
        rows,
        stacked: false,
    };
    psdr_benchmarks::write_results("secondary", &csv, &chart.svg())?;
    scaling(w / 2, h / 2, spp)
}

/// The shortest of three timed runs of `f`, seconds.
fn best_of_3(mut f: impl FnMut() -> psdr::Result<()>) -> anyhow::Result<f64> {
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t0 = Instant::now();
        f()?;
        best = best.min(t0.elapsed().as_secs_f64());
    }
    Ok(best)
}

/// Seconds per gradient against the moving mesh's triangle count, psdr by term and Mitsuba 3's `prb_projective`
/// (guiding none, as in bench_grad) on the same job: L2 to a target with the sphere moved 5 cm, its x
/// translation. Mitsuba is left out (and said so) when benchmarks/setup_mitsuba.sh has not been run.
fn scaling(w: u32, h: u32, spp: u32) -> anyhow::Result<()> {
    use psdr::report::chart::{Point, Series, XyChart};
    use psdr::scene::{load_scene, sphere_mesh, Object, Pose};
    let mut csv = String::from("triangles,width,height,spp,terms,seconds\n");
    let mut series = vec![vec![], vec![], vec![]];
    let work = std::env::temp_dir().join(format!("psdr_bench_secondary_{}", std::process::id()));
    for (rings, segments) in [(16, 32), (32, 64), (64, 128), (128, 256), (224, 448)] {
        let mut s =
            load_scene(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/room/scene.json")))?;
        (s.camera.width, s.camera.height, s.settings.spp) = (w, h, spp);
        let mut ball = sphere_mesh(0.35, rings, segments, false);
        ball.normals = None; // flat-shaded: every edge a crease
        ball.material = 0;
        let pose = Pose { translation: glam::Vec3::new(0.6, 0.5, -1.0), ..Default::default() };
        s.objects.push(Object { name: "ball".into(), parts: vec![ball], pose, emitter: None });
        let tris = s.objects.last().unwrap().parts[0].indices.len();
        let mut moved = s.clone();
        moved.objects.last_mut().unwrap().pose.translation.x += 0.05;
        moved.settings.spp = 64;
        let target = render_cpu(&SceneData::build(&moved)?, &moved.settings, &|_, _| {}).radiance;
        let loss = ImageLoss::L2To { output: Output::Radiance, target: target.clone() };
        let params: Vec<ParamPath> = vec!["object/ball/translation".parse()?];
        for (k, (terms, sppse)) in [("interior + primary", 0), ("all terms", 1)].into_iter().enumerate() {
            let opts = AdOptions { replicas: 1, edge_samples: w * h, secondary_edge_samples: sppse };
            let best = best_of_3(|| analytic_gradient(&s, &params, &loss, &opts, &mut CpuBackend).map(|_| ()))?;
            println!("sphere {tris:>7} triangles  {terms:<20} {best:7.3} s");
            csv += &format!("{tris},{w},{h},{spp},{terms},{best:.4}\n");
            series[k].push(Point::new(tris as f64, best));
        }
        match mitsuba_seconds(&s, &target, &work.join(format!("ball_{tris}"))) {
            Ok(best) => {
                println!("sphere {tris:>7} triangles  {:<20} {best:7.3} s", "Mitsuba prb_projective");
                csv += &format!("{tris},{w},{h},{spp},mitsuba prb_projective (guiding none),{best:.4}\n");
                series[2].push(Point::new(tris as f64, best));
            }
            Err(e) => println!("sphere {tris:>7} triangles  Mitsuba left out: {e:#}"),
        }
    }
    let _ = std::fs::remove_dir_all(&work);
    let names = ["psdr interior + primary", "psdr all terms (secondary boundary)", "Mitsuba prb_projective"];
    let chart = XyChart {
        title: "Seconds per translation gradient against the moving mesh's triangles".into(),
        caption: format!(
            "flat-shaded sphere in the example room, L2 to a target moved 5 cm, {w}x{h}, {spp} spp, CPU (2 threads)"
        ),
        x_label: "triangles of the moving mesh".into(),
        y_label: "seconds".into(),
        log_x: true,
        log_y: true,
        series: series
            .into_iter()
            .zip(names)
            .filter(|(points, _)| !points.is_empty())
            .map(|(points, name)| Series::marked(name, points))
            .collect(),
        hlines: vec![],
        width: 640.0,
        height: 400.0,
        legend_right: false,
    };
    psdr_benchmarks::write_results("secondary_scaling", &csv, &chart.svg())?;
    Ok(())
}

/// The best of 3 timed gradient iterations of Mitsuba 3's `prb_projective` (guiding none, welded meshes; after
/// one warm-up for its JIT) on `scene` exported to `dir`: the ball's x translation, L2 to `target`
/// (benchmarks/mitsuba_grad.py, the driver bench_grad uses).
fn mitsuba_seconds(scene: &psdr::scene::Scene, target: &[f32], dir: &std::path::Path) -> anyhow::Result<f64> {
    use anyhow::Context;
    let bench = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let python = bench.join(".venv/bin/python");
    anyhow::ensure!(python.exists(), "{} missing: run benchmarks/setup_mitsuba.sh", python.display());
    let xml = psdr::export::mitsuba::export_mitsuba(scene, dir)?;
    let target_path = dir.join("target.f32");
    std::fs::write(&target_path, target.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>())?;
    // The exported shapes' ids (object_part, non-alphanumerics as '_'), as export_mitsuba names them.
    let ball = scene.objects.last().context("no ball")?;
    let shapes: Vec<String> = ball
        .parts
        .iter()
        .map(|p| {
            format!("{}_{}", ball.name, p.name)
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                .collect()
        })
        .collect();
    let cfg = serde_json::json!({
        "scene": xml, "width": scene.camera.width, "height": scene.camera.height, "target": target_path,
        "max_depth": scene.settings.max_depth, "rr_depth": scene.settings.rr_depth,
        "params": [{"label": "ball", "kind": "translation", "shapes": shapes, "component": 0}],
        "integrators": [{"label": "prb_projective_noguide", "type": "prb_projective", "guiding": "none",
                         "weld": true, "spp": [scene.settings.spp]}],
        "seeds": [0, 1, 2],
    });
    let cfg_path = dir.join("config.json");
    std::fs::write(&cfg_path, serde_json::to_string_pretty(&cfg)?)?;
    let llvm =
        std::env::var("DRJIT_LIBLLVM_PATH").unwrap_or_else(|_| "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1".into());
    let out = std::process::Command::new(&python)
        .arg(bench.join("mitsuba_grad.py"))
        .arg(&cfg_path)
        .env("DRJIT_LIBLLVM_PATH", llvm)
        .output()
        .context("starting mitsuba_grad.py")?;
    anyhow::ensure!(out.status.success(), "mitsuba_grad.py failed: {}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let times: Vec<f64> = stdout
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(&l[l.find('{')?..]).ok())
        .filter(|v| v["event"] == "iteration")
        .filter_map(|v| v["seconds"].as_f64())
        .collect();
    times.into_iter().reduce(f64::min).context("mitsuba_grad.py reported no iteration")
}
