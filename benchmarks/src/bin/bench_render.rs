//! Primal render speed against image error, psdr's CPU renderer vs Mitsuba 3 LLVM on the exported scene:
//! `cargo run -p psdr-benchmarks --release --bin bench_render [-- --reps N --ref-spp N --reuse-reference --no-mitsuba --quick]`
//! (Mitsuba needs `benchmarks/setup_mitsuba.sh`; DRJIT_LIBLLVM_PATH defaults to Debian's libLLVM 19).
//!
//! For the example room at 256x192 and 512x384, 16 and 64 spp:
//! - psdr: a warm-up render (its time is the "cold" column), then the best of N timed renders; Mrays/s from
//!   the rays the renderer counts (camera, bounce and shadow rays).
//! - Mitsuba: the scene is exported with `psdr export` at that size; `mitsuba_render.py` times the first render
//!   of the process (cold: tracing + JIT compile or kernel-cache load) and the best of N warm renders.
//! - Error: RMSE (and relative L1) of each image against psdr at `ref-spp` spp and 512x384 with another seed,
//!   box-downsampled 2x2 for 256x192. Mitsuba's error therefore includes any model mismatch of the export.
//! - Agreement: Mitsuba at `ref-spp` spp and 256x192 against the same reference, next to an independent psdr
//!   render at the same spp (its difference is the noise level).
//!
//! Writes benchmarks/results/render.csv and render.svg (seconds, log, against RMSE, log).

use psdr::output::{read_exr_rgb, write_exr_channels};
use psdr::render::{render_cpu, Frame, SceneData};
use psdr::scene::{load_scene, Scene};
use psdr_benchmarks::mitsuba_runner::run_mitsuba;
use std::path::Path;
use std::time::Instant;

const SIZES: [(u32, u32); 2] = [(256, 192), (512, 384)];
const SPPS: [u32; 2] = [16, 64];
const REF_SEED: u32 = 1000;

struct Row {
    renderer: &'static str,
    width: u32,
    height: u32,
    spp: u32,
    cold_s: f64,
    seconds: f64,
    mrays: Option<f64>,
    rmse: f64,
    rel_l1: f64,
}

fn render(scene: &Scene, w: u32, h: u32, spp: u32, seed: u32) -> anyhow::Result<(Frame, f64)> {
    let mut s = scene.clone();
    (s.camera.width, s.camera.height, s.settings.spp, s.settings.seed) = (w, h, spp, seed);
    let d = SceneData::build(&s)?;
    let t = Instant::now();
    let f = render_cpu(&d, &s.settings, &|_, _| {});
    Ok((f, t.elapsed().as_secs_f64()))
}

/// 2x2 box average of interleaved RGB (a box-filtered render at half size, in expectation).
fn downsample(rgb: &[f32], w: usize, h: usize) -> Vec<f32> {
    let (w2, h2) = (w / 2, h / 2);
    let mut out = vec![0.0; w2 * h2 * 3];
    for y in 0..h2 {
        for x in 0..w2 {
            for c in 0..3 {
                let at = |dx: usize, dy: usize| rgb[((2 * y + dy) * w + 2 * x + dx) * 3 + c];
                out[(y * w2 + x) * 3 + c] = 0.25 * (at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1));
            }
        }
    }
    out
}

fn rmse(a: &[f32], r: &[f32]) -> f64 {
    (a.iter().zip(r).map(|(&x, &y)| ((x - y) as f64).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
}

/// Mean relative difference: sum |a - r| / sum |r| over all channel values.
fn rel_l1(a: &[f32], r: &[f32]) -> f64 {
    a.iter().zip(r).map(|(&x, &y)| (x - y).abs() as f64).sum::<f64>() / r.iter().map(|&y| y.abs() as f64).sum::<f64>()
}

fn channel_means(a: &[f32]) -> [f64; 3] {
    let n = (a.len() / 3) as f64;
    [0, 1, 2].map(|c| a.iter().skip(c).step_by(3).map(|&v| v as f64).sum::<f64>() / n)
}

/// Primal render time against image error, psdr CPU against Mitsuba 3 LLVM (CSV + SVG under benchmarks/results).
#[derive(clap::Parser)]
struct Args {
    /// A 64 spp reference and one repetition.
    #[arg(long)]
    quick: bool,
    /// Timed repetitions per cell (best of; default 3, 1 with --quick).
    #[arg(long)]
    reps: Option<u32>,
    /// Samples per pixel of the reference (default 1024, 64 with --quick).
    #[arg(long)]
    ref_spp: Option<u32>,
    /// Reuse the reference kept in out/bench_render (only valid for an unchanged renderer).
    #[arg(long)]
    reuse_reference: bool,
    /// Skip Mitsuba.
    #[arg(long)]
    no_mitsuba: bool,
}

fn main() -> anyhow::Result<()> {
    let args = <Args as clap::Parser>::parse();
    let quick = args.quick;
    let reps = args.reps.unwrap_or(if quick { 1 } else { 3 }) as usize;
    let ref_spp = args.ref_spp.unwrap_or(if quick { 64 } else { 1024 });
    let with_mitsuba = !args.no_mitsuba;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf();
    let scene = load_scene(&root.join("examples/room/scene.json"))?;
    let work = root.join("out/bench_render");
    std::fs::create_dir_all(&work)?;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());

    // Reference: psdr at 512x384, ref_spp, another seed; 256x192 is its 2x2 box average.
    let (wr, hr) = SIZES[1];
    // Kept in out/bench_render; `--reuse-reference` skips re-rendering it (only valid for an unchanged renderer).
    let ref_path = work.join(format!("reference_{wr}x{hr}_{ref_spp}spp.exr"));
    let reference = if args.reuse_reference && ref_path.exists() {
        read_exr_rgb(&ref_path)?.2
    } else {
        let (frame, ref_s) = render(&scene, wr, hr, ref_spp, REF_SEED)?;
        println!("reference {wr}x{hr} {ref_spp} spp: {ref_s:.1} s");
        let channel = |c: usize| frame.radiance.iter().skip(c).step_by(3).copied().collect();
        let channels = [("R", 0), ("G", 1), ("B", 2)].map(|(n, c)| (n.to_string(), channel(c)));
        write_exr_channels(&ref_path, wr, hr, &channels)?;
        frame.radiance
    };
    let ref_small = downsample(&reference, wr as usize, hr as usize);
    let reference_for = |w: u32| if w == wr { &reference[..] } else { &ref_small[..] };

    let mut rows = vec![];
    for &(w, h) in &SIZES {
        for &spp in &SPPS {
            let (frame, cold) = render(&scene, w, h, spp, 0)?;
            let best =
                (0..reps).map(|_| render(&scene, w, h, spp, 0).map(|r| r.1)).collect::<anyhow::Result<Vec<_>>>()?;
            let secs = best.into_iter().fold(cold, f64::min);
            let r = reference_for(w);
            rows.push(Row {
                renderer: "psdr_cpu",
                width: w,
                height: h,
                spp,
                cold_s: cold,
                seconds: secs,
                mrays: Some(frame.rays as f64 / secs / 1e6),
                rmse: rmse(&frame.radiance, r),
                rel_l1: rel_l1(&frame.radiance, r),
            });
        }
        if with_mitsuba {
            for run in run_mitsuba(&scene, w, h, &SPPS, reps, &work.join(format!("mitsuba_{w}x{h}")))? {
                let (_, _, img) = read_exr_rgb(&run.image)?;
                let r = reference_for(w);
                rows.push(Row {
                    renderer: "mitsuba_llvm",
                    width: w,
                    height: h,
                    spp: run.spp,
                    cold_s: run.cold_s,
                    seconds: run.warm_s.unwrap_or(run.cold_s),
                    mrays: None,
                    rmse: rmse(&img, r),
                    rel_l1: rel_l1(&img, r),
                });
            }
        }
    }

    let mut csv = String::from(
        "renderer,width,height,spp,threads,cold_seconds,seconds,mrays_per_s,rmse_vs_reference,rel_l1_vs_reference\n",
    );
    for r in &rows {
        let mrays = r.mrays.map_or(String::new(), |m| format!("{m:.2}"));
        csv += &format!(
            "{},{},{},{},{threads},{:.4},{:.4},{mrays},{:.5},{:.5}\n",
            r.renderer, r.width, r.height, r.spp, r.cold_s, r.seconds, r.rmse, r.rel_l1
        );
        println!(
            "{:<13} {:>3}x{:<3} {:>3} spp  cold {:7.3} s  best {:7.3} s  {:>6} Mrays/s  rmse {:.5}  rel_l1 {:.4}",
            r.renderer, r.width, r.height, r.spp, r.cold_s, r.seconds, mrays, r.rmse, r.rel_l1
        );
    }
    for &(w, h) in &SIZES {
        for &spp in &SPPS {
            let find = |name: &str| rows.iter().find(|r| r.renderer == name && r.width == w && r.spp == spp);
            if let (Some(a), Some(b)) = (find("psdr_cpu"), find("mitsuba_llvm")) {
                println!("{w}x{h} {spp} spp: psdr is {:.2}x as fast as Mitsuba (warm)", b.seconds / a.seconds);
            }
        }
    }

    // Agreement of the two renderers' converged images (256x192), next to psdr's own noise at that spp.
    if with_mitsuba {
        let (w, h) = SIZES[0];
        let run = run_mitsuba(&scene, w, h, &[ref_spp], 0, &work.join(format!("mitsuba_{w}x{h}_agree")))?;
        let (_, _, mts) = read_exr_rgb(&run[0].image)?;
        let (ours, _) = render(&scene, w, h, ref_spp, REF_SEED + 1)?;
        let r = &ref_small;
        let fmt = |m: [f64; 3]| format!("({:.5}, {:.5}, {:.5})", m[0], m[1], m[2]);
        let (cm, co, cr) = (channel_means(&mts), channel_means(&ours.radiance), channel_means(r));
        println!("agreement at {w}x{h}, {ref_spp} spp, against the reference:");
        println!("  mitsuba: rel_l1 {:.4}  channel means {}", rel_l1(&mts, r), fmt(cm));
        println!("  psdr:    rel_l1 {:.4}  channel means {}  (noise level)", rel_l1(&ours.radiance, r), fmt(co));
        println!("  reference channel means {}", fmt(cr));
        let rel = |m: [f64; 3]| [0, 1, 2].map(|c| m[c] / cr[c] - 1.0);
        println!("  channel-mean difference: mitsuba {}  psdr {}", fmt(rel(cm)), fmt(rel(co)));
    }

    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/render.csv");
    std::fs::create_dir_all(out.parent().unwrap())?;
    std::fs::write(&out, &csv)?;
    std::fs::write(out.with_extension("svg"), chart(&rows, threads))?;
    println!("wrote {} and {}", out.display(), out.with_extension("svg").display());
    Ok(())
}

/// Log-log scatter of seconds (x) against RMSE (y); one line per renderer and size, points labelled by spp.
fn chart(rows: &[Row], threads: usize) -> String {
    use psdr::report::chart::{Line, Point, Series, XyChart};
    let mut c = XyChart::new(
        &format!("Example room: render time vs RMSE against a converged reference ({threads} threads)"),
        "seconds per frame (warm, best of N)",
        "RMSE vs reference",
    );
    c.caption = "labels: spp".into();
    (c.log_x, c.log_y, c.width, c.height, c.legend_right) = (true, true, 780.0, 430.0, true);
    for (renderer, colour) in [("psdr_cpu", "#3b6fb6"), ("mitsuba_llvm", "#e07b39")] {
        for (si, &(w, h)) in SIZES.iter().enumerate() {
            let pts: Vec<Point> = rows
                .iter()
                .filter(|r| r.renderer == renderer && r.width == w)
                .map(|r| Point::labelled(r.seconds, r.rmse, r.spp.to_string()))
                .collect();
            if !pts.is_empty() {
                let mut series = Series::marked(format!("{renderer} {w}x{h}"), pts).color(colour);
                series.line = if si == 0 { Line::Solid } else { Line::Dashed };
                c.series.push(series);
            }
        }
    }
    c.svg() + "\n"
}
