//! `psdr grad SCENE --param PATH [--loss mean|l2-to TARGET.exr] --fd STEP [--replicas K] [--component I]`

use crate::backend::{create_backend, BackendKind};
use crate::grad::{central_difference, FdOptions, ImageLoss, Output, ParamPath};
use crate::scene::load_scene;
use anyhow::bail;
use clap::Args;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args)]
pub struct GradArgs {
    /// Scene file (JSON).
    scene: PathBuf,
    /// Parameter path, e.g. object/table/translation, material/walnut/albedo, light/ceiling_light/radiance.
    #[arg(long)]
    param: ParamPath,
    /// `mean` (mean radiance) or `l2-to` (mean squared difference to --target).
    #[arg(long, default_value = "mean")]
    loss: String,
    /// Target radiance EXR for `--loss l2-to` (same resolution as the scene).
    #[arg(long)]
    target: Option<PathBuf>,
    /// Central finite differences with this step (in the parameter's units).
    #[arg(long)]
    fd: Option<f32>,
    /// Independent seed pairs for the finite differences (standard error needs at least 2).
    #[arg(long, default_value_t = 4)]
    replicas: u32,
    /// Only these components of the parameter (comma separated); default all.
    #[arg(long, value_delimiter = ',')]
    component: Vec<usize>,
    /// Samples per pixel (overrides the scene's render.spp).
    #[arg(long)]
    spp: Option<u32>,
    #[arg(long, default_value = "cpu")]
    backend: BackendKind,
}

pub fn run(a: GradArgs) -> anyhow::Result<()> {
    let mut scene = load_scene(&a.scene)?;
    if let Some(spp) = a.spp {
        scene.settings.spp = spp;
    }
    let loss = match (a.loss.as_str(), &a.target) {
        ("mean", None) => ImageLoss::Mean(Output::Radiance),
        ("l2-to", Some(t)) => ImageLoss::l2_to_exr(t)?,
        ("l2-to", None) => bail!("--loss l2-to needs --target TARGET.exr"),
        ("mean", Some(_)) => bail!("--target is only used with --loss l2-to"),
        (other, _) => bail!("unknown loss '{other}' (mean, l2-to)"),
    };
    let value = a.param.get(&scene)?;
    println!("{} = {:?}", a.param, value);
    let Some(step) = a.fd else {
        bail!(
            "analytic (AD) gradients are not implemented yet; pass --fd STEP for central finite differences \
             with standard errors"
        );
    };
    let mut backend = create_backend(a.backend)?;
    let t = Instant::now();
    let opts = FdOptions { step, replicas: a.replicas, components: a.component };
    let fd = central_difference(&scene, &a.param, &loss, &opts, backend.as_mut())?;
    for ((c, m), se) in fd.components.iter().zip(&fd.mean).zip(&fd.std_err) {
        println!("d loss / d {}[{c}]  FD {m:+.6e}  ± {se:.2e} (1 s.e.)", a.param);
    }
    println!(
        "{} renders of {}x{} at {} spp on {} in {:.2} s (step {step}, {} replicas)",
        fd.renders,
        scene.camera.width,
        scene.camera.height,
        scene.settings.spp,
        backend.name(),
        t.elapsed().as_secs_f64(),
        fd.replicas
    );
    Ok(())
}
