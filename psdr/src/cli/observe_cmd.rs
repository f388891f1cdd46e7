//! `psdr observe PHOTO -o DIR [--depth F] [--masks F] [--labels F] [--fov DEG] [--depth-units U]
//! [--camera-height M]`: resolves
//! the photo's observations and writes them (with a mask overlay) for inspection and editing.

use super::observation_args::ObservationArgs;
use crate::vision::Observations;
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct ObserveArgs {
    /// The photo (PNG, JPEG or EXR).
    photo: PathBuf,
    /// Output folder.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    observations: ObservationArgs,
}

pub fn run(a: ObserveArgs) -> anyhow::Result<()> {
    let inputs = a.observations.inputs(&a.photo);
    let obs = Observations::resolve(&inputs)?;
    let written = obs.write(&a.output)?;
    for (q, src) in &obs.sources {
        println!("{q:<10} {src}");
    }
    for w in &obs.warnings {
        println!("warning: {w}");
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
