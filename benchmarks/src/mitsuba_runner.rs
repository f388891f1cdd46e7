//! Runs Mitsuba 3 (LLVM) on psdr's export of a scene through `mitsuba_render.py` (shared by the render benches).

use anyhow::{bail, Context};
use psdr::scene::Scene;
use std::path::{Path, PathBuf};
use std::process::Command;

/// One spp of a `mitsuba_render.py` run: the first render of the process and the best warm render.
pub struct MitsubaRun {
    pub spp: u32,
    pub cold_s: f64,
    pub warm_s: Option<f64>,
    pub image: PathBuf,
}

/// Exports `scene` at w x h (its own render settings: max depth, Russian roulette) into `dir` and renders it
/// with mitsuba_render.py at each spp, `reps` warm renders each.
pub fn run_mitsuba(
    scene: &Scene,
    w: u32,
    h: u32,
    spps: &[u32],
    reps: usize,
    dir: &Path,
) -> anyhow::Result<Vec<MitsubaRun>> {
    let bench = Path::new(env!("CARGO_MANIFEST_DIR"));
    let python = bench.join(".venv/bin/python");
    if !python.exists() {
        bail!("{} not found: run benchmarks/setup_mitsuba.sh first (or pass --no-mitsuba)", python.display());
    }
    let mut s = scene.clone();
    (s.camera.width, s.camera.height) = (w, h);
    let xml = psdr::export::mitsuba::export_mitsuba(&s, dir)?;
    let llvm =
        std::env::var("DRJIT_LIBLLVM_PATH").unwrap_or_else(|_| "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1".into());
    let out = Command::new(&python)
        .arg(bench.join("mitsuba_render.py"))
        .arg(&xml)
        .arg("--spp")
        .args(spps.iter().map(|s| s.to_string()))
        .args(["--reps", &reps.to_string(), "--out-dir"])
        .arg(dir)
        .env("DRJIT_LIBLLVM_PATH", llvm)
        .output()
        .context("running mitsuba_render.py")?;
    if !out.status.success() {
        bail!("mitsuba_render.py failed:\n{}", String::from_utf8_lossy(&out.stderr));
    }
    let mut runs = vec![];
    for line in String::from_utf8_lossy(&out.stdout).lines().filter(|l| l.starts_with('{')) {
        let v: serde_json::Value = serde_json::from_str(line)?;
        runs.push(MitsubaRun {
            spp: v["spp"].as_u64().context("spp")? as u32,
            cold_s: v["cold_s"].as_f64().context("cold_s")?,
            warm_s: v["warm_s"].as_f64(),
            image: PathBuf::from(v["image"].as_str().context("image")?),
        });
    }
    Ok(runs)
}
