//! `psdr materials list | render | sheet`: the procedural material library (psdr-materials).

use clap::{Args, Subcommand};
use psdr_materials::cli as lib;
use std::path::PathBuf;

#[derive(Args)]
pub struct MaterialsArgs {
    #[command(subcommand)]
    command: MaterialsCommand,
}

#[derive(Subcommand)]
enum MaterialsCommand {
    /// List the library: name, category, description and parameters with ranges.
    List,
    /// Render one material's maps (base_color, roughness, normal, height, preview) as PNGs.
    Render {
        /// Library material name (see `psdr materials list`).
        name: String,
        /// Output directory (created if needed).
        #[arg(short, long)]
        out: PathBuf,
        /// Texture size in texels (square).
        #[arg(long, default_value_t = 512)]
        size: usize,
        /// Parameter override `key=value` (or `key=r,g,b`); repeatable.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Write a contact sheet of the whole library at default parameters.
    Sheet {
        /// Output PNG.
        #[arg(short, long)]
        out: PathBuf,
    },
}

pub fn run(args: MaterialsArgs) -> anyhow::Result<()> {
    match args.command {
        MaterialsCommand::List => print!("{}", lib::list_text()?),
        MaterialsCommand::Render { name, out, size, set } => {
            for path in lib::render(&name, &out, size, &set)? {
                println!("{}", path.display());
            }
        }
        MaterialsCommand::Sheet { out } => {
            print!("{}", lib::sheet(&out)?);
            println!("wrote {}", out.display());
        }
    }
    Ok(())
}
