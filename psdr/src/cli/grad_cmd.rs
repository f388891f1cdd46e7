//! `psdr grad SCENE --param PATH [--loss mean|l2-to --target T.exr] [--fd STEP] [--replicas K] [--component I]`:
//! the analytic gradient (reverse mode) and, with --fd, central finite differences, each with a standard error.

use crate::backend::{create_backend, BackendKind};
use crate::grad::{analytic_gradient, central_difference, AdOptions, FdOptions, ImageLoss, Output, ParamPath};
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
    /// Default: every path in the scene's "requires_grad" list.
    #[arg(long)]
    param: Option<ParamPath>,
    /// `mean` (mean radiance) or `l2-to` (mean squared difference to --target).
    #[arg(long, default_value = "mean")]
    loss: String,
    /// What the loss reads: radiance, depth, or mask:OBJECT (that object's coverage mask).
    #[arg(long, default_value = "radiance")]
    output: String,
    /// Target EXR for `--loss l2-to` (same resolution as the scene; `psdr render --aov` writes usable targets).
    #[arg(long)]
    target: Option<PathBuf>,
    /// Also central finite differences with this step (in the parameter's units), as a check.
    #[arg(long)]
    fd: Option<f32>,
    /// Independent seeds for both estimates (a standard error needs at least 2).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..))]
    replicas: u32,
    /// Only these components of the parameter (comma separated); default all.
    #[arg(long, value_delimiter = ',')]
    component: Vec<usize>,
    /// Primary boundary (camera silhouette) samples per gradient evaluation.
    #[arg(long, default_value_t = 1 << 16)]
    sppe: u32,
    /// Secondary boundary (shadow and indirect) samples per scattering path vertex.
    #[arg(long, default_value_t = 1)]
    sppse: u32,
    /// Samples per pixel (overrides the scene's render.spp).
    #[arg(long)]
    spp: Option<u32>,
    #[arg(long, default_value = "cpu", value_parser = super::backend_parser())]
    backend: BackendKind,
}

pub fn run(a: GradArgs) -> anyhow::Result<()> {
    let mut scene = load_scene(&a.scene)?;
    if let Some(spp) = a.spp {
        scene.settings.spp = spp;
    }
    let (output, channel) = match a.output.split_once(':') {
        None if a.output == "radiance" => (Output::Radiance, None),
        None if a.output == "depth" => (Output::Depth, None),
        Some(("mask", name)) => match scene.object_index(name) {
            Some(o) => (Output::Mask(o), Some(name)),
            None => bail!("--output mask:{name}: no object named '{name}'"),
        },
        _ => bail!("--output {}: expected radiance, depth or mask:OBJECT", a.output),
    };
    let loss = match (a.loss.as_str(), &a.target) {
        ("mean", None) => ImageLoss::Mean(output),
        ("l2-to", Some(t)) => ImageLoss::l2_to_exr(t, output, channel)?,
        ("l2-to", None) => bail!("--loss l2-to needs --target TARGET.exr"),
        ("mean", Some(_)) => bail!("--target is only used with --loss l2-to"),
        (other, _) => bail!("unknown loss '{other}' (mean, l2-to)"),
    };
    let params = match &a.param {
        Some(p) => vec![p.clone()],
        None if !scene.requires_grad.is_empty() => scene.requires_grad.clone(),
        None => bail!("name a parameter with --param, or list them in the scene's \"requires_grad\""),
    };
    let mut backend = create_backend(a.backend)?;
    for param in &params {
        let value = param.get(&scene)?;
        if value.len() <= 12 {
            println!("{param} = {value:?}");
        } else {
            println!("{param}: {} values", value.len());
        }
        let components: Vec<usize> =
            if a.component.is_empty() { (0..value.len()).collect() } else { a.component.clone() };
        let t = Instant::now();
        let ad_opts = AdOptions { replicas: a.replicas, edge_samples: a.sppe, secondary_edge_samples: a.sppse };
        let ad = analytic_gradient(&scene, std::slice::from_ref(param), &loss, &ad_opts, backend.as_mut());
        let ad_s = t.elapsed().as_secs_f64();
        let fd = match a.fd {
            Some(step) => {
                let t = Instant::now();
                let opts = FdOptions { step, replicas: a.replicas, components: components.clone() };
                Some((central_difference(&scene, param, &loss, &opts, backend.as_mut())?, t.elapsed().as_secs_f64()))
            }
            None => None,
        };
        if let (Err(e), None) = (&ad, &fd) {
            anyhow::bail!("{e}");
        }
        for (k, &c) in components.iter().enumerate() {
            let mut line = format!("d loss / d {param}[{c}]");
            match &ad {
                Ok(g) if c < g.mean.len() => line += &format!("  AD {:+.6e} ± {}", g.mean[c], std_err(g.std_err[c])),
                Ok(_) => anyhow::bail!("{param}: component {c} does not exist"),
                Err(_) => line += "  AD n/a",
            }
            if let Some((f, _)) = &fd {
                line += &format!("  FD {:+.6e} ± {}", f.mean[k], std_err(f.std_err[k]));
            }
            match a.replicas {
                1 => println!("{line}   (one seed: no standard error; --replicas 2 or more gives one)"),
                n => println!("{line}   (± 1 standard error over {n} seeds)"),
            }
        }
        let (w, h, spp) = (scene.camera.width, scene.camera.height, scene.settings.spp);
        match &ad {
            Ok(g) => {
                let loss = g.loss.map(|l| format!(", loss {l:.6e}")).unwrap_or_default();
                println!(
                    "AD: {w}x{h} at {spp} spp, sppe {}, sppse {}, {} replicas, {ad_s:.2} s on {}{loss}",
                    a.sppe,
                    a.sppse,
                    a.replicas,
                    backend.name()
                )
            }
            Err(e) => println!("AD: {e}"),
        }
        if let Some((f, secs)) = &fd {
            println!("FD: {} renders at {spp} spp on {} in {secs:.2} s", f.renders, backend.name());
        }
    }
    Ok(())
}

/// A standard error for printing: "n/a" where one seed cannot give one.
fn std_err(se: f64) -> String {
    if se.is_finite() {
        format!("{se:.2e}")
    } else {
        "n/a".into()
    }
}
