//! OBJ loading through the scene file: one part per MTL material (groups sharing a material merge), scene
//! materials mapped per part, the "<shape>/<mtl>" fallback built from the MTL's Kd, group names when there is no
//! MTL, and errors for unmapped or unknown parts.

use glam::Vec3;
use psdr::scene::{load_scene, Color, Scalar};
use psdr_tests::*;

const OBJ: &str = "mtllib parts.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
g seat
usemtl red
f 1 2 3
f 1 3 4
g back
usemtl blue
f 5 6 7
g legs
usemtl red
f 5 7 8
g frame
usemtl green
f 1 2 6
f 1 6 5
";

const MTL: &str = "newmtl red
Kd 0.8 0.1 0.1
newmtl blue
Kd 0.1 0.2 0.9
newmtl green
Kd 0.1 0.7 0.2
";

fn write_chair(name: &str) -> std::path::PathBuf {
    let dir = temp_dir(name);
    write_file(&dir, "chair.obj", OBJ);
    write_file(&dir, "parts.mtl", MTL);
    dir
}

#[test]
fn usemtl_groups_load_as_parts_with_mapped_and_fallback_materials() {
    let dir = write_chair("obj-parts");
    let json = scene_json(
        r#"{ "name": "fabric", "albedo": [0.3, 0.3, 0.35], "roughness": 0.9, "specular": 0 }"#,
        r#"{ "name": "chair", "type": "obj", "file": "chair.obj", "part_materials": { "blue": "fabric" } }"#,
    );
    let scene = load_scene(&write_file(&dir, "scene.json", &json)).unwrap();
    let parts = &scene.objects[0].parts;
    let mut names: Vec<&str> = parts.iter().map(|p| p.name.as_str()).collect();
    names.sort();
    assert_eq!(names, ["blue", "green", "red"], "one part per MTL material");
    let part = |n: &str| parts.iter().find(|p| p.name == n).unwrap();
    // "red" merges groups seat (2 faces) and legs (1 face).
    assert_eq!(part("red").indices.len(), 3);
    assert_eq!(part("blue").indices.len(), 1);
    assert_eq!(part("green").indices.len(), 2);
    // Every face keeps its own corner positions.
    let red = part("red");
    let corners: Vec<Vec3> = red.indices.iter().flat_map(|t| t.map(|i| red.positions[i as usize])).collect();
    assert!(corners.contains(&Vec3::new(0.0, 1.0, 0.0)) && corners.contains(&Vec3::new(0.0, 1.0, 1.0)));
    // Mapped part -> the scene material; the others -> "<shape>/<mtl>" from Kd with roughness/specular 0.5.
    assert_eq!(scene.materials[part("blue").material].name, "fabric");
    for (n, kd) in [("red", Vec3::new(0.8, 0.1, 0.1)), ("green", Vec3::new(0.1, 0.7, 0.2))] {
        let m = &scene.materials[part(n).material];
        assert_eq!(m.name, format!("chair/{n}"));
        assert_eq!(m.albedo, Color::Constant(kd));
        assert_eq!((m.roughness, m.specular), (Scalar::Constant(0.5), Scalar::Constant(0.5)));
    }
    assert_eq!(scene.materials.len(), 3, "fallback materials are created once each");
    let f = render(&scene);
    assert!(f.is_finite());
}

#[test]
fn shape_material_overrides_the_mtl_for_unmapped_parts() {
    let dir = write_chair("obj-material");
    let json = scene_json(
        r#"{ "name": "wood", "albedo": 0.4 }, { "name": "fabric", "albedo": 0.2 }"#,
        r#"{ "name": "chair", "type": "obj", "file": "chair.obj", "material": "wood",
             "part_materials": { "green": "fabric" } }"#,
    );
    let scene = load_scene(&write_file(&dir, "scene.json", &json)).unwrap();
    for p in &scene.objects[0].parts {
        let want = if p.name == "green" { "fabric" } else { "wood" };
        assert_eq!(scene.materials[p.material].name, want, "part {}", p.name);
    }
    assert_eq!(scene.materials.len(), 2, "no MTL fallback materials when the shape names one");
}

#[test]
fn without_mtl_parts_are_named_by_group_and_need_a_material() {
    let dir = temp_dir("obj-groups");
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\ng top\nf 1 2 3\ng bottom\nf 1 3 4\n";
    write_file(&dir, "g.obj", obj);
    let ok = scene_json(r#"{ "name": "m" }"#, r#"{ "name": "s", "type": "obj", "file": "g.obj", "material": "m" }"#);
    let scene = load_scene(&write_file(&dir, "ok.json", &ok)).unwrap();
    let mut names: Vec<_> = scene.objects[0].parts.iter().map(|p| p.name.clone()).collect();
    names.sort();
    assert_eq!(names, ["bottom", "top"]);

    let bad = scene_json(r#"{ "name": "m" }"#, r#"{ "name": "s", "type": "obj", "file": "g.obj" }"#);
    let path = write_file(&dir, "bad.json", &bad);
    let e = load_scene(&path).unwrap_err().to_string();
    assert!(e.contains("bad.json") && e.contains("shapes[0] ('s').material") && e.contains("has no material"), "{e}");

    let unknown = scene_json(
        r#"{ "name": "m" }"#,
        r#"{ "name": "s", "type": "obj", "file": "g.obj", "material": "m", "part_materials": { "side": "m" } }"#,
    );
    let e = load_scene(&write_file(&dir, "unknown.json", &unknown)).unwrap_err().to_string();
    assert!(e.contains("part_materials.side") && e.contains("no such part") && e.contains("top"), "{e}");
}
