//! Prints what `psdr materials list` prints.
fn main() {
    match psdr_materials::cli::list_text() {
        Ok(t) => print!("{t}"),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
