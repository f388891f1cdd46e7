//! Prints the Markdown node reference found in `materials/README.md`.
fn main() {
    print!("{}", psdr_materials::nodes::reference_markdown());
}
