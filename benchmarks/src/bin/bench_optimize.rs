//! Time per optimisation iteration, split into render, loss (tape forward), backward (tape + renderer adjoint)
//! and step, for the fit example's three kinds of stage at 128x96 and 256x192, and the overhead of running the
//! loss as a Rhai closure instead of Rust. Writes benchmarks/results/optimize.csv and optimize.svg:
//! `cargo run -p psdr-benchmarks --release --bin bench_optimize [-- --iters N]`.

use anyhow::Context;
use psdr::backend::CpuBackend;
use psdr::loss::{self, Tensor};
use psdr::optim::IterationRecord;
use psdr::optim::{optimize, OptimizeOptions, ParamSpec, Rendered};
use psdr::report::chart::BarChart;
use psdr::scene::{load_scene, Scene};
use psdr::script::{run_script, RunOptions, ScriptRun};
use std::path::{Path, PathBuf};
use std::rc::Rc;

#[derive(clap::Parser)]
struct Args {
    /// Timed iterations per configuration (after one warm-up iteration).
    #[arg(long, default_value_t = 12)]
    iters: usize,
    /// Rounds of the Rust / Rhai comparison (interleaved, best kept).
    #[arg(long, default_value_t = 3)]
    rounds: usize,
}

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

fn scene_at(file: &str, w: u32, h: u32) -> anyhow::Result<Scene> {
    let mut s = load_scene(&repo(file))?;
    s.camera.width = w;
    s.camera.height = h;
    Ok(s)
}

/// What the fit example's stages optimise, and with which loss.
#[derive(Clone, Copy, PartialEq)]
enum Stage {
    /// Light and albedos, L2 on radiance: the fused estimator.
    Appearance,
    /// The same with the fused estimator off (primal render + independent adjoint pass).
    AppearanceTwoPass,
    /// The cabinet's floor-plane translation and yaw, L2 on the blurred radiance (boundary terms).
    Pose,
}

impl Stage {
    fn name(self) -> &'static str {
        match self {
            Stage::Appearance => "appearance (fused L2)",
            Stage::AppearanceTwoPass => "appearance (two-pass)",
            Stage::Pose => "pose (blurred L2)",
        }
    }
    fn params(self) -> &'static [&'static str] {
        match self {
            Stage::Pose => &["object/cabinet/translation", "object/cabinet/yaw"],
            _ => &["light/light/radiance", "material/floor/albedo", "material/cabinet/albedo"],
        }
    }
}

/// Mean per-iteration seconds [render, loss, backward, step] over the records after the first (warm-up).
fn means(records: &[IterationRecord]) -> [f64; 4] {
    let r = &records[1.min(records.len())..];
    let n = r.len().max(1) as f64;
    let sum = |f: fn(&IterationRecord) -> f64| r.iter().map(f).sum::<f64>() / n;
    [sum(|x| x.seconds_render), sum(|x| x.seconds_loss), sum(|x| x.seconds_backward), sum(|x| x.seconds_step)]
}

fn run_rust(stage: Stage, w: u32, h: u32, iters: usize, target: &Tensor) -> anyhow::Result<Vec<IterationRecord>> {
    let mut scene = scene_at("examples/fit/start.json", w, h)?;
    let specs: Vec<ParamSpec> =
        stage.params().iter().map(|p| ParamSpec::new(&scene, p.parse().unwrap())).collect::<Result<_, _>>()?;
    let opts = OptimizeOptions {
        iters: iters + 1,
        spp: 4,
        seed: 1,
        fused: stage != Stage::AppearanceTwoPass,
        ..Default::default()
    };
    let blurred = loss::blur(target, 1.5)?;
    let mut l = |r: Rc<Rendered>| -> psdr::Result<Vec<(String, Tensor)>> {
        let v = match stage {
            Stage::Pose => loss::l2(&loss::blur(&r.radiance()?, 1.5)?, &blurred)?,
            _ => loss::l2(&r.radiance()?, target)?,
        };
        Ok(vec![("loss".into(), v)])
    };
    Ok(optimize(&mut scene, &specs, &mut l, &opts, &mut CpuBackend, &mut |_| {})?.records)
}

/// The same optimisation as `run_rust` written as a Rhai script, run through `psdr run`'s machinery.
fn run_rhai(
    stage: Stage,
    w: u32,
    h: u32,
    iters: usize,
    photo: &Path,
    dir: &Path,
) -> anyhow::Result<Vec<IterationRecord>> {
    let params: Vec<String> = stage.params().iter().map(|p| format!("\"{p}\"")).collect();
    let loss = match stage {
        Stage::Pose => "|r| l2(blur(r.radiance, 1.5), target)",
        _ => "|r| l2(r.radiance, photo)",
    };
    let script = format!(
        "let scene = load_scene(\"{}\");\nscene.set_resolution({w}, {h});\nlet photo = load_photo(PHOTO, scene);\n\
         let target = blur(photo, 1.5);\nscene = stage(\"bench\", scene, |s| {{\n  optimize(s, #{{ params: [{}], \
         iters: {}, spp: 4, seed: 1, fused: {}, loss: {loss} }});\n  s\n}});\n",
        repo("examples/fit/start.json").display(),
        params.join(", "),
        iters + 1,
        stage != Stage::AppearanceTwoPass
    );
    let path = dir.join("bench.rhai");
    std::fs::write(&path, script)?;
    let out = dir.join("out");
    run_script(
        ScriptRun {
            script: path,
            photo: photo.to_path_buf(),
            out: out.clone(),
            sets: vec![],
            options: RunOptions { quiet: true, preview_spp: 1, ..Default::default() },
            command: "bench_optimize".into(),
        },
        Box::new(CpuBackend),
    )?;
    let text = std::fs::read_to_string(out.join("stages/01_bench/stage.json"))?;
    let stage: psdr::report::StageReport = serde_json::from_str(&text)?;
    Ok(stage.optimizations.into_iter().next().context("no optimisation recorded")?.iterations)
}

fn main() -> anyhow::Result<()> {
    let a = <Args as clap::Parser>::parse();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let dir = std::env::temp_dir().join(format!("psdr-bench-optimize-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let mut csv = String::from(
        "stage,width,height,loss_in,threads,iterations,render_ms,loss_ms,backward_ms,step_ms,total_ms,rhai_overhead_pct,\
         iteration_difference_pct,identical_trajectory\n",
    );
    let mut bars = vec![];
    for (w, h) in [(128u32, 96u32), (256, 192)] {
        // The photo: the truth rendered at 256 spp (a PNG, as a user would give it).
        let truth = scene_at("examples/fit/truth.json", w, h)?;
        let mut settings = truth.settings.clone();
        settings.spp = 256;
        let frame = psdr::render::render_cpu(&psdr::render::SceneData::build(&truth)?, &settings, &|_, _| {});
        let photo = dir.join(format!("photo_{w}.png"));
        psdr::output::write_png_srgb(&photo, w, h, &frame.radiance)?;
        let target = Tensor::constant(psdr::script::read_image(&photo)?);
        for stage in [Stage::Appearance, Stage::AppearanceTwoPass, Stage::Pose] {
            // Interleaved rounds; per phase the best (least disturbed) round's mean.
            let (mut rust, mut rhai) = ([f64::INFINITY; 4], [f64::INFINITY; 4]);
            let mut identical = true;
            for round in 0..a.rounds {
                // Alternate which goes first, so order effects (caches, clocks) do not favour one.
                let (rr, sr) = if round % 2 == 0 {
                    let rr = run_rust(stage, w, h, a.iters, &target)?;
                    (rr, run_rhai(stage, w, h, a.iters, &photo, &dir)?)
                } else {
                    let sr = run_rhai(stage, w, h, a.iters, &photo, &dir)?;
                    (run_rust(stage, w, h, a.iters, &target)?, sr)
                };
                // The same optimisation either way: the same losses and parameters, iteration by iteration.
                identical &= rr.iter().zip(&sr).all(|(x, y)| x.loss == y.loss && x.values == y.values);
                let (r, s) = (means(&rr), means(&sr));
                for k in 0..4 {
                    rust[k] = rust[k].min(r[k]);
                    rhai[k] = rhai[k].min(s[k]);
                }
            }
            let total = |m: &[f64; 4]| m.iter().sum::<f64>();
            // The Rhai closure runs in the loss phase (the fused estimator's probe of the loss is in the render
            // phase; it is one more closure call of the same cost). The whole-iteration difference also holds
            // the machine's timing noise, reported beside it.
            let probes = if stage == Stage::Appearance { 2.0 } else { 1.0 };
            let overhead = probes * (rhai[1] - rust[1]) / total(&rust) * 100.0;
            let whole = (total(&rhai) - total(&rust)) / total(&rust) * 100.0;
            for (lang, m) in [("rust", rust), ("rhai", rhai)] {
                println!(
                    "{w}x{h} {:<24} {lang}: render {:7.1} loss {:6.2} backward {:7.1} step {:5.2} = {:7.1} ms/iteration",
                    stage.name(),
                    m[0] * 1e3,
                    m[1] * 1e3,
                    m[2] * 1e3,
                    m[3] * 1e3,
                    total(&m) * 1e3
                );
                csv += &format!(
                    "{},{w},{h},{lang},{threads},{},{:.3},{:.3},{:.3},{:.3},{:.3},{},{},{identical}\n",
                    stage.name(),
                    a.iters,
                    m[0] * 1e3,
                    m[1] * 1e3,
                    m[2] * 1e3,
                    m[3] * 1e3,
                    total(&m) * 1e3,
                    if lang == "rhai" { format!("{overhead:.3}") } else { String::new() },
                    if lang == "rhai" { format!("{whole:.2}") } else { String::new() }
                );
            }
            println!(
                "  Rhai overhead (loss closure): {overhead:+.3} % of an iteration; whole iterations differ by {whole:+.2} % \
                 (timing noise); identical trajectories: {identical}"
            );
            bars.push((format!("{} {w}x{h}", stage.name()), rust.iter().map(|v| v * 1e3).collect::<Vec<_>>()));
        }
    }
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/optimize.csv");
    std::fs::create_dir_all(out.parent().unwrap())?;
    std::fs::write(&out, &csv)?;
    let chart = BarChart {
        title: format!("Fit example: ms per optimisation iteration, 4 spp ({threads} threads)"),
        unit: "ms".into(),
        series: ["render (fused: render + gradient)", "loss (tape)", "backward (tape + adjoint)", "step"]
            .map(String::from)
            .to_vec(),
        rows: bars,
        stacked: true,
    };
    std::fs::write(out.with_extension("svg"), chart.svg())?;
    println!("wrote {} and {}", out.display(), out.with_extension("svg").display());
    std::fs::remove_dir_all(&dir).ok();
    Ok(())
}
