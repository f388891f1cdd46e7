//! `psdr export SCENE --format mitsuba|gltf -o DIR`

use crate::export::gltf::export_glb;
use crate::export::mitsuba::export_mitsuba;
use crate::scene::load_scene;
use clap::{Args, ValueEnum};
use std::path::PathBuf;

#[derive(Clone, Copy, ValueEnum)]
enum Format {
    /// Mitsuba 3 XML scene with PLY meshes and EXR textures.
    Mitsuba,
    /// glTF 2.0 binary (DIR/scene.glb) for Blender and the web.
    Gltf,
}

#[derive(Args)]
pub struct ExportArgs {
    scene: PathBuf,
    #[arg(long, value_enum, default_value = "mitsuba")]
    format: Format,
    /// Output folder (created).
    #[arg(short, long)]
    output: PathBuf,
}

pub fn run(a: ExportArgs) -> anyhow::Result<()> {
    let scene = load_scene(&a.scene)?;
    match a.format {
        Format::Mitsuba => {
            let xml = export_mitsuba(&scene, &a.output)?;
            println!("wrote {}", xml.display());
        }
        Format::Gltf => {
            std::fs::create_dir_all(&a.output)?;
            let glb = a.output.join("scene.glb");
            export_glb(&scene, &glb)?;
            println!("wrote {}", glb.display());
        }
    }
    Ok(())
}
