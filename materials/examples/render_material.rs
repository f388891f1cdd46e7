//! Renders one library material's maps: `cargo run -p psdr-materials --example
//! render_material -- NAME OUT_DIR [SIZE] [key=value ...]` (what `psdr materials render` does).
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        eprintln!("usage: render_material NAME OUT_DIR [SIZE] [key=value ...]");
        std::process::exit(2);
    }
    let size = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(512);
    let overrides: Vec<String> = args.iter().skip(3).cloned().collect();
    match psdr_materials::cli::render(&args[0], std::path::Path::new(&args[1]), size, &overrides) {
        Ok(files) => files.iter().for_each(|f| println!("{}", f.display())),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
