//! Where the primal render time goes, path depth by path depth, psdr's CPU renderer against Mitsuba 3 LLVM:
//! `cargo run -p psdr-benchmarks --release --bin bench_depth [-- --scene S --reps N --rounds N --spp N
//! --width W --height H]` (Mitsuba needs `benchmarks/setup_mitsuba.sh`).
//!
//! A scene (default: the example room) is rendered with max depth 1 (camera rays and the emitters they see),
//! 2 (plus direct lighting: one shadow ray and one BSDF-sampled ray per hit), 3, 4 and 5 (Russian roulette as
//! the scene file says). Each depth is timed for both renderers in turn (psdr: a warm-up then the best of N;
//! Mitsuba: `mitsuba_render.py`'s best of N warm renders), and the whole sweep is repeated `rounds` times, each
//! time keeping the best: the machine's speed drifts by 10-25 % over minutes, and the difference between
//! consecutive depths (the cost of one more path vertex) is a difference of two such times. The ratios say
//! which part of the path tracer the gap to Mitsuba is in.
//! Both render the same light transport: the image-mean ratio Mitsuba / psdr per depth is reported next to the
//! times (at 16 spp and 512x384 its noise is about 0.1 %).
//!
//! Writes benchmarks/results/render_depth_NAME.csv and .svg (seconds against max depth), NAME the scene file's
//! folder (`room`, `cube_room`).

use psdr::output::read_exr_rgb;
use psdr::render::{render_cpu, Frame, SceneData};
use psdr::scene::{load_scene, Scene};
use psdr_benchmarks::mitsuba_runner::run_mitsuba;
use std::path::Path;
use std::time::Instant;

const DEPTHS: [u32; 5] = [1, 2, 3, 4, 5];

#[derive(clap::Parser)]
struct Args {
    /// Scene file, relative to the repository root.
    #[arg(long, default_value = "examples/room/scene.json")]
    scene: String,
    /// Timed repetitions per depth, renderer and round (best of).
    #[arg(long, default_value_t = 3)]
    reps: u32,
    /// Sweeps over all depths (best of; each round times both renderers at every depth).
    #[arg(long, default_value_t = 3)]
    rounds: u32,
    #[arg(long, default_value_t = 16)]
    spp: u32,
    #[arg(long, default_value_t = 512)]
    width: u32,
    #[arg(long, default_value_t = 384)]
    height: u32,
}

struct Row {
    max_depth: u32,
    psdr_s: f64,
    mitsuba_s: f64,
    psdr_rays: u64,
    /// Mean over pixels and channels, Mitsuba's image over psdr's, formatted ("" when psdr's image is black,
    /// as at depth 1 when no emitter is in view).
    mean_ratio: String,
}

fn render(scene: &Scene) -> anyhow::Result<(Frame, f64)> {
    let d = SceneData::build(scene)?;
    let t = Instant::now();
    let f = render_cpu(&d, &scene.settings, &|_, _| {});
    Ok((f, t.elapsed().as_secs_f64()))
}

fn mean(v: &[f32]) -> f64 {
    v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
}

fn main() -> anyhow::Result<()> {
    let a = <Args as clap::Parser>::parse();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf();
    let scene_path = root.join(&a.scene);
    let name = scene_path.parent().and_then(|p| p.file_name()).map_or("scene".into(), |n| n.to_string_lossy());
    let mut scene = load_scene(&scene_path)?;
    (scene.camera.width, scene.camera.height, scene.settings.spp) = (a.width, a.height, a.spp);
    let work = root.join("out/bench_depth").join(&*name);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());

    let mut rows: Vec<Row> = vec![];
    for round in 0..a.rounds {
        for (i, &max_depth) in DEPTHS.iter().enumerate() {
            let mut s = scene.clone();
            s.settings.max_depth = max_depth;
            let (frame, mut best) = render(&s)?;
            for _ in 0..a.reps {
                best = best.min(render(&s)?.1);
            }
            let dir = work.join(format!("depth{max_depth}"));
            let runs = run_mitsuba(&s, a.width, a.height, &[a.spp], a.reps as usize, &dir)?;
            let run = &runs[0];
            let mitsuba_s = run.warm_s.unwrap_or(run.cold_s);
            println!("round {round} max depth {max_depth}: psdr {best:.3} s, Mitsuba {mitsuba_s:.3} s");
            if round == 0 {
                let (_, _, img) = read_exr_rgb(&run.image)?;
                let psdr_mean = mean(&frame.radiance);
                let mean_ratio = if psdr_mean > 0.0 { format!("{:.5}", mean(&img) / psdr_mean) } else { String::new() };
                rows.push(Row { max_depth, psdr_s: best, mitsuba_s, psdr_rays: frame.rays, mean_ratio });
            } else {
                rows[i].psdr_s = rows[i].psdr_s.min(best);
                rows[i].mitsuba_s = rows[i].mitsuba_s.min(mitsuba_s);
            }
        }
    }
    for r in &rows {
        println!(
            "max depth {}: psdr {:.3} s ({:.2} rays/sample), Mitsuba {:.3} s, psdr / Mitsuba time {:.2}, \
             image mean Mitsuba / psdr {}",
            r.max_depth,
            r.psdr_s,
            r.psdr_rays as f64 / (a.width * a.height * a.spp) as f64,
            r.mitsuba_s,
            r.psdr_s / r.mitsuba_s,
            r.mean_ratio
        );
    }

    let mut csv = String::from(
        "max_depth,width,height,spp,threads,psdr_seconds,mitsuba_seconds,psdr_over_mitsuba,psdr_rays_per_sample,\
         psdr_level_seconds,mitsuba_level_seconds,level_psdr_over_mitsuba,image_mean_mitsuba_over_psdr\n",
    );
    for (i, r) in rows.iter().enumerate() {
        // The cost of this depth's vertex: the time added over the previous depth (all of it at depth 1).
        let (pl, ml) = match i {
            0 => (r.psdr_s, r.mitsuba_s),
            _ => (r.psdr_s - rows[i - 1].psdr_s, r.mitsuba_s - rows[i - 1].mitsuba_s),
        };
        csv += &format!(
            "{},{},{},{},{threads},{:.4},{:.4},{:.3},{:.3},{pl:.4},{ml:.4},{:.3},{}\n",
            r.max_depth,
            a.width,
            a.height,
            a.spp,
            r.psdr_s,
            r.mitsuba_s,
            r.psdr_s / r.mitsuba_s,
            r.psdr_rays as f64 / (a.width * a.height * a.spp) as f64,
            pl / ml,
            r.mean_ratio
        );
    }
    print!("{csv}");
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("results/render_depth_{name}.csv"));
    std::fs::create_dir_all(out.parent().unwrap())?;
    std::fs::write(&out, &csv)?;
    std::fs::write(out.with_extension("svg"), chart(&rows, &a, &name, threads))?;
    println!("wrote {} and {}", out.display(), out.with_extension("svg").display());
    Ok(())
}

/// Seconds (linear) against max depth, one line per renderer, each psdr point labelled with psdr / Mitsuba.
fn chart(rows: &[Row], a: &Args, name: &str, threads: usize) -> String {
    use psdr::report::chart::{Point, Series, XyChart};
    let mut c = XyChart::new(
        &format!("{name} {}x{}, {} spp: render time by max path depth ({threads} threads)", a.width, a.height, a.spp),
        "max depth (1: emitters seen directly, 2: + direct light, ...)",
        "seconds",
    );
    c.caption = "labels: psdr time / Mitsuba time".into();
    (c.width, c.height, c.legend_right) = (700.0, 410.0, true);
    let psdr =
        rows.iter().map(|r| Point::labelled(r.max_depth as f64, r.psdr_s, format!("{:.2}x", r.psdr_s / r.mitsuba_s)));
    c.series.push(Series::marked("psdr_cpu", psdr.collect()).color("#3b6fb6"));
    let mitsuba = rows.iter().map(|r| Point::new(r.max_depth as f64, r.mitsuba_s));
    c.series.push(Series::marked("mitsuba_llvm", mitsuba.collect()).color("#e07b39"));
    c.svg() + "\n"
}
