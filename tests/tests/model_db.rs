//! The model database: a Sweet Home 3D library built by the test (catalog in centimetres, a model rotation, a
//! model whose OBJ is corrupt), a corrupt archive, and, when the Debian package is installed, every installed
//! library: each model indexed or reported with its reason.

use psdr::db::{build_db, class_of, read_sh3f, ModelSet, SWEET_HOME_3D_FURNITURE};
use psdr_tests::temp_dir;
use std::io::Write;
use std::path::Path;

/// A unit cube's OBJ stretched to (sx, sy, sz), standing on y = 0.
fn box_obj(sx: f32, sy: f32, sz: f32) -> String {
    let mut s = String::new();
    for (x, y, z) in [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)] {
        s += &format!("v {} {} {}\n", x as f32 * sx, y as f32 * sy, z as f32 * sz);
    }
    for f in
        ["1 2 3", "1 3 4", "5 7 6", "5 8 7", "1 5 6", "1 6 2", "2 6 7", "2 7 3", "3 7 8", "3 8 4", "4 8 5", "4 5 1"]
    {
        s += &format!("f {f}\n");
    }
    s
}

fn write_sh3f(path: &Path) {
    let mut zip = zip::ZipWriter::new(std::fs::File::create(path).unwrap());
    let opts: zip::write::SimpleFileOptions =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    let catalog = "id=Test\nname=Test library\nlicense=CC-BY 3.0\n\n\
        id#1=test#sofa\nname#1=Corner sofa\ncategory#1=Living room\nmodel#1=/lib/sofa/sofa.obj\n\
        width#1=200\ndepth#1=90\nheight#1=80\ncreator#1=Someone\n\
        modelRotation#1=0 0 1 0 1 0 -1 0 0\n\n\
        id#2=test#broken\nname#2=Bedside table\nmodel#2=/lib/broken/broken.obj\nwidth#2=50\ndepth#2=40\nheight#2=60\n\n\
        id#3=test#socket\nname#3=Wall socket\ntags#3=Electric, Plug\nmodel#3=/lib/socket.obj\nwidth#3=8\ndepth#3=2\nheight#3=8\n";
    for (name, body) in [
        ("PluginFurnitureCatalog.properties", catalog.to_string()),
        ("lib/sofa/sofa.obj", box_obj(3.0, 2.0, 7.0)),
        ("lib/broken/broken.obj", "v 0 0 0\nv 1 0 0\nf 1 2 9\n".to_string()),
        ("lib/socket.obj", box_obj(1.0, 1.0, 1.0)),
    ] {
        zip.start_file(name, opts).unwrap();
        zip.write_all(body.as_bytes()).unwrap();
    }
    zip.finish().unwrap();
}

#[test]
fn a_library_is_indexed_and_bad_models_are_reported() {
    let dir = temp_dir("model-db");
    let lib = dir.join("test.sh3f");
    write_sh3f(&lib);
    let corrupt = dir.join("corrupt.sh3f");
    std::fs::write(&corrupt, b"PK\x03\x04 not really a zip").unwrap();
    let catalog = read_sh3f(&lib).unwrap();
    assert_eq!(catalog.models.len(), 3);
    assert_eq!(catalog.models[0].class, "sofa", "name first");
    assert_eq!(catalog.models[1].class, "table", "then the name's last word");
    assert_eq!(catalog.models[2].class, "object", "'wall' is never a model's class");
    let out = dir.join("db");
    let report = build_db(&[lib, corrupt.clone()], &out, true).unwrap();
    assert_eq!(report.indexed.len(), 2, "{:?}", report.skipped);
    let reasons: Vec<String> = report.skipped.iter().map(|s| format!("{} {}: {}", s.0, s.1, s.2)).collect();
    assert_eq!(report.skipped.len(), 2, "{reasons:?}");
    assert!(reasons.iter().any(|r| r.contains("Bedside table") && r.contains("OBJ")), "{reasons:?}");
    assert!(reasons.iter().any(|r| r.contains("corrupt.sh3f") && r.contains("zip")), "{reasons:?}");
    // The index reads back without opening the OBJs; the sofa is rotated (x <-> z) then scaled to its
    // catalog size in metres: 2.0 wide, 0.8 high, 0.9 deep.
    let set = ModelSet::from_folder(&out).unwrap();
    assert_eq!(set.models.len(), 2);
    let sofa = &set.of_class("sofa")[0];
    let s = sofa.size();
    assert!((s.x - 2.0).abs() < 1e-4 && (s.y - 0.8).abs() < 1e-4 && (s.z - 0.9).abs() < 1e-4, "{s:?}");
    assert!(sofa.licence.contains("CC-BY 3.0") && sofa.licence.contains("Someone"), "{}", sofa.licence);
    let parts = sofa.load_parts().unwrap();
    let (mut lo, mut hi) = (glam::Vec3::splat(f32::MAX), glam::Vec3::splat(f32::MIN));
    for v in parts.iter().flat_map(|p| &p.positions) {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    assert!((hi - lo - s).abs().max_element() < 1e-4 && lo.y.abs() < 1e-5 && (lo.x + hi.x).abs() < 1e-4);
    assert_eq!(class_of("Round table", ""), "table");
    // Thumbnails: one per indexed model, the model darker than the white ground around it.
    let catalog: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("catalog.json")).unwrap()).unwrap();
    for m in catalog["models"].as_array().unwrap() {
        let thumb = out.join(m["thumbnail"].as_str().expect("a thumbnail"));
        let img = image::open(&thumb).unwrap().to_luma8();
        let (w, h) = img.dimensions();
        let (centre, corner) = (img.get_pixel(w / 2, h / 2)[0], img.get_pixel(2, h - 3)[0]);
        assert!(w == 96 && centre < corner && corner > 100, "{}: centre {centre}, corner {corner}", thumb.display());
    }
}

/// Every model of the installed Sweet Home 3D libraries is indexed or reported with a reason.
#[test]
fn installed_sweet_home_3d_libraries_are_indexed() {
    let installed = Path::new(SWEET_HOME_3D_FURNITURE);
    if !installed.is_dir() {
        eprintln!("skipping: {SWEET_HOME_3D_FURNITURE} not installed (apt-get install sweethome3d-furniture)");
        return;
    }
    let mut entries = 0;
    for lib in std::fs::read_dir(installed).unwrap().filter_map(|e| e.ok()) {
        if lib.path().extension().is_some_and(|x| x == "sh3f") {
            entries += read_sh3f(&lib.path()).unwrap().models.len();
        }
    }
    let out = temp_dir("sh3d-db");
    let t = std::time::Instant::now();
    let report = build_db(&[installed.to_path_buf()], &out, false).unwrap();
    eprintln!(
        "{} libraries' {entries} models: {} indexed, {} skipped in {:.1} s: {:?}",
        SWEET_HOME_3D_FURNITURE,
        report.indexed.len(),
        report.skipped.len(),
        t.elapsed().as_secs_f32(),
        report.skipped
    );
    assert_eq!(report.indexed.len() + report.skipped.len(), entries);
    assert!(report.indexed.len() * 100 >= entries * 95, "most models must load");
    let set = ModelSet::from_folder(&out).unwrap();
    assert_eq!(set.models.len(), report.indexed.len());
    for class in ["sofa", "chair", "table", "bed", "armchair", "lamp"] {
        assert!(set.of_class(class).len() >= 5, "few models of class {class}");
    }
    std::fs::remove_dir_all(&out).ok();
}
