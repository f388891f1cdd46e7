//! Speed against accuracy of radiance gradients (issue 5, deliverable 6): seconds per forward+backward
//! iteration against the relative error of the gradient, for psdr (`analytic_gradient`, swept over spp, sppe
//! and sppse) and for Mitsuba 3 LLVM (`llvm_ad_rgb`, run in the same process tree through
//! benchmarks/mitsuba_grad.py on the scene `psdr export` writes), both against one truth: psdr's
//! `central_difference` at high spp over several seeds, with its standard error, of the L2 loss linearised at
//! the scene (`linearised_l2`: FD of the L2 of noisy renders carries the derivative of their variance).
//!
//! `cargo run -p psdr-benchmarks --release --bin bench_grad [-- --out DIR] [--large] [--quick] [--no-mitsuba]
//! [--only CASE] [--backend cpu|vk] [--chart-only CSV]`
//! writes DIR/grad.csv and DIR/grad.svg (default benchmarks/results). Needs benchmarks/setup_mitsuba.sh
//! (DRJIT_LIBLLVM_PATH defaults to Debian's libLLVM 19).
//!
//! Scenes: (a) the room case (examples/cube_room), a flat-shaded blue cube (0.5 m, yaw 30 deg)
//! resting on the floor of a closed room (inward box 4 x 2.6 x 5, diffuse 0.7) under a ceiling light, d/dx of
//! the cube's translation,
//! L2 to a target with the cube moved 5 cm along x; (b) the same with the cube lifted 5 cm; (c) the example
//! room, wall albedo and ceiling-light radiance, L2 to a target with both perturbed. 128x96; with --large
//! also (a) at 512x384, 16 spp. `--only furnished_room`: the furnished room of Sweet Home 3D models at 128x96,
//! with --large at 256x192.
//!
//! One psdr iteration = `GradientEvaluator::gradient` with one replica: its primal render (which gives the loss
//! value and the adjoint) and the backward pass, or the fused pass for material and light parameters. One
//! Mitsuba iteration = parameter update + `mi.render` + L2 + `dr.backward`. psdr's iterations run interleaved
//! with Mitsuba's (a share of them before each Mitsuba iteration, its sweep points in order as Mitsuba's spp),
//! so drift of the shared machine affects both alike; each method's time is its best over the seeds, after one
//! untimed warm-up per sweep point (psdr) or timed-as-cold one per spp (Mitsuba).
//! Relative error = |g - g_fd| / |g_fd| over the parameter's compared components, per seed; the CSV gives its
//! mean and standard deviation over seeds and the error of the seed-averaged gradient (a bias indicator).

use anyhow::{bail, Context};
use psdr::backend::{Backend, CpuBackend};
use psdr::export::mitsuba::export_mitsuba;
use psdr::grad::{central_difference, AdOptions, FdOptions, GradientEvaluator, ImageLoss, Output, ParamPath};
use psdr::render::SceneData;
use psdr::scene::{load_scene, Scene};
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::io::{BufRead, BufReader, Write as _};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// One differentiated parameter: which components are compared, its FD step, and how Mitsuba addresses it.
struct Param {
    path: ParamPath,
    components: Vec<usize>,
    fd_step: f32,
    mitsuba: Value,
}

struct FdPlan {
    spp: u32,
    replicas: u32,
    /// A second, cheaper FD at this spp: a loss of noisy images that is not linear in them carries an O(1/spp)
    /// bias; (fd_low - fd) * low/(spp - low) estimates it at `spp` (about zero for the linearised L2, a check).
    low_spp: u32,
}

struct Case {
    name: String,
    scene: Scene,
    params: Vec<Param>,
    target: Vec<f32>,
    /// Sweep sppe/sppse and run Mitsuba's projective integrators (geometry); otherwise spp only and `prb`.
    geometric: bool,
    fd: FdPlan,
    psdr_sweep: Vec<(u32, u32, u32)>,
    mitsuba_integrators: Vec<Value>,
    /// Central differences of Mitsuba's own loss (spp, seeds): checks the hookup and Mitsuba's renderer.
    mitsuba_fd: Option<(u32, u32)>,
    seeds: u32,
}

/// A measured method on one case: per-seed gradients (one vector per parameter), times and losses.
#[derive(Default)]
struct Runs {
    grads: Vec<Vec<Vec<f64>>>,
    times: Vec<f64>,
    losses: Vec<f64>,
    cold: Option<f64>,
}

struct Row {
    case: String,
    size: String,
    method: String,
    spp: u32,
    sppe: String,
    sppse: String,
    runs: Runs,
}

/// The room case, shipped as examples/cube_room (the tests' scene too), at `width` x `height` with the
/// cube raised by `lift`.
fn room_with_cube(lift: f32, width: u32, height: u32) -> anyhow::Result<Scene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/cube_room/scene.json");
    let mut s = load_scene(&path).with_context(|| format!("loading {}", path.display()))?;
    (s.camera.width, s.camera.height) = (width, height);
    let cube = s.object_index("cube").context("examples/cube_room has no cube")?;
    s.objects[cube].pose.translation.y += lift;
    Ok(s)
}

/// Mitsuba ids of an object's shapes, as the exporter writes them.
fn shape_ids(scene: &Scene, object: &str) -> Vec<String> {
    let o = &scene.objects[scene.object_index(object).expect("object")];
    o.parts
        .iter()
        .map(|p| {
            format!("{}_{}", o.name, p.name)
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' })
                .collect()
        })
        .collect()
}

fn render(scene: &Scene, spp: u32, seed: u32) -> anyhow::Result<Vec<f32>> {
    let mut s = scene.settings.clone();
    s.spp = spp;
    s.seed = seed;
    Ok(CpuBackend.render(&SceneData::build(scene)?, &s, &|_, _| {})?.radiance)
}

fn l2(loss_target: &[f32]) -> ImageLoss {
    ImageLoss::L2To { output: Output::Radiance, target: loss_target.to_vec() }
}

fn cube_case(lift: f32, width: u32, height: u32, large: bool, quick: bool) -> anyhow::Result<Case> {
    let name = if lift == 0.0 { "cube_on_floor" } else { "cube_lifted" };
    let scene = room_with_cube(lift, width, height)?;
    let mut t = scene.clone();
    t.objects[1].pose.translation.x += 0.05;
    let target_spp = if large { 256 } else { 1024 };
    let target = render(&t, target_spp, 777)?;
    let ids = shape_ids(&scene, "cube");
    let psdr_sweep = if large {
        vec![(16, 1 << 16, 1), (16, 1 << 18, 1)]
    } else if quick {
        vec![(4, 1 << 14, 1), (16, 1 << 16, 1)]
    } else {
        vec![
            (4, 1 << 14, 1),
            (4, 1 << 16, 1),
            (16, 1 << 14, 1),
            (16, 1 << 16, 1),
            (16, 1 << 18, 1),
            (16, 1 << 16, 2),
            (64, 1 << 16, 1),
            (64, 1 << 18, 1),
            (64, 1 << 18, 2),
        ]
    };
    let spps: Vec<u32> = if large { vec![16] } else { vec![4, 16, 64] };
    // "weld": Mitsuba renders a copy of the export whose meshes have merged vertices (see mitsuba_grad.py
    // welded_scene): psdr's box exports per-face vertex copies, and Mitsuba's projective integrators then count
    // every edge shared by two faces twice. The unwelded export is kept as a reference series.
    let mut mitsuba_integrators = vec![
        json!({"label": "prb_projective_noguide", "type": "prb_projective", "guiding": "none", "weld": true, "spp": spps}),
        json!({"label": "direct_projective", "type": "direct_projective", "weld": true, "spp": spps}),
        json!({"label": "prb_projective_noguide_unwelded", "type": "prb_projective", "guiding": "none", "spp": spps}),
    ];
    if !large {
        // Mitsuba's default (octree-guided indirect boundary) costs ~20 s per iteration at this size, mostly the
        // guiding octree; measured at 16 spp and 2 seeds only.
        mitsuba_integrators.insert(
            0,
            json!({"label": "prb_projective", "type": "prb_projective", "weld": true, "spp": [16], "seeds": [0, 1]}),
        );
    }
    Ok(Case {
        name: name.into(),
        scene,
        params: vec![Param {
            path: "object/cube/translation".parse()?,
            components: vec![0],
            fd_step: 0.01,
            mitsuba: json!({"label": "object/cube/translation", "kind": "translation", "shapes": ids, "component": 0}),
        }],
        target,
        geometric: true,
        fd: if large {
            FdPlan { spp: 128, replicas: 4, low_spp: 32 }
        } else if quick {
            FdPlan { spp: 256, replicas: 4, low_spp: 64 }
        } else {
            FdPlan { spp: 1024, replicas: 6, low_spp: 128 }
        },
        psdr_sweep,
        mitsuba_integrators,
        mitsuba_fd: if large { None } else { Some((1024, 3)) },
        seeds: if large { 3 } else { 4 },
    })
}

/// The issue "Secondary boundary at scale"'s job: the furnished room of Sweet Home 3D models (tests/src/sweet_home.rs,
/// 28k triangles, flat-shaded), the armchair's translation along x, L2 to a target with it moved 5 cm.
fn furnished_case(quick: bool, width: u32, height: u32) -> anyhow::Result<Case> {
    let scene = psdr_tests::sweet_home::sweet_home_room(width, height, 16)
        .context("the furnished room needs the Sweet Home 3D libraries (apt sweethome3d-furniture)")?;
    let mut t = scene.clone();
    let a = t.object_index("armchair").expect("the room has an armchair");
    t.objects[a].pose.translation.x += 0.05;
    let target = render(&t, 1024, 777)?;
    let ids = shape_ids(&scene, "armchair");
    let psdr_sweep = if quick {
        vec![(4, 1 << 14, 1), (16, 1 << 16, 1)]
    } else {
        vec![(4, 1 << 14, 1), (16, 1 << 14, 1), (16, 1 << 16, 1), (16, 1 << 16, 2), (64, 1 << 16, 1), (64, 1 << 18, 2)]
    };
    let spps: Vec<u32> = if quick { vec![4, 16] } else { vec![4, 16, 64] };
    Ok(Case {
        name: "furnished_room".into(),
        scene,
        params: vec![Param {
            path: "object/armchair/translation".parse()?,
            components: vec![0],
            fd_step: 0.01,
            mitsuba: json!({"label": "object/armchair/translation", "kind": "translation", "shapes": ids, "component": 0}),
        }],
        target,
        geometric: true,
        fd: if quick {
            FdPlan { spp: 256, replicas: 4, low_spp: 64 }
        } else {
            FdPlan { spp: 1024, replicas: 4, low_spp: 128 }
        },
        psdr_sweep,
        mitsuba_integrators: vec![
            json!({"label": "prb_projective_noguide", "type": "prb_projective", "guiding": "none", "weld": true, "spp": spps}),
        ],
        mitsuba_fd: None,
        seeds: 4,
    })
}

fn material_case(quick: bool) -> anyhow::Result<Case> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/room/scene.json");
    let mut scene = load_scene(&path).with_context(|| format!("loading {}", path.display()))?;
    scene.camera.width = 128;
    scene.camera.height = 96;
    let albedo: ParamPath = "material/wall/albedo".parse()?;
    let radiance: ParamPath = "light/ceiling_light/radiance".parse()?;
    let wall = scene.material_index("wall").expect("wall");
    {
        let m = &scene.materials[wall];
        if !matches!(m.specular, psdr::scene::Scalar::Constant(s) if s <= 0.0) || m.normal_map.is_some() {
            bail!("material 'wall' must export as Mitsuba's diffuse for its albedo key");
        }
    }
    let mut t = scene.clone();
    let a = albedo.get(&t)?;
    albedo.set(&mut t, &[a[0] * 0.9, a[1], a[2] * 1.1])?;
    let r = radiance.get(&t)?;
    radiance.set(&mut t, &r.iter().map(|v| v * 1.1).collect::<Vec<_>>())?;
    let target = render(&t, if quick { 256 } else { 1024 }, 777)?;
    let light_keys: Vec<String> =
        shape_ids(&scene, "ceiling_light").into_iter().map(|id| format!("{id}.emitter.radiance.value")).collect();
    let spps = vec![4, 16, 64];
    Ok(Case {
        name: "room_albedo_radiance".into(),
        params: vec![
            Param {
                path: albedo.clone(),
                components: vec![0, 1, 2],
                fd_step: 0.01,
                mitsuba: json!({"label": albedo.to_string(), "kind": "value",
                                "keys": [format!("mat{wall}.brdf_0.reflectance.value")]}),
            },
            Param {
                path: radiance.clone(),
                components: vec![0, 1, 2],
                fd_step: 0.1,
                mitsuba: json!({"label": radiance.to_string(), "kind": "value", "keys": light_keys}),
            },
        ],
        scene,
        target,
        geometric: false,
        fd: if quick {
            FdPlan { spp: 128, replicas: 3, low_spp: 32 }
        } else {
            FdPlan { spp: 512, replicas: 4, low_spp: 64 }
        },
        // psdr also at 8 and 32 spp: its error curve bends between 4 and 64 spp (each half of the fused
        // estimator's samples is stratified on its own), so equal-error times come from nearby points.
        psdr_sweep: [4, 8, 16, 32, 64].iter().map(|&s| (s, 0, 0)).collect(),
        mitsuba_integrators: vec![json!({"label": "prb", "type": "prb", "spp": spps})],
        mitsuba_fd: None,
        // Cheap per seed, and its error is carried by a few emitter-silhouette pixels (heavy-tailed): 4 seeds
        // left the error means uncertain by a factor of about 2, and 16 still moved Mitsuba's 16-spp radiance
        // error from 1.5 % to 1.7 % against 64 (which decides an equal-error time ratio near 2).
        seeds: 64,
    })
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = if x.len() > 1 { x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0) } else { f64::NAN };
    (m, v.sqrt())
}

fn rel_err(g: &[f64], truth: &[f64]) -> f64 {
    let d: f64 = g.iter().zip(truth).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
    d / truth.iter().map(|b| b * b).sum::<f64>().sqrt()
}

fn min(x: &[f64]) -> f64 {
    x.iter().cloned().fold(f64::INFINITY, f64::min)
}

/// The truth for one parameter: FD mean and standard error on the compared components, plus the FD at the
/// lower spp (for the O(1/spp) bias estimate) and the seconds spent.
struct Truth {
    mean: Vec<f64>,
    se: Vec<f64>,
    low: Vec<f64>,
    secs: f64,
}

/// The L2 loss linearised at the case's scene, mean(w · I) with w = 2 (I_ref − T), I_ref an independent render
/// at the truth's spp: its gradient is that of (Ī − T)², what every method here estimates in expectation (psdr
/// takes its adjoint from an independent render; Mitsuba's converges with spp). FD of the L2 of noisy renders
/// differentiates E[(I − T)²] = (Ī − T)² + Var(I): on the furnished room at 1024 spp it read 1.3 % low
/// (measured 2026-11-25: -1.1535e-3 against -1.1682e-3 linearised).
fn linearised_l2(case: &Case) -> anyhow::Result<ImageLoss> {
    let reference = render(&case.scene, case.fd.spp, 9000)?;
    let weights = reference.iter().zip(&case.target).map(|(i, t)| 2.0 * (i - t)).collect();
    Ok(ImageLoss::Weighted { output: Output::Radiance, weights })
}

fn truth(case: &Case, loss: &ImageLoss, p: &Param) -> anyhow::Result<Truth> {
    let fd_at = |spp: u32| -> anyhow::Result<(Vec<f64>, Vec<f64>)> {
        let mut s = case.scene.clone();
        s.settings.spp = spp;
        s.settings.seed = 5000;
        let opts = FdOptions { step: p.fd_step, replicas: case.fd.replicas, components: p.components.clone() };
        let f = central_difference(&s, &p.path, loss, &opts, &mut CpuBackend)?;
        Ok((f.mean, f.std_err))
    };
    let t = Instant::now();
    let (mean, se) = fd_at(case.fd.spp)?;
    let secs = t.elapsed().as_secs_f64();
    let (low, _) = fd_at(case.fd.low_spp)?;
    Ok(Truth { mean, se, low, secs })
}

/// psdr's iterations of one case as a queue of jobs that `run_mitsuba` interleaves with Mitsuba's: per sweep
/// point (in sweep order, as Mitsuba runs its spp in order) one untimed warm-up (Mitsuba gets one per spp
/// group), then one timed iteration per seed. Material and light cases keep one `GradientEvaluator` per point
/// (their iterations move no geometry, so the BVH is built once, as in an optimiser's material stage);
/// geometric cases rebuild every iteration (Mitsuba's parameter update rebuilds its acceleration structure for
/// moved vertices, too).
struct PsdrQueue<'a> {
    case: &'a Case,
    loss: &'a ImageLoss,
    /// (sweep point, seed; None for the warm-up).
    jobs: std::collections::VecDeque<(usize, Option<u32>)>,
    runs: Vec<Runs>,
    evaluators: Vec<GradientEvaluator>,
    /// Where psdr's iterations run (`--backend`); the FD truth always runs on the CPU.
    backend: Box<dyn Backend>,
}

impl<'a> PsdrQueue<'a> {
    fn new(case: &'a Case, loss: &'a ImageLoss, backend: Box<dyn Backend>) -> Self {
        let points = case.psdr_sweep.len();
        let jobs = (0..points)
            .flat_map(|p| std::iter::once((p, None)).chain((0..case.seeds).map(move |s| (p, Some(s)))))
            .collect();
        let runs = (0..points).map(|_| Runs::default()).collect();
        let evaluators = (0..points).map(|_| GradientEvaluator::default()).collect();
        PsdrQueue { case, loss, jobs, runs, evaluators, backend }
    }

    fn run_one(&mut self) -> anyhow::Result<()> {
        let Some((p, seed)) = self.jobs.pop_front() else { return Ok(()) };
        let case = self.case;
        let (spp, sppe, sppse) = case.psdr_sweep[p];
        let paths: Vec<ParamPath> = case.params.iter().map(|p| p.path.clone()).collect();
        let opts = AdOptions { replicas: 1, edge_samples: sppe, secondary_edge_samples: sppse };
        let mut s = case.scene.clone();
        (s.settings.spp, s.settings.seed) = (spp, seed.unwrap_or(0) * 7919 + 11);
        if case.geometric {
            self.evaluators[p] = GradientEvaluator::default();
        }
        let t = Instant::now();
        let g = self.evaluators[p].gradient(&s, &paths, self.loss, &opts, self.backend.as_mut())?;
        let secs = t.elapsed().as_secs_f64();
        if seed.is_none() {
            return Ok(());
        }
        let runs = &mut self.runs[p];
        runs.times.push(secs);
        runs.losses.push(g.loss.context("an L2 loss renders its primal")?);
        // Split the flat gradient per parameter and keep the compared components.
        let mut at = 0;
        let mut per = vec![];
        for p in &case.params {
            let n = p.path.get(&s)?.len();
            per.push(p.components.iter().map(|&c| g.mean[at + c]).collect());
            at += n;
        }
        runs.grads.push(per);
        Ok(())
    }

    /// Runs this queue's share of the work left while Mitsuba has `mitsuba_left` timed iterations to go.
    fn run_share(&mut self, mitsuba_left: u64) -> anyhow::Result<()> {
        for _ in 0..self.jobs.len().div_ceil(mitsuba_left.max(1) as usize) {
            self.run_one()?;
        }
        Ok(())
    }

    fn run_rest(&mut self) -> anyhow::Result<()> {
        while !self.jobs.is_empty() {
            self.run_one()?;
        }
        Ok(())
    }
}

fn write_f32(path: &Path, v: &[f32]) -> anyhow::Result<()> {
    std::fs::write(path, v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>())?;
    Ok(())
}

/// Mitsuba's runs by (integrator label, spp).
type MitsubaRuns = Vec<(String, u32, Runs)>;

/// Runs mitsuba_grad.py on the exported case; returns its runs and the primal check.
/// Mitsuba's runs of `case`; before each of its timed iterations `between(timed iterations left)` runs (psdr's
/// share of its own iterations), so both methods' timings spread over the same stretch of time.
fn run_mitsuba(
    case: &Case,
    dir: &Path,
    reference: &[f32],
    between: &mut dyn FnMut(u64) -> anyhow::Result<()>,
) -> anyhow::Result<(MitsubaRuns, Value)> {
    let bench = Path::new(env!("CARGO_MANIFEST_DIR"));
    let python = bench.join(".venv/bin/python");
    if !python.exists() {
        bail!("{} missing: run benchmarks/setup_mitsuba.sh", python.display());
    }
    let export_dir = dir.join(format!("{}_mitsuba", case.name));
    let xml = export_mitsuba(&case.scene, &export_dir)?;
    let (w, h) = (case.scene.camera.width, case.scene.camera.height);
    write_f32(&export_dir.join("target.f32"), &case.target)?;
    write_f32(&export_dir.join("reference.f32"), reference)?;
    let cfg = json!({
        "scene": xml, "width": w, "height": h,
        "target": export_dir.join("target.f32"), "reference": export_dir.join("reference.f32"), "reference_spp": 256,
        "max_depth": case.scene.settings.max_depth, "rr_depth": case.scene.settings.rr_depth,
        "params": case.params.iter().map(|p| p.mitsuba.clone()).collect::<Vec<_>>(),
        "integrators": case.mitsuba_integrators, "seeds": (0..case.seeds).collect::<Vec<_>>(), "interleave": true,
    });
    let mut cfg = cfg;
    if let Some((spp, seeds)) = case.mitsuba_fd {
        let steps: serde_json::Map<String, Value> =
            case.params.iter().map(|p| (p.path.to_string(), json!(p.fd_step))).collect();
        cfg["fd"] = json!({"spp": spp, "seeds": (100..100 + seeds).collect::<Vec<_>>(), "steps": steps});
    }
    let cfg_path = export_dir.join("config.json");
    std::fs::write(&cfg_path, serde_json::to_string_pretty(&cfg)?)?;
    let llvm =
        std::env::var("DRJIT_LIBLLVM_PATH").unwrap_or_else(|_| "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1".into());
    let mut child = Command::new(&python)
        .arg(bench.join("mitsuba_grad.py"))
        .arg(&cfg_path)
        .env("DRJIT_LIBLLVM_PATH", llvm)
        .stdout(Stdio::piped())
        .stdin(Stdio::piped())
        .spawn()
        .context("starting mitsuba_grad.py")?;
    let mut go = child.stdin.take().expect("piped");
    let mut out: MitsubaRuns = vec![];
    let mut primal = Value::Null;
    for line in BufReader::new(child.stdout.take().expect("piped")).lines() {
        let line = line?;
        // Mitsuba's log (warnings) also goes to stdout; our records are the JSON lines.
        let Some(json_at) = line.find('{') else { continue };
        let Ok(v) = serde_json::from_str::<Value>(&line[json_at..]) else {
            eprintln!("  mitsuba log: {line}");
            continue;
        };
        let event = v["event"].as_str().unwrap_or_default();
        if event == "ready" {
            between(v["remaining"].as_u64().unwrap_or(1))?;
            writeln!(go, "go")?;
            go.flush()?;
            continue;
        }
        if event == "primal_check" {
            println!("  mitsuba primal check: {v}");
            primal = v;
            continue;
        }
        if event == "fd" {
            // Mitsuba's own FD: stored as a pseudo-method with one "seed" (its mean) and the time it took.
            let label = v["label"].as_str().unwrap_or_default();
            let mean: Vec<f64> =
                v["mean"].as_array().map(|a| a.iter().filter_map(|x| x.as_f64()).collect()).unwrap_or_default();
            println!("  mitsuba own FD {label}: {mean:?} ± {} ({} spp)", v["std_err"], v["spp"]);
            let spp = v["spp"].as_u64().unwrap_or(0) as u32;
            let mut runs = Runs { times: vec![v["seconds"].as_f64().unwrap_or(f64::NAN)], ..Default::default() };
            runs.grads.push(
                case.params
                    .iter()
                    .map(|p| {
                        if p.path.to_string() == label {
                            p.components.iter().map(|&c| mean.get(c).copied().unwrap_or(f64::NAN)).collect()
                        } else {
                            vec![f64::NAN; p.components.len()]
                        }
                    })
                    .collect(),
            );
            out.push(("own_fd".into(), spp, runs));
            continue;
        }
        if event != "cold" && event != "iteration" {
            println!("  mitsuba: {v}");
            continue;
        }
        let label = v["integrator"].as_str().unwrap_or_default().to_string();
        let spp = v["spp"].as_u64().unwrap_or(0) as u32;
        let secs = v["seconds"].as_f64().unwrap_or(f64::NAN);
        let idx = match out.iter().position(|(l, s, _)| *l == label && *s == spp) {
            Some(i) => i,
            None => {
                out.push((label.clone(), spp, Runs::default()));
                out.len() - 1
            }
        };
        let runs = &mut out[idx].2;
        if event == "cold" {
            runs.cold = Some(secs);
            println!("  mitsuba {label} {spp} spp: cold iteration {secs:.2} s");
            continue;
        }
        runs.times.push(secs);
        runs.losses.push(v["loss"].as_f64().unwrap_or(f64::NAN));
        let per: Vec<Vec<f64>> = case
            .params
            .iter()
            .map(|p| {
                let g: Vec<f64> = v["grad"][p.path.to_string()]
                    .as_array()
                    .map(|a| a.iter().filter_map(|x| x.as_f64()).collect())
                    .unwrap_or_default();
                // Translation: one float (the component); RGB values: all three.
                if g.len() == 1 {
                    g
                } else {
                    p.components.iter().map(|&c| g.get(c).copied().unwrap_or(f64::NAN)).collect()
                }
            })
            .collect();
        runs.grads.push(per);
    }
    if !child.wait()?.success() {
        bail!("mitsuba_grad.py failed");
    }
    Ok((out, primal))
}

/// Gradient speed against accuracy, psdr against Mitsuba 3 LLVM (CSV + SVG under benchmarks/results).
#[derive(clap::Parser)]
struct Args {
    /// Output folder.
    #[arg(long, default_value_os_t = Path::new(env!("CARGO_MANIFEST_DIR")).join("results"))]
    out: PathBuf,
    /// Only redraw the chart from this CSV.
    #[arg(long)]
    chart_only: Option<PathBuf>,
    /// Only this case (cube_on_floor, cube_lifted, room_albedo_radiance; furnished_room runs only when named).
    #[arg(long)]
    only: Option<String>,
    /// Add the 512x384 rows.
    #[arg(long)]
    large: bool,
    /// A smaller sweep.
    #[arg(long)]
    quick: bool,
    /// Skip Mitsuba.
    #[arg(long)]
    no_mitsuba: bool,
    /// Seeds per method and spp (default: 4, 3 with --large); more seeds firm up the error means.
    #[arg(long)]
    seeds: Option<u32>,
    /// Where psdr's iterations run: cpu or vk (the FD truth and Mitsuba are unaffected).
    #[arg(long, default_value = "cpu")]
    backend: psdr::backend::BackendKind,
}

const CSV_HEADER: &str = "case,size,param,method,spp,sppe,sppse,seeds,seconds_iter,seconds_forward,seconds_grad,\
seconds_cold,rel_err_mean,rel_err_sd,rel_err_of_mean,grad_mean,truth,truth_se,loss_mean,loss_se\n";

fn fmt_vec(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x:.6e}")).collect::<Vec<_>>().join(" ")
}

fn main() -> anyhow::Result<()> {
    let args = <Args as clap::Parser>::parse();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    if let Some(csv) = &args.chart_only {
        return write_chart(csv, threads);
    }
    std::fs::create_dir_all(&args.out)?;
    let work = std::env::temp_dir().join(format!("psdr_bench_grad_{}", std::process::id()));
    std::fs::create_dir_all(&work)?;
    println!("bench_grad: {threads} threads; best-of timings (the machine may be shared); work dir {}", work.display());
    let wanted = |name: &str| args.only.as_deref().is_none_or(|o| o == name);
    let mut cases = vec![];
    if args.large && args.only.as_deref() == Some("furnished_room") {
        // The size for the furnished room.
        cases.push(furnished_case(args.quick, 256, 192)?);
    } else if args.large {
        cases.push(cube_case(0.0, 512, 384, true, args.quick)?);
    } else {
        for (name, lift) in [("cube_on_floor", 0.0), ("cube_lifted", 0.05)] {
            if wanted(name) {
                cases.push(cube_case(lift, 128, 96, false, args.quick)?);
            }
        }
        if wanted("room_albedo_radiance") {
            cases.push(material_case(args.quick)?);
        }
        // Not in the default run (its truth alone takes minutes): --only furnished_room.
        if args.only.as_deref() == Some("furnished_room") {
            cases.push(furnished_case(args.quick, 128, 96)?);
        }
    }
    if let Some(n) = args.seeds {
        cases.iter_mut().for_each(|c| c.seeds = n.max(2));
    }
    let csv_path = args.out.join("grad.csv");
    let mut csv = String::from(CSV_HEADER);
    let total = Instant::now();
    for case in &cases {
        let size = format!("{}x{}", case.scene.camera.width, case.scene.camera.height);
        println!("== {} at {size}", case.name);
        let loss = l2(&case.target);
        let linear = linearised_l2(case)?;
        let truths: Vec<Truth> = case.params.iter().map(|p| truth(case, &linear, p)).collect::<anyhow::Result<_>>()?;
        for (p, t) in case.params.iter().zip(&truths) {
            let k = case.fd.low_spp as f64 / (case.fd.spp - case.fd.low_spp) as f64;
            let bias: Vec<f64> = t.low.iter().zip(&t.mean).map(|(l, m)| (l - m) * k).collect();
            println!(
                "  truth {}: FD {} ± {} ({} spp x {} seeds x 2, {:.1} s); FD at {} spp {}; est. 1/spp bias at {} spp {}",
                p.path,
                fmt_vec(&t.mean),
                fmt_vec(&t.se),
                case.fd.spp,
                case.fd.replicas,
                t.secs,
                case.fd.low_spp,
                fmt_vec(&t.low),
                case.fd.spp,
                fmt_vec(&bias)
            );
        }
        let backend = psdr::backend::create_backend(args.backend)?;
        writeln!(csv, "# {},{size}, psdr backend: {}", case.name, backend.name())?;
        let mut psdr = PsdrQueue::new(case, &loss, backend);
        let (mut rows, mut mitsuba_rows) = (vec![], vec![]);
        let mut primal = Value::Null;
        if !args.no_mitsuba {
            let reference = render(&case.scene, 256, 4242)?;
            let (m, pc) = run_mitsuba(case, &work, &reference, &mut |left| psdr.run_share(left))?;
            primal = pc;
            for (label, spp, runs) in m {
                mitsuba_rows.push(Row {
                    case: case.name.clone(),
                    size: size.clone(),
                    method: format!("mitsuba_{label}"),
                    spp,
                    sppe: "-".into(),
                    sppse: "-".into(),
                    runs,
                });
            }
        }
        psdr.run_rest()?;
        for (&(spp, sppe, sppse), runs) in case.psdr_sweep.iter().zip(psdr.runs) {
            let (sppe_s, sppse_s) =
                if case.geometric { (sppe.to_string(), sppse.to_string()) } else { ("-".into(), "-".into()) };
            rows.push(Row {
                case: case.name.clone(),
                size: size.clone(),
                method: "psdr".into(),
                spp,
                sppe: sppe_s,
                sppse: sppse_s,
                runs,
            });
        }
        rows.append(&mut mitsuba_rows); // psdr's rows first in the CSV
                                        // Loss agreement at equal spp (noise included: E[L] = |E[I] - T|^2 + Var/spp, so equal spp is required).
        for r in rows.iter().filter(|r| r.method != "psdr") {
            if let Some(o) = rows.iter().find(|o| o.method == "psdr" && o.spp == r.spp) {
                let (lm, ls) = mean_sd(&r.runs.losses);
                let (om, os) = mean_sd(&o.runs.losses);
                println!(
                    "  loss at {} spp: {} {lm:.6e} ± {:.1e}, psdr {om:.6e} ± {:.1e} (ratio {:.4})",
                    r.spp,
                    r.method,
                    ls / (r.runs.losses.len() as f64).sqrt(),
                    os / (o.runs.losses.len() as f64).sqrt(),
                    lm / om
                );
            }
        }
        if !primal.is_null() {
            writeln!(csv, "# {},{size}, primal check (Mitsuba path 256 spp vs psdr 256 spp): {primal}", case.name)?;
        }
        for (pi, p) in case.params.iter().enumerate() {
            let t = &truths[pi];
            let rel_se =
                t.se.iter().map(|x| x * x).sum::<f64>().sqrt() / t.mean.iter().map(|x| x * x).sum::<f64>().sqrt();
            writeln!(
                csv,
                "{},{size},{},fd_truth,{},-,-,{},{:.4},,,,{rel_se:.4e},,,,{},{},,",
                case.name,
                p.path,
                case.fd.spp,
                case.fd.replicas,
                t.secs / (2 * case.fd.replicas as usize * p.components.len()) as f64,
                fmt_vec(&t.mean),
                fmt_vec(&t.se)
            )?;
            for r in &rows {
                let errs: Vec<f64> = r.runs.grads.iter().map(|g| rel_err(&g[pi], &t.mean)).collect();
                if errs.iter().all(|e| e.is_nan()) {
                    continue; // Mitsuba's own FD of another parameter
                }
                let (em, esd) = mean_sd(&errs);
                let n = r.runs.grads.len();
                let gmean: Vec<f64> = (0..p.components.len())
                    .map(|c| r.runs.grads.iter().map(|g| g[pi][c]).sum::<f64>() / n as f64)
                    .collect();
                let (lm, lsd) = mean_sd(&r.runs.losses);
                // A single run (Mitsuba's own FD) has no spread and no loss: empty fields, not NaN.
                let finite = |x: f64, f: &dyn Fn(f64) -> String| if x.is_finite() { f(x) } else { String::new() };
                let esd_s = finite(esd, &|x| format!("{x:.4e}"));
                let lm_s = finite(lm, &|x| format!("{x:.6e}"));
                let lse_s = finite(lsd / (r.runs.losses.len() as f64).sqrt(), &|x| format!("{x:.2e}"));
                // Every method's iteration includes its own primal render (the loss value); the forward column
                // is kept empty for the CSV's earlier readers.
                let grad = min(&r.runs.times);
                let iter = grad;
                writeln!(
                    csv,
                    "{},{},{},{},{},{},{},{n},{iter:.4},,{grad:.4},{},{em:.4e},{esd_s},{:.4e},{},{},{},{lm_s},{lse_s}",
                    r.case,
                    r.size,
                    p.path,
                    r.method,
                    r.spp,
                    r.sppe,
                    r.sppse,
                    r.runs.cold.map(|c| format!("{c:.3}")).unwrap_or_default(),
                    rel_err(&gmean, &t.mean),
                    fmt_vec(&gmean),
                    fmt_vec(&t.mean),
                    fmt_vec(&t.se),
                )?;
                println!(
                    "  {:<34} {:<28} spp {:>3} sppe {:>6} sppse {:>2}: {iter:7.3} s/iter, rel err {:.3} ± {} (of mean {:.3})",
                    r.method,
                    p.path.to_string(),
                    r.spp,
                    r.sppe,
                    r.sppse,
                    em,
                    if esd.is_finite() { format!("{esd:.3}") } else { "n/a".into() },
                    rel_err(&gmean, &t.mean)
                );
            }
        }
        std::fs::write(work.join("partial.csv"), &csv)?;
    }
    println!("total {:.0} s", total.elapsed().as_secs_f64());
    // --large and --only add their rows to an existing grad.csv (replacing earlier rows of the same case and
    // size), so one case can be refreshed without rerunning the others.
    if (args.large || args.only.is_some()) && csv_path.exists() {
        let keys: Vec<String> =
            cases.iter().map(|c| format!("{},{}x{},", c.name, c.scene.camera.width, c.scene.camera.height)).collect();
        let old = std::fs::read_to_string(&csv_path)?;
        let kept: String = old
            .lines()
            .skip(1)
            .filter(|l| !keys.iter().any(|k| l.trim_start_matches("# ").starts_with(k.as_str())))
            .map(|l| format!("{l}\n"))
            .collect();
        csv = format!("{CSV_HEADER}{kept}{}", &csv[CSV_HEADER.len()..]);
    }
    std::fs::write(&csv_path, &csv)?;
    std::fs::remove_dir_all(&work).ok();
    write_chart(&csv_path, threads)?;
    Ok(())
}

/// One plotted point: seconds per iteration, relative error mean and spread, and a short label.
struct Point {
    secs: f64,
    err: f64,
    sd: f64,
    label: String,
}

/// Series colours by method (psdr first).
const SERIES: [(&str, &str, &str); 6] = [
    ("psdr", "#1f77b4", "psdr (analytic_gradient)"),
    ("mitsuba_prb_projective", "#d62728", "Mitsuba prb_projective (octree guiding), welded"),
    ("mitsuba_prb_projective_noguide", "#ff7f0e", "Mitsuba prb_projective, guiding none, welded"),
    ("mitsuba_direct_projective", "#9467bd", "Mitsuba direct_projective, welded"),
    ("mitsuba_prb_projective_noguide_unwelded", "#8c564b", "Mitsuba prb_projective, guiding none, export as is"),
    ("mitsuba_prb", "#2ca02c", "Mitsuba prb"),
];

fn write_chart(csv_path: &Path, threads: usize) -> anyhow::Result<()> {
    let csv = std::fs::read_to_string(csv_path)?;
    let svg = csv_path.with_extension("svg");
    std::fs::write(&svg, chart(&csv, threads))?;
    println!("wrote {} and {}", csv_path.display(), svg.display());
    Ok(())
}

/// Log-log panels, one per (case, size, parameter): x = seconds per forward+backward iteration, y = relative
/// gradient error against FD (mean over seeds, bar = ± one standard deviation), one series per method (its
/// Pareto front as a line); the dashed line is the truth's own relative standard error (errors near it are not
/// resolved).
fn chart(csv: &str, threads: usize) -> String {
    use psdr::report::chart::{grid, Line, Point as P, Series, XyChart};
    // (title, (method, point) list, truth's relative standard error)
    type Panel = (String, Vec<(String, Point)>, f64);
    let mut panels: Vec<Panel> = vec![];
    for line in csv.lines().skip(1).filter(|l| !l.starts_with('#')) {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() < 16 {
            continue;
        }
        let key = format!("{} {} {}", f[0], f[1], f[2]);
        let idx = match panels.iter().position(|p| p.0 == key) {
            Some(i) => i,
            None => {
                panels.push((key, vec![], f64::NAN));
                panels.len() - 1
            }
        };
        let num = |i: usize| f[i].parse::<f64>().unwrap_or(f64::NAN);
        if f[3] == "fd_truth" {
            panels[idx].2 = num(12);
            continue;
        }
        let label = if f[3] == "psdr" && f[5] != "-" {
            format!("{}/{}k/{}", f[4], num(5) as u64 / 1024, f[6])
        } else {
            f[4].to_string()
        };
        panels[idx].1.push((f[3].to_string(), Point { secs: num(8), err: num(12), sd: num(13), label }));
    }
    let good = |v: f64| v.is_finite() && v > 0.0;
    let charts: Vec<XyChart> = panels
        .iter()
        .map(|(title, pts, floor)| {
            let mut c = XyChart::new(title, "seconds per iteration", "relative error");
            (c.log_x, c.log_y, c.width, c.height) = (true, true, 460.0, 360.0);
            if good(*floor) {
                c.hlines.push(*floor);
            }
            for (method, colour, name) in SERIES {
                let mut series: Vec<&Point> = pts
                    .iter()
                    .filter(|p| p.0 == method)
                    .map(|p| &p.1)
                    .filter(|p| good(p.secs) && good(p.err))
                    .collect();
                if series.is_empty() {
                    continue;
                }
                series.sort_by(|a, b| a.secs.total_cmp(&b.secs));
                // Pareto front (no faster point with lower error) as a line; psdr labels only its front points.
                let mut front: Vec<&Point> = vec![];
                for p in &series {
                    if front.last().is_none_or(|q| p.err < q.err) {
                        front.push(p);
                    }
                }
                let mut line = Series::line(name, front.iter().map(|p| P::new(p.secs, p.err)).collect()).color(colour);
                line.legend = false;
                let points = series
                    .iter()
                    .map(|p| {
                        let labelled = method != "psdr" || front.iter().any(|q| std::ptr::eq(*q, *p));
                        P {
                            x: p.secs,
                            y: p.err,
                            label: labelled.then(|| p.label.clone()),
                            err: good(p.sd).then_some(p.sd),
                        }
                    })
                    .collect();
                let mut marks = Series::marked(name, points).color(colour);
                (marks.line, marks.legend) = (Line::None, false);
                c.series.extend([line, marks]);
            }
            c
        })
        .collect();
    grid(
        &format!(
            "Gradient error against FD vs seconds per forward+backward iteration ({threads} CPU threads, shared machine, \
             best-of timings)"
        ),
        "psdr labels: spp/sppe(k)/sppse; Mitsuba labels: spp. Bars: ± 1 sd over seeds. Dashed: truth's relative \
         standard error.",
        &charts,
        2,
        &SERIES.map(|(_, colour, name)| (name, colour)),
    )
}
