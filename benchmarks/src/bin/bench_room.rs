//! The room stage's wall time and fit error (`scripts/room.rhai`): the fit example's room (4 x 5 x 2.6 m,
//! truth.json) rendered at 256x192 and 512x384 with its observation files (depth, instance masks, labels,
//! fov), then the script run with 0, 10, 20 and 40 optimisation iterations. Writes
//! benchmarks/results/room.csv and room.svg (error against time):
//! `cargo run -p psdr-benchmarks --release --bin bench_room`.

use psdr::backend::CpuBackend;
use psdr::render::{render_cpu, SceneData};
use psdr::report::chart::{Point, Series, XyChart};
use psdr::scene::load_scene;
use psdr::script::{run_script, RunOptions, ScriptRun};
use std::path::{Path, PathBuf};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// Renders the fit example's truth at w x h and writes room.png with its observation files into `dir`.
fn observations(dir: &Path, w: u32, h: u32) -> anyhow::Result<PathBuf> {
    let mut s = load_scene(&repo("examples/fit/truth.json"))?;
    (s.camera.width, s.camera.height, s.settings.spp) = (w, h, 32);
    let f = render_cpu(&SceneData::build(&s)?, &s.settings, &|_, _| {});
    let photo = dir.join("room.png");
    psdr::output::write_png_srgb(&photo, w, h, &f.radiance)?;
    psdr::output::write_exr_channels(&dir.join("room.depth.exr"), w, h, &[("Z".into(), f.depth.clone())])?;
    let ids: Vec<u16> = f.object_id.iter().map(|&o| if o == u32::MAX { 0 } else { o as u16 + 1 }).collect();
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, ids)
        .ok_or_else(|| anyhow::anyhow!("mask size"))?
        .save(dir.join("room.masks.png"))?;
    let class = |n: &str| if n.ends_with("wall") { "wall".to_string() } else { n.to_string() };
    let labels: serde_json::Map<String, serde_json::Value> = s
        .objects
        .iter()
        .enumerate()
        .filter(|(o, _)| f.object_id.contains(&(*o as u32)))
        .map(|(o, obj)| ((o + 1).to_string(), class(&obj.name).into()))
        .collect();
    std::fs::write(dir.join("room.labels.json"), serde_json::to_string(&labels)?)?;
    std::fs::write(dir.join("room.camera.json"), format!("{{\"fov_y_deg\": {}}}", s.camera.fov_y_deg))?;
    Ok(photo)
}

fn main() -> anyhow::Result<()> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let dir = std::env::temp_dir().join(format!("psdr-bench-room-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let mut csv = String::from(
        "width,height,threads,iterations,stage_s,s_per_iteration,depth_m,height_m,depth_err_pct,height_err_pct\n",
    );
    let mut chart = XyChart::new(
        &format!("Room stage on the fit example: box error vs wall time ({threads} threads)"),
        "seconds (room stage: initialisation + optimisation)",
        "error of the measured box extents (%)",
    );
    (chart.log_y, chart.width, chart.height) = (true, 640.0, 360.0);
    chart.caption = "labels: iterations; truth 4.0 m deep (wall to wall in view), 2.6 m high".into();
    for (w, h) in [(256u32, 192u32), (512, 384)] {
        let photo = observations(&dir, w, h)?;
        let mut pts = vec![];
        for iters in [0usize, 10, 20, 40] {
            let out = dir.join(format!("out_{w}_{iters}"));
            run_script(
                ScriptRun {
                    script: repo("scripts/room.rhai"),
                    photo: photo.clone(),
                    out: out.clone(),
                    sets: vec![format!("room_iters={iters}"), "object_iters=0".into()],
                    options: RunOptions { quiet: true, preview_spp: 1, ..Default::default() },
                    command: "bench_room".into(),
                },
                Box::new(CpuBackend),
            )?;
            let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("result.json"))?)?;
            let stage_s = r["stages"][0]["seconds"].as_f64().unwrap_or(f64::NAN);
            let opt_s = r["stages"][0]["optimizations"][0]["seconds"].as_f64().unwrap_or(0.0);
            let room = &r["recorded"]["room"];
            let (d, hh) = (room["depth"].as_f64().unwrap_or(f64::NAN), room["height"].as_f64().unwrap_or(f64::NAN));
            let (de, he) = ((d - 4.0).abs() / 4.0 * 100.0, (hh - 2.6).abs() / 2.6 * 100.0);
            let per = if iters > 0 { opt_s / iters as f64 } else { 0.0 };
            println!(
                "{w}x{h} {iters:>3} iterations: stage {stage_s:6.2} s ({per:.3} s/iteration), depth {d:.4} m ({de:.3} %), height {hh:.4} m ({he:.3} %)"
            );
            csv += &format!("{w},{h},{threads},{iters},{stage_s:.3},{per:.4},{d:.5},{hh:.5},{de:.4},{he:.4}\n");
            pts.push(Point::labelled(stage_s, de.max(he).max(1e-3), iters.to_string()));
        }
        chart.series.push(Series::marked(format!("{w}x{h}"), pts));
    }
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/room.csv");
    std::fs::create_dir_all(out.parent().unwrap())?;
    std::fs::write(&out, &csv)?;
    std::fs::write(out.with_extension("svg"), chart.svg() + "\n")?;
    println!("wrote {} and {}", out.display(), out.with_extension("svg").display());
    std::fs::remove_dir_all(&dir).ok();
    Ok(())
}
