//! Forward and backward time of every library material at 256 and 512, written
//! to benchmarks/results/materials.csv (median of repeated runs, release build):
//! `cargo run -p psdr-benchmarks --release --bin bench_materials [-- OUT.csv]`; also writes OUT.svg, a bar chart
//! of forward and backward time per material at 512.

use psdr_materials::{library, Evaluator, RenderGrads};
use std::time::Instant;

fn median_ms(mut f: impl FnMut(), reps: usize) -> f64 {
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(|a, b| a.partial_cmp(b).unwrap());
    t[reps / 2]
}

/// Forward and backward time of every library material (CSV + SVG under benchmarks/results).
#[derive(clap::Parser)]
struct Args {
    /// Output CSV (the SVG goes next to it).
    #[arg(default_value_os_t = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("results/materials.csv"))]
    out: std::path::PathBuf,
}

fn main() -> anyhow::Result<()> {
    let out = <Args as clap::Parser>::parse().out;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut csv = String::from("material,size,threads,float_params,nodes_forward_ms,forward_ms,backward_ms\n");
    let mut sums = [(0.0, 0.0, 0usize); 2];
    let mut bars = vec![];
    for name in library::names() {
        let graph = library::load(name).expect("listed")?;
        let params = graph.default_params();
        for (si, size) in [256usize, 512].into_iter().enumerate() {
            let mut ev = Evaluator::new(graph.clone(), size);
            ev.forward(&params); // warm-up
            let reps = if size == 256 { 5 } else { 3 };
            let eval_ms = median_ms(|| ev.evaluate(&params), reps);
            let fwd = median_ms(
                || {
                    ev.forward(&params);
                },
                reps,
            );
            let n2 = size * size;
            let ga: Vec<f32> = (0..n2 * 3).map(|i| ((i * 7919 % 101) as f32 - 50.0) * 1e-3).collect();
            let gr: Vec<f32> = ga[..n2].to_vec();
            let has_h = ev.maps().height.is_some();
            let grads = RenderGrads {
                albedo_linear: Some(&ga),
                roughness: Some(&gr),
                normal: Some(&ga),
                height: has_h.then_some(&gr[..]),
            };
            let mut grad = vec![0.0; graph.num_floats()];
            let bwd = median_ms(|| ev.backward(&grads, &mut grad), reps);
            println!("{name:<22} {size:>4}  forward {fwd:8.2} ms  backward {bwd:8.2} ms");
            csv += &format!("{name},{size},{threads},{},{eval_ms:.3},{fwd:.3},{bwd:.3}\n", graph.num_floats());
            if size == 512 {
                bars.push((name.to_string(), fwd, bwd));
            }
            sums[si].0 += fwd;
            sums[si].1 += bwd;
            sums[si].2 += 1;
        }
    }
    for (si, size) in [256, 512].into_iter().enumerate() {
        let (f, b, n) = sums[si];
        println!("mean at {size}: forward {:.2} ms, backward {:.2} ms over {n} materials", f / n as f64, b / n as f64);
    }
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(&out, csv)?;
    let svg = out.with_extension("svg");
    std::fs::write(&svg, bar_chart(&bars, threads))?;
    println!("wrote {} and {}", out.display(), svg.display());
    Ok(())
}

/// Horizontal bars, one row per material: forward and backward milliseconds at 512.
fn bar_chart(rows: &[(String, f64, f64)], threads: usize) -> String {
    psdr::report::chart::BarChart {
        title: format!("Material graphs at 512x512: forward and backward ms, {threads} threads"),
        unit: "ms".into(),
        series: vec!["forward".into(), "backward".into()],
        rows: rows.iter().map(|(n, f, b)| (n.clone(), vec![*f, *b])).collect(),
        stacked: false,
    }
    .svg()
}
