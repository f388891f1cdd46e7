//! Regenerates the committed thumbnails and writes a contact sheet:
//! `cargo run -p psdr-materials --release --example library_sheet -- [sheet.png]`.
fn main() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("library/thumbs");
    let sheet = std::env::args().nth(1).unwrap_or_else(|| "sheet.png".into());
    let thumbs = psdr_materials::cli::thumbnails(&dir, 128).expect("thumbnails");
    println!("{} thumbnails in {}", thumbs.len(), dir.display());
    let legend = psdr_materials::cli::sheet(std::path::Path::new(&sheet)).expect("sheet");
    print!("{legend}");
}
