//! The functions behind `psdr materials list | render | sheet`.

use psdr_materials::cli::{self, CliError};

fn temp_dir(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("psdr-materials-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn list_names_every_material_with_a_description() {
    let l = cli::list().unwrap();
    assert!(l.len() >= 40);
    assert!(l.iter().all(|m| !m.description.is_empty() && !m.params.is_empty()));
    assert!(cli::list_text().unwrap().contains("oak_planks"));
}

#[test]
fn render_writes_maps_with_overrides() {
    let dir = temp_dir("render");
    let files = cli::render("oak_planks", &dir, 32, &["gap=0.05".into(), "seed=9".into()]).unwrap();
    let names: Vec<String> = files.iter().map(|p| p.file_name().unwrap().to_string_lossy().into()).collect();
    for want in ["base_color.png", "roughness.png", "normal.png", "height.png", "preview.png"] {
        assert!(names.iter().any(|n| n == want), "missing {want} in {names:?}");
    }
    let img = image::open(dir.join("base_color.png")).unwrap();
    assert_eq!((img.width(), img.height()), (32, 32));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn render_reports_bad_requests() {
    let dir = temp_dir("bad");
    let e = cli::render("oak_plonks", &dir, 32, &[]).unwrap_err();
    assert!(matches!(e, CliError::UnknownMaterial { .. }) && e.to_string().contains("oak_planks"), "{e}");
    let e = cli::render("oak_planks", &dir, 32, &["gap=9".into()]).unwrap_err();
    assert!(e.to_string().contains("'gap'") && e.to_string().contains("outside"), "{e}");
    let e = cli::render("oak_planks", &dir, 2, &[]).unwrap_err();
    assert!(matches!(e, CliError::Size(2)), "{e}");
}

#[test]
fn sheet_writes_a_labelled_grid_and_legend() {
    let dir = temp_dir("sheet");
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("sheet.png");
    let legend = cli::sheet_with(&out, 16).unwrap();
    assert!(legend.lines().count() >= 40 && legend.contains("marble_white"));
    let img = image::open(&out).unwrap();
    assert!(img.width() > 16 * 8);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn readme_documents_every_node_type_and_material() {
    let readme = include_str!("../README.md");
    for spec in psdr_materials::nodes::NODES {
        assert!(readme.contains(&format!("#### `{}`", spec.name)), "README lacks node {}", spec.name);
    }
    for name in psdr_materials::library::names() {
        assert!(readme.contains(name), "README lacks material {name}");
    }
}
