//! The README's main command on the shipped example at a larger photo size (the benchmark: 320x240,
//! default settings, 2 CPU cores, within 10 minutes): `examples/fit/truth.json` rendered by psdr at that size
//! (64 spp, its own path length) with its depth, instance masks (instance id = the truth object's index + 1, as
//! `examples/fit/target.labels.json` numbers them) and fov, then `psdr run scripts/room.rhai --db
//! examples/models --set truth=...` at the script's defaults. Prints and writes `results/example.csv`: the
//! size, each stage's seconds, the total, and the evaluation's main errors.
//!
//! `cargo run -p psdr-benchmarks --release --bin bench_example [-- WIDTH HEIGHT]` (`BENCH_EXAMPLE_KEEP=1` keeps
//! the run's folder and prints it).

use psdr::backend::CpuBackend;
use psdr::render::{render_cpu, SceneData};
use psdr::scene::load_scene;
use psdr::script::{run_script, RunOptions, ScriptRun};
use std::path::Path;

fn main() -> anyhow::Result<()> {
    let size: Vec<u32> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let (w, h) = (size.first().copied().unwrap_or(320), size.get(1).copied().unwrap_or(240));
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let example = root.join("examples/fit");
    let mut truth = load_scene(&example.join("truth.json"))?;
    (truth.camera.width, truth.camera.height) = (w, h);
    truth.settings.spp = 64;
    let f = render_cpu(&SceneData::build(&truth)?, &truth.settings, &|_, _| {});
    let labels: serde_json::Map<String, serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(example.join("target.labels.json"))?)?;
    let masks: Vec<u16> = f
        .object_id
        .iter()
        .map(|&o| {
            let id = o.wrapping_add(1) as u16;
            if labels.contains_key(&id.to_string()) {
                id
            } else {
                0
            }
        })
        .collect();
    let shown: serde_json::Map<String, serde_json::Value> =
        labels.into_iter().filter(|(k, _)| k.parse::<u16>().is_ok_and(|id| masks.contains(&id))).collect();
    let dir = std::env::temp_dir().join(format!("psdr-bench-example-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    psdr::output::write_png_srgb(&dir.join("photo.png"), w, h, &f.radiance)?;
    psdr::output::write_exr_channels(&dir.join("photo.depth.exr"), w, h, &[("Z".into(), f.depth.clone())])?;
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, masks)
        .ok_or_else(|| anyhow::anyhow!("mask size"))?
        .save(dir.join("photo.masks.png"))?;
    std::fs::write(dir.join("photo.labels.json"), serde_json::to_string(&shown)?)?;
    std::fs::write(dir.join("photo.camera.json"), format!("{{\"fov_y_deg\": {}}}", truth.camera.fov_y_deg))?;
    let out = dir.join("out");
    run_script(
        ScriptRun {
            script: root.join("scripts/room.rhai"),
            photo: dir.join("photo.png"),
            out: out.clone(),
            sets: vec![format!("truth={}", example.join("truth.json").display())],
            options: RunOptions { quiet: true, db: Some(root.join("examples/models")), ..Default::default() },
            command: "bench_example".into(),
        },
        Box::new(CpuBackend),
    )?;
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("result.json"))?)?;
    let e = &r["recorded"]["evaluation"];
    let num = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let stage = |name: &str| {
        r["stages"]
            .as_array()
            .and_then(|s| s.iter().find(|x| x["name"] == name))
            .map_or(f64::NAN, |x| num(&x["seconds"]))
    };
    let o = &e["objects"][0];
    let csv = format!(
        "width,height,s_room,s_objects,s_lights,s_materials,s_total,cabinet_centre_err_pct,cabinet_yaw_err_deg,\
         same_model,image_rmse_1_8_pct,ssim,albedo_worst_err_pct\n\
         {w},{h},{:.1},{:.1},{:.1},{:.1},{:.1},{:.3},{:.2},{},{:.2},{:.3},{:.1}\n",
        stage("room"),
        stage("objects"),
        stage("lights"),
        stage("materials"),
        num(&r["total_seconds"]),
        num(&o["centre_error_rel"]) * 100.0,
        num(&o["yaw_error_deg"]),
        o["same_model"],
        num(&e["image"]["rmse_rel_1_8"]) * 100.0,
        num(&e["image"]["ssim"]),
        num(&e["albedo"]["worst_error_rel"]) * 100.0,
    );
    print!("{csv}");
    std::fs::write(Path::new(env!("CARGO_MANIFEST_DIR")).join("results/example.csv"), &csv)?;
    if std::env::var_os("BENCH_EXAMPLE_KEEP").is_some() {
        println!("kept {}", dir.display());
    } else {
        std::fs::remove_dir_all(&dir).ok();
    }
    Ok(())
}
