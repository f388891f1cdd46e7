//! Shared helpers for the benchmark binaries.

pub mod mitsuba_runner;

/// Writes `benchmarks/results/NAME.csv` and `NAME.svg` and says where.
pub fn write_results(name: &str, csv: &str, svg: &str) -> std::io::Result<()> {
    let out = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("results").join(format!("{name}.csv"));
    std::fs::create_dir_all(out.parent().unwrap_or(std::path::Path::new(".")))?;
    std::fs::write(&out, csv)?;
    std::fs::write(out.with_extension("svg"), format!("{svg}\n"))?;
    println!("wrote {} and {}", out.display(), out.with_extension("svg").display());
    Ok(())
}
