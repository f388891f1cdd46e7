//! Library functions behind `psdr materials list | render | sheet`.

use crate::error::{GraphError, ParamError};
use crate::evaluator::Evaluator;
use crate::export;
use crate::font;
use crate::library;
use std::path::{Path, PathBuf};

/// Error of a materials CLI command.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    #[error("unknown material '{name}'; run `psdr materials list` (known: {known})")]
    UnknownMaterial { name: String, known: String },
    #[error(transparent)]
    Graph(Box<GraphError>),
    #[error("{0}")]
    Param(#[from] ParamError),
    #[error("--size {0}: must be between 4 and 8192")]
    Size(usize),
    #[error("{path}: {msg}")]
    Io { path: PathBuf, msg: String },
}

impl From<GraphError> for CliError {
    fn from(e: GraphError) -> Self {
        CliError::Graph(Box::new(e))
    }
}

/// One line of `psdr materials list`.
#[derive(Clone, Debug)]
pub struct MaterialSummary {
    pub name: String,
    pub category: String,
    pub description: String,
    /// `name=default [min, max]` for each exposed parameter.
    pub params: Vec<String>,
}

/// Every library material with its description, in library order.
pub fn list() -> Result<Vec<MaterialSummary>, CliError> {
    library::names()
        .into_iter()
        .map(|name| {
            let g = library::load(name).expect("listed")?;
            let params = g
                .params
                .iter()
                .map(|p| {
                    let fmt = |v: &[f64]| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(",");
                    format!("{}={} [{}, {}]", p.name, fmt(&p.default), fmt(&p.min), fmt(&p.max))
                })
                .collect();
            Ok(MaterialSummary {
                name: name.to_string(),
                category: g.category.clone(),
                description: g.description.clone(),
                params,
            })
        })
        .collect()
}

/// `list()` formatted as a table for printing.
pub fn list_text() -> Result<String, CliError> {
    let mut s = String::new();
    for m in list()? {
        s += &format!("{:<22} {:<10} {}\n", m.name, m.category, m.description);
    }
    Ok(s)
}

fn load_named(name: &str) -> Result<crate::graph::Graph, CliError> {
    match library::load(name) {
        Some(g) => Ok(g?),
        None => Err(CliError::UnknownMaterial { name: name.to_string(), known: library::names().join(", ") }),
    }
}

fn write_png(path: &Path, size: usize, data: Vec<u8>, rgb: bool) -> Result<(), CliError> {
    write_png_wh(path, size, size, &data, rgb)
}

fn write_png_wh(path: &Path, w: usize, h: usize, data: &[u8], rgb: bool) -> Result<(), CliError> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    use image::ImageEncoder;
    let io_err = |msg: String| CliError::Io { path: path.to_path_buf(), msg };
    let file = std::fs::File::create(path).map_err(|e| io_err(e.to_string()))?;
    // Best compression keeps the committed thumbnails small.
    let enc = PngEncoder::new_with_quality(std::io::BufWriter::new(file), CompressionType::Best, FilterType::Adaptive);
    let color = if rgb { image::ExtendedColorType::Rgb8 } else { image::ExtendedColorType::L8 };
    enc.write_image(data, w as u32, h as u32, color).map_err(|e| io_err(e.to_string()))
}

/// Renders material `name` at `size` with `key=value` overrides into `out_dir`
/// (created if needed) as base_color.png (sRGB), roughness.png, normal.png
/// (0.5 + 0.5 n, OpenGL), height.png (16-bit, when the graph has a height) and
/// preview.png (lit). Returns the written paths.
pub fn render(name: &str, out_dir: &Path, size: usize, overrides: &[String]) -> Result<Vec<PathBuf>, CliError> {
    if !(4..=8192).contains(&size) {
        return Err(CliError::Size(size));
    }
    let graph = load_named(name)?;
    let mut params = graph.default_params();
    for o in overrides {
        graph.apply_override(&mut params, o)?;
    }
    std::fs::create_dir_all(out_dir).map_err(|e| CliError::Io { path: out_dir.to_path_buf(), msg: e.to_string() })?;
    let mut ev = Evaluator::new(graph, size);
    ev.forward(&params);
    let mut written = vec![];
    let mut put = |file: &str, data: Vec<u8>, rgb: bool| -> Result<(), CliError> {
        let p = out_dir.join(file);
        write_png(&p, size, data, rgb)?;
        written.push(p);
        Ok(())
    };
    put("base_color.png", export::base_color_rgb8(&ev), true)?;
    put("roughness.png", export::roughness_gray8(&ev), false)?;
    put("normal.png", export::normal_rgb8(&ev), true)?;
    put("preview.png", export::preview_rgb8(&ev), true)?;
    if let Some(h) = export::height_gray16(&ev) {
        let p = out_dir.join("height.png");
        let img =
            image::ImageBuffer::<image::Luma<u16>, _>::from_raw(size as u32, size as u32, h).expect("buffer size");
        img.save(&p).map_err(|e| CliError::Io { path: p.clone(), msg: e.to_string() })?;
        written.push(p);
    }
    Ok(written)
}

/// Pixel size of each swatch on the contact sheet.
pub const SHEET_SWATCH: usize = 128;

/// Writes a contact sheet PNG of the whole library at default parameters (lit
/// previews, labelled with names, in library order). Returns a printable
/// legend (index, name, description).
pub fn sheet(out: &Path) -> Result<String, CliError> {
    sheet_with(out, SHEET_SWATCH)
}

/// [`sheet`] with swatches of `swatch` pixels.
pub fn sheet_with(out: &Path, swatch: usize) -> Result<String, CliError> {
    let names = library::names();
    let (sw, label) = (swatch.max(4), 16);
    let cell_w = sw + 32;
    let cell_h = sw + label + 8;
    let cols = 8;
    let rows = names.len().div_ceil(cols);
    let (w, h) = (cols * cell_w, rows * cell_h);
    let mut buf = vec![32u8; w * h * 3];
    let mut legend = String::new();
    for (k, name) in names.iter().enumerate() {
        let graph = load_named(name)?;
        legend += &format!("{k:>3}  {name:<22} {}\n", graph.description);
        let params = graph.default_params();
        let mut ev = Evaluator::new(graph, sw);
        ev.forward(&params);
        let px = export::preview_rgb8(&ev);
        let (x0, y0) = ((k % cols) * cell_w + 16, (k / cols) * cell_h + 4);
        for y in 0..sw {
            let dst = ((y0 + y) * w + x0) * 3;
            buf[dst..dst + sw * 3].copy_from_slice(&px[y * sw * 3..(y + 1) * sw * 3]);
        }
        let tw = font::text_width(name, 2).min(cell_w);
        let tx = (k % cols) * cell_w + (cell_w - tw) / 2;
        font::draw_text(&mut buf, w, tx, y0 + sw + 4, 2, name, [230, 230, 230]);
    }
    write_png_wh(out, w, h, &buf, true)?;
    Ok(legend)
}

/// Writes a `SHEET_SWATCH`-pixel lit thumbnail of every library material to `dir/NAME.png`.
pub fn thumbnails(dir: &Path, size: usize) -> Result<Vec<PathBuf>, CliError> {
    std::fs::create_dir_all(dir).map_err(|e| CliError::Io { path: dir.to_path_buf(), msg: e.to_string() })?;
    let mut out = vec![];
    for name in library::names() {
        let graph = load_named(name)?;
        let params = graph.default_params();
        let mut ev = Evaluator::new(graph, size);
        ev.forward(&params);
        let p = dir.join(format!("{name}.png"));
        write_png(&p, size, export::preview_rgb8(&ev), true)?;
        out.push(p);
    }
    Ok(out)
}
