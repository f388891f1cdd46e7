//! What psdr reads it must write and read back unchanged: OBJ files with groups with and without texture
//! coordinates or normals, several materials, n-gons, relative indices, forward references and no MTL file go
//! through `load_obj`, a scene with a material per part, `save_scene` (what every stage writes) and `load_scene`,
//! and must come back with the same triangles, attributes and materials (`same_scene`). Independent truth: the
//! triangles' positions, uvs and normals are checked against the values written in the OBJ text, and a sample of
//! the installed Sweet Home 3D models (those that mix groups with and without uvs first) goes the same way.

use glam::{Vec2, Vec3};
use psdr::db::{check_model, default_db, ModelSet, SWEET_HOME_3D_FURNITURE};
use psdr::scene::{load_obj, load_scene, same_scene, save_scene, Material, MeshPart, Object, Pose, Scene};
use psdr_tests::*;
use std::path::Path;

/// A one-object scene of the parts, one material per part name.
fn scene_of(parts: Vec<MeshPart>) -> Scene {
    let cam = psdr::scene::Camera::look_at(Vec3::new(0.0, 0.5, 4.0), Vec3::ZERO, Vec3::Y, 45.0, 8, 6);
    let mut scene = empty_scene(cam, Default::default());
    let mut parts = parts;
    for p in parts.iter_mut() {
        let name = format!("thing:{}", p.name);
        p.material = scene.material_index(&name).unwrap_or_else(|| {
            scene.materials.push(Material::diffuse(&name, Vec3::new(0.4, 0.5, 0.6)));
            scene.materials.len() - 1
        });
    }
    scene.objects.push(Object { name: "thing".into(), parts, pose: Pose::default(), emitter: None });
    scene
}

/// Loads `obj` (with `mtl` beside it when given), saves the scene as a stage does, reloads it and asserts it is
/// the same; returns the parts as first read.
fn round_trip(name: &str, obj: &str, mtl: Option<&str>) -> Vec<MeshPart> {
    let dir = temp_dir(name);
    write_file(&dir, "model.obj", obj);
    if let Some(m) = mtl {
        write_file(&dir, "model.mtl", m);
    }
    let parts = load_obj(&dir.join("model.obj")).unwrap_or_else(|e| panic!("{name}: {e}")).parts;
    let scene = scene_of(parts.clone());
    let file = dir.join("stage/scene.json");
    save_scene(&scene, &file).unwrap();
    let back = load_scene(&file).unwrap_or_else(|e| panic!("{name}: psdr cannot read its own file: {e}"));
    same_scene(&scene, &back).unwrap_or_else(|e| panic!("{name}: {e}"));
    // Twice: what was written once writes the same again.
    let file2 = dir.join("stage2/scene.json");
    save_scene(&back, &file2).unwrap();
    same_scene(&scene, &load_scene(&file2).unwrap()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    parts
}

fn part<'a>(parts: &'a [MeshPart], name: &str, uvs: bool) -> &'a MeshPart {
    parts.iter().find(|p| p.name == name && p.uvs.is_some() == uvs).unwrap_or_else(|| {
        panic!("no part '{name}' with uvs {uvs} in {:?}", parts.iter().map(|p| &p.name).collect::<Vec<_>>())
    })
}

/// The corners of triangle k as (position, uv).
fn corners(p: &MeshPart, k: usize) -> [(Vec3, Option<Vec2>); 3] {
    p.indices[k].map(|i| (p.positions[i as usize], p.uvs.as_ref().map(|u| u[i as usize])))
}

const MIXED_MTL: &str = "newmtl metal\nKd 0.5 0.5 0.5\nnewmtl fabric\nKd 0.7 0.2 0.1\n";

/// The real-model case that crashed 3 runs of 4: a first group without texture coordinates (more vertices than
/// the file has `vt` lines), then a textured one, then one with normals only, one material shared by two.
const MIXED: &str = "mtllib model.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
v 2 0 0
v 2 1 0
o frame
usemtl metal
f 1 2 3
f 1 3 4
f 5 6 7
f 5 7 8
f 2 9 10
o cushion
usemtl fabric
vt 0 0
vt 1 0
vt 1 1
f 6/1 7/2 8/3
o rail
usemtl metal
vn 0 0 1
f 1//1 2//1 6//1
";

#[test]
fn groups_with_and_without_uvs_and_normals_survive() {
    let parts = round_trip("obj-mixed", MIXED, Some(MIXED_MTL));
    // metal without anything, fabric with uvs, metal with normals: three parts, none losing what it has.
    assert_eq!(
        parts.len(),
        3,
        "{:?}",
        parts.iter().map(|p| (&p.name, p.uvs.is_some(), p.normals.is_some())).collect::<Vec<_>>()
    );
    let frame = part(&parts, "metal", false);
    assert!(frame.normals.is_none() && frame.indices.len() == 5);
    let cushion = part(&parts, "fabric", true);
    assert_eq!(
        corners(cushion, 0).map(|c| c.1.unwrap()),
        [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0)]
    );
    assert_eq!(
        corners(cushion, 0).map(|c| c.0),
        [Vec3::new(1.0, 0.0, 1.0), Vec3::new(1.0, 1.0, 1.0), Vec3::new(0.0, 1.0, 1.0)]
    );
    let rail = parts.iter().find(|p| p.normals.is_some()).expect("the rail keeps its normals");
    assert_eq!(rail.name, "metal");
    assert_eq!(rail.normals.as_ref().unwrap()[0], Vec3::Z);
}

#[test]
fn ngons_relative_indices_and_no_mtl_file() {
    // A pentagon (3 triangles) and a quad by relative indices; the MTL file named is missing: parts by group.
    let obj = "mtllib missing.mtl
o top
v 0 0 0
v 1 0 0
v 1.5 1 0
v 0.5 1.6 0
v -0.5 1 0
f 1 2 3 4 5
o side
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
usemtl nowhere
f -4 -3 -2 -1
";
    let parts = round_trip("obj-ngon", obj, None);
    let top = part(&parts, "top", false);
    assert_eq!(top.indices.len(), 3, "a pentagon is three triangles");
    let side = part(&parts, "side", false);
    assert_eq!(side.indices.len(), 2);
    let area: f32 = (0..2)
        .map(|k| {
            let [a, b, c] = corners(side, k).map(|c| c.0);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    assert!((area - 1.0).abs() < 1e-6, "the relative-index quad is the unit square at z = 1 (area {area})");
    assert!(side.positions.iter().all(|p| p.z == 1.0));
}

#[test]
fn forward_references_duplicates_and_flat_triangles() {
    // Faces naming texture coordinates defined further down (Sweet Home 3D's truck does this), one triangle
    // repeated (also starting at another corner) and one with no area: the repeats and the flat one are dropped.
    let obj = "v 0 0 0
v 1 0 0
v 0 1 0
v 2 2 2
o body
f 1/2 2/3 3/1
f 2/3 3/1 1/2
f 1/2 2/3 4/1
f 1/1 1/1 2/2
vt 0.25 0.5
vt 0.5 0.75
vt 0.75 1
";
    let parts = round_trip("obj-forward", obj, None);
    let body = part(&parts, "body", true);
    assert_eq!(body.indices.len(), 2, "the repeat and the flat triangle are dropped");
    assert_eq!(
        corners(body, 0).map(|c| c.1.unwrap()),
        [Vec2::new(0.5, 0.75), Vec2::new(0.75, 1.0), Vec2::new(0.25, 0.5)]
    );
}

#[test]
fn part_names_that_need_renaming_keep_their_materials() {
    // Two parts named alike with different materials, and a name with spaces: every part keeps its material.
    let mut parts = load_obj(&{
        let dir = temp_dir("obj-names");
        write_file(&dir, "m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\no a\nf 1 2 3\no b\nf 1 2 4\no c\nf 1 3 4\n")
    })
    .unwrap()
    .parts;
    parts[1].name = "a".into();
    parts[2].name = "wood 2".into();
    let mut scene = scene_of(parts.clone());
    scene.materials.push(Material::diffuse("other", Vec3::splat(0.1)));
    scene.objects[0].parts[1].material = scene.materials.len() - 1;
    let dir = temp_dir("obj-names-out");
    save_scene(&scene, &dir.join("scene.json")).unwrap();
    let back = load_scene(&dir.join("scene.json")).unwrap();
    same_scene(&scene, &back).unwrap();
    assert_eq!(back.objects[0].parts[2].name, "wood 2");
}

/// The installed Sweet Home 3D models, or None (with a note) when the package is not installed; CI installs it
/// and sets PSDR_REQUIRE_SWEET_HOME_3D=1, which makes its absence a failure.
fn installed_models() -> Option<ModelSet> {
    if !Path::new(SWEET_HOME_3D_FURNITURE).is_dir() {
        assert!(
            std::env::var("PSDR_REQUIRE_SWEET_HOME_3D").is_err(),
            "PSDR_REQUIRE_SWEET_HOME_3D is set but {SWEET_HOME_3D_FURNITURE} is missing"
        );
        eprintln!("Sweet Home 3D furniture not installed: skipping");
        return None;
    }
    let fallback = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/models");
    Some(ModelSet::from_folder(&default_db(None, &fallback).unwrap()).unwrap())
}

#[test]
fn installed_models_survive_save_and_reload() {
    let Some(set) = installed_models() else { return };
    assert!(set.models.len() > 700, "the libraries hold ~820 models, the index {}", set.models.len());
    // Every model whose groups mix uvs and none (the files that crashed runs), then every 12th model.
    let mixed: Vec<usize> = (0..set.models.len())
        .filter(|&k| {
            load_obj(&set.models[k].path)
                .is_ok_and(|m| m.parts.iter().any(|p| p.uvs.is_some()) && m.parts.iter().any(|p| p.uvs.is_none()))
        })
        .collect();
    assert!(mixed.len() >= 20, "only {} models mix groups with and without uvs", mixed.len());
    let mut sample: Vec<usize> = mixed.iter().copied().take(30).collect();
    let every_12th: Vec<usize> = (0..set.models.len()).step_by(12).filter(|k| !sample.contains(k)).collect();
    sample.extend(every_12th);
    assert!(sample.len() >= 50);
    let dir = temp_dir("obj-installed");
    let failures: Vec<String> = sample
        .iter()
        .filter_map(|&k| {
            let m = &set.models[k];
            check_model(m, &dir.join(format!("{k}"))).err().map(|e| format!("{} ({}): {e}", m.name, m.path.display()))
        })
        .collect();
    assert!(failures.is_empty(), "{} of {} models fail:\n{}", failures.len(), sample.len(), failures.join("\n"));
    eprintln!("{} installed models ({} with mixed groups) survive save and reload", sample.len(), mixed.len().min(30));
}

/// An emitter's sky gradient survives save and reload (`same_scene` compares it); a uniform emitter's file
/// has no `sky_gradient` field, so files written before it existed read the same.
#[test]
fn an_emitters_sky_gradient_survives_save_and_reload() {
    let dir = temp_dir("sky_gradient");
    let mut scene = scene_of(vec![psdr::scene::rectangle_mesh(1.0, 0.6)]);
    let g = Vec3::new(0.5, -0.25, 1.0);
    scene.objects[0].emitter =
        Some(psdr::scene::Emitter { sky_gradient: g, ..psdr::scene::Emitter::uniform(Vec3::ONE, false) });
    let file = dir.join("window/scene.json");
    save_scene(&scene, &file).unwrap();
    let back = load_scene(&file).unwrap();
    same_scene(&scene, &back).unwrap();
    assert_eq!(back.objects[0].emitter.unwrap().sky_gradient, g);
    scene.objects[0].emitter.as_mut().unwrap().sky_gradient = Vec3::ZERO;
    let file = dir.join("uniform/scene.json");
    save_scene(&scene, &file).unwrap();
    assert!(!std::fs::read_to_string(&file).unwrap().contains("sky_gradient"));
    same_scene(&scene, &load_scene(&file).unwrap()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}
