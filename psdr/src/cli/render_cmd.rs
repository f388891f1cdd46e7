//! `psdr render SCENE -o OUT.exr [--spp N] [--seed S] [--aov LIST] [--backend cpu|vk] [--device GPU]`

use crate::backend::{create_backend_on, BackendKind};
use crate::output::{check_frame_path, write_frame, Aov};
use crate::render::SceneData;
use crate::scene::load_scene;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args)]
pub struct RenderArgs {
    /// Scene file (JSON).
    scene: PathBuf,
    /// Output image: .exr (radiance + PNG preview + one EXR per AOV) or .png.
    #[arg(short, long)]
    output: PathBuf,
    /// Samples per pixel (overrides the scene's render.spp).
    #[arg(long)]
    spp: Option<u32>,
    /// Random seed (overrides the scene's render.seed).
    #[arg(long)]
    seed: Option<u32>,
    /// Longest path in vertices (overrides render.max_depth).
    #[arg(long)]
    max_depth: Option<u32>,
    /// AOVs to write next to the image, comma separated.
    #[arg(long, value_delimiter = ',')]
    aov: Vec<Aov>,
    /// Render backend.
    #[arg(long, default_value = "cpu", value_parser = super::backend_parser())]
    backend: BackendKind,
    /// GPU to render on (vk backend): a case-insensitive part of its name, e.g. "llvmpipe"; default: the
    /// PSDR_VK_DEVICE environment variable, else the fastest device.
    #[arg(long)]
    device: Option<String>,
    /// Hide the progress bar.
    #[arg(long)]
    quiet: bool,
}

pub fn run(a: RenderArgs) -> anyhow::Result<()> {
    check_frame_path(&a.output)?;
    let mut scene = load_scene(&a.scene)?;
    if let Some(v) = a.spp {
        scene.settings.spp = v;
    }
    if let Some(v) = a.seed {
        scene.settings.seed = v;
    }
    if let Some(v) = a.max_depth {
        scene.settings.max_depth = v;
    }
    let t_build = Instant::now();
    let data = SceneData::build(&scene)?;
    let build_s = t_build.elapsed().as_secs_f64();
    let mut backend = create_backend_on(a.backend, a.device.as_deref())?;
    let bar = if a.quiet { ProgressBar::hidden() } else { ProgressBar::new(scene.camera.height as u64) };
    bar.set_style(ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {pos}/{len}").unwrap());
    let t = Instant::now();
    // Units are the backend's own (rows on the CPU, sample passes on the GPU).
    let frame = backend.render(&data, &scene.settings, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64)
    })?;
    let secs = t.elapsed().as_secs_f64();
    bar.finish_and_clear();
    if !frame.is_finite() {
        anyhow::bail!("the render produced non-finite values; please report this scene");
    }
    let names: Vec<String> = scene.objects.iter().map(|o| o.name.clone()).collect();
    let written = write_frame(&a.output, &frame, &a.aov, &names)?;
    println!(
        "{}x{} {} spp on {}: {:.3} s ({:.2} Mrays/s, {} triangles, BVH {:.3} s) -> {}",
        frame.width,
        frame.height,
        scene.settings.spp,
        backend.name(),
        secs,
        frame.rays as f64 / secs / 1e6,
        scene.triangle_count(),
        build_s,
        written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
    );
    Ok(())
}
