//! `psdr observe PHOTO -o DIR [--depth F] [--masks F] [--labels F] [--fov DEG] [--depth-units U]`: resolves
//! the photo's observations and writes them (with a mask overlay) for inspection and editing.

use crate::vision::{DepthUnits, ObservationInputs, Observations};
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct ObserveArgs {
    /// The photo (PNG, JPEG or EXR).
    photo: PathBuf,
    /// Output folder.
    #[arg(short, long)]
    output: PathBuf,
    /// Depth map (EXR, or 16-bit PNG) instead of STEM.depth.exr/.png beside the photo.
    #[arg(long)]
    depth: Option<PathBuf>,
    /// What the depth values are: metres, or relative (unknown scale and offset).
    #[arg(long, default_value = "metres")]
    depth_units: DepthUnits,
    /// Instance ids (16-bit PNG, 0 = none) instead of STEM.masks.png.
    #[arg(long)]
    masks: Option<PathBuf>,
    /// Instance classes ({"<id>": "<class>"}) instead of STEM.labels.json.
    #[arg(long)]
    labels: Option<PathBuf>,
    /// Vertical field of view in degrees instead of STEM.camera.json.
    #[arg(long)]
    fov: Option<f32>,
}

pub fn run(a: ObserveArgs) -> anyhow::Result<()> {
    let inputs = ObservationInputs {
        photo: a.photo,
        depth: a.depth,
        depth_units: a.depth_units,
        masks: a.masks,
        labels: a.labels,
        fov_y_deg: a.fov,
    };
    let obs = Observations::resolve(&inputs)?;
    let written = obs.write(&a.output)?;
    for (q, src) in &obs.sources {
        println!("{q:<10} {src}");
    }
    for missing in ["depth", "instances", "fov"].iter().filter(|q| !obs.sources.contains_key(**q)) {
        let why = match *missing {
            "depth" => obs.require_depth().err(),
            "instances" => obs.require_instances().err(),
            _ => obs.require_fov().err(),
        };
        println!("{missing:<10} none: {}", why.map(|e| e.to_string()).unwrap_or_default());
    }
    if let Some(m) = &obs.instances {
        for i in &m.instances {
            println!(
                "  instance {:>5}  {:<10} {:>8} px  ({})",
                i.id,
                i.class,
                i.pixels,
                i.label.as_deref().unwrap_or("no label")
            );
        }
    }
    println!("wrote {} files to {}", written.len(), a.output.display());
    Ok(())
}
