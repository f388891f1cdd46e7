//! Bad input: every failure is an error that names the file and the field (asserted on the message), or, where
//! the input is legal but odd (degenerate triangles), the render succeeds without a panic or a single non-finite
//! value. The CLI exits non-zero with the message.

use glam::{Quat, Vec3};
use psdr::render::SceneData;
use psdr::scene::validate::validate;
use psdr::scene::{load_scene, rectangle_mesh, Camera, Color, Emitter, Pose, RenderSettings, Scalar, Scene};
use psdr_tests::*;
use std::path::Path;

const MAT: &str = r#"{ "name": "m", "albedo": 0.5 }"#;
const RECT: &str = r#"{ "name": "wall", "type": "rectangle", "size": [2, 2], "material": "m" }"#;

/// Loads `json` written as `dir/name` and returns the error message (the load must fail).
fn load_err(dir: &Path, name: &str, json: &str) -> String {
    let path = write_file(dir, name, json);
    match load_scene(&path) {
        Ok(_) => panic!("{name}: loaded but should have failed"),
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.contains(name), "{name}: message does not name the file: {msg}");
            msg
        }
    }
}

#[test]
fn malformed_json_names_file_and_position() {
    let dir = temp_dir("bad-json");
    let e = load_err(&dir, "truncated.json", r#"{ "format": "psdr-scene", "version": 1, "camera": { "#);
    assert!(e.contains("line 1 column"), "{e}");
    let e = load_err(&dir, "typo.json", &scene_json(MAT, RECT).replace("\"fov_y\"", "\"fovy\""));
    assert!(e.contains("fovy"), "unknown field is named: {e}");
}

#[test]
fn missing_files_are_named() {
    let dir = temp_dir("bad-missing");
    let e = load_err(
        &dir,
        "obj.json",
        &scene_json(MAT, r#"{ "name": "thing", "type": "obj", "file": "nope.obj", "material": "m" }"#),
    );
    assert!(e.contains("shapes[0] ('thing').file") && e.contains("nope.obj") && e.contains("not found"), "{e}");
    let e = load_err(&dir, "tex.json", &scene_json(r#"{ "name": "m", "albedo": { "texture": "gone.png" } }"#, RECT));
    assert!(e.contains("materials[0].albedo") && e.contains("gone.png") && e.contains("not found"), "{e}");
    let e = load_err(&dir, "nmap.json", &scene_json(r#"{ "name": "m", "normal_map": "gone_n.png" }"#, RECT));
    assert!(e.contains("materials[0].normal_map") && e.contains("gone_n.png"), "{e}");
    // A scene file that does not exist at all.
    let missing = dir.join("no_scene.json");
    let e = load_scene(&missing).unwrap_err().to_string();
    assert!(e.contains("no_scene.json"), "{e}");
}

#[test]
fn a_file_that_is_not_an_obj_or_an_image_is_an_error() {
    let dir = temp_dir("bad-content");
    write_file(&dir, "junk.png", "this is not a png");
    let e = load_err(&dir, "junk.json", &scene_json(r#"{ "name": "m", "albedo": { "texture": "junk.png" } }"#, RECT));
    assert!(e.contains("materials[0].albedo") && e.contains("junk.png"), "{e}");
    write_file(&dir, "empty.obj", "# nothing here\nv 0 0 0\n");
    let e = load_err(
        &dir,
        "empty.json",
        &scene_json(MAT, r#"{ "name": "e", "type": "obj", "file": "empty.obj", "material": "m" }"#),
    );
    assert!(e.contains("shapes[0] ('e').file") && e.contains("no triangle"), "{e}");
    // A loss target that is not an EXR (a PNG, say) is named as such.
    let png = write_file(&dir, "target.png", "\u{89}PNG this is not an exr");
    let e = psdr::output::read_exr_rgb(&png).unwrap_err().to_string();
    assert!(e.contains("target.png") && e.contains("not an OpenEXR file"), "{e}");
}

#[test]
fn invalid_values_in_json_are_named() {
    let dir = temp_dir("bad-values");
    let base = scene_json(MAT, RECT);
    let e = load_err(&dir, "zero.json", &base.replace("\"width\": 16", "\"width\": 0"));
    assert!(e.contains("camera.width/height") && e.contains("0x12"), "{e}");
    let e = load_err(&dir, "fov.json", &base.replace("\"fov_y\": 45", "\"fov_y\": 180"));
    assert!(e.contains("camera.fov_y"), "{e}");
    let e = load_err(&dir, "unknown_mat.json", &scene_json(MAT, &RECT.replace("\"m\"", "\"nope\"")));
    assert!(e.contains("shapes[0] ('wall').material") && e.contains("unknown material 'nope'"), "{e}");
    let e = load_err(&dir, "albedo.json", &scene_json(r#"{ "name": "m", "albedo": [0.5, 2, 0.5] }"#, RECT));
    assert!(e.contains("materials[0] ('m').albedo") && e.contains("[0, 1]"), "{e}");
    let e = load_err(&dir, "rough.json", &scene_json(r#"{ "name": "m", "roughness": -0.1 }"#, RECT));
    assert!(e.contains("materials[0] ('m').roughness"), "{e}");
    // "scale" is one number or a list (README); the one-number form must parse, and 0 must fail validation.
    let ok = scene_json(
        r#"{ "name": "m", "uv_transform": { "scale": 3 } }"#,
        &RECT.replace("}", r#", "transform": { "scale": 2 } }"#),
    );
    let s = load_scene(&write_file(&dir, "scale_ok.json", &ok)).unwrap();
    assert_eq!(s.objects[0].pose.scale, Vec3::splat(2.0));
    assert_eq!(s.materials[0].uv_transform.scale, glam::Vec2::splat(3.0));
    let e = load_err(&dir, "scale.json", &scene_json(MAT, &RECT.replace("}", r#", "transform": { "scale": 0 } }"#)));
    assert!(e.contains("shapes[0] ('wall').transform.scale"), "{e}");
    let e = load_err(&dir, "spp.json", &base.replace("\"spp\": 2", "\"spp\": 0"));
    assert!(e.contains("render.spp"), "{e}");
    let e =
        load_err(&dir, "radiance.json", &scene_json(MAT, &RECT.replace("}", r#", "emitter": { "radiance": -1 } }"#)));
    assert!(e.contains("shapes[0] ('wall').emitter.radiance"), "{e}");
}

#[test]
fn overflowing_numbers_in_json_are_rejected_not_turned_into_inf() {
    // JSON cannot hold NaN; 1e999 is the nearest thing. Whatever serde makes of it, the load must fail with the
    // file named (a parse error at its position, or a validation error naming the field).
    let dir = temp_dir("bad-inf");
    for (name, json) in [
        ("inf_albedo.json", scene_json(r#"{ "name": "m", "albedo": [1e999, 0, 0] }"#, RECT)),
        ("inf_fov.json", scene_json(MAT, RECT).replace("\"fov_y\": 45", "\"fov_y\": 1e999")),
        ("inf_pos.json", scene_json(MAT, RECT).replace("[0, 0, 4]", "[0, 0, 1e999]")),
        ("inf_radiance.json", scene_json(MAT, &RECT.replace("}", r#", "emitter": { "radiance": 1e39 } }"#))),
    ] {
        let e = load_err(&dir, name, &json);
        eprintln!("{name}: {e}");
    }
}

fn programmatic_scene() -> Scene {
    let cam = Camera::look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y, 45.0, 8, 6);
    let mut sc = empty_scene(cam, RenderSettings { spp: 2, max_depth: 3, rr_depth: 3, seed: 0 });
    add_material(&mut sc, lambert("m", Vec3::splat(0.5)));
    add_object(&mut sc, "wall", rectangle_mesh(2.0, 2.0), 0, Pose::default(), emitter(Vec3::ONE));
    sc
}

/// NaN set in code is caught by validate (naming the field) and SceneData::build refuses the scene, so it can
/// never reach a render.
#[test]
fn nan_parameters_set_in_code_are_caught_by_validation() {
    assert!(validate(&programmatic_scene()).is_ok());
    type Poke = fn(&mut Scene);
    let cases: [(&str, Poke); 11] = [
        ("materials[0] ('m').albedo", |s| s.materials[0].albedo = Color::Constant(Vec3::new(0.5, f32::NAN, 0.5))),
        ("materials[0] ('m').roughness", |s| s.materials[0].roughness = Scalar::Constant(f32::NAN)),
        ("materials[0] ('m').specular", |s| s.materials[0].specular = Scalar::Constant(f32::INFINITY)),
        ("materials[0] ('m').uv_transform", |s| s.materials[0].uv_transform.rotation_deg = f32::NAN),
        ("shapes[0] ('wall').transform", |s| s.objects[0].pose.translation.x = f32::NAN),
        ("shapes[0] ('wall').transform", |s| s.objects[0].pose.rotation = Quat::from_xyzw(f32::NAN, 0.0, 0.0, 1.0)),
        ("shapes[0] ('wall').emitter.radiance", |s| {
            s.objects[0].emitter = Some(Emitter::uniform(Vec3::new(1.0, f32::NAN, 1.0), false))
        }),
        // |g| > 1 would emit negative radiance toward some directions.
        ("shapes[0] ('wall').emitter.sky_gradient", |s| {
            s.objects[0].emitter =
                Some(Emitter { sky_gradient: Vec3::new(0.0, 1.5, 0.0), ..Emitter::uniform(Vec3::ONE, false) })
        }),
        ("shapes[0] ('wall').emitter.sky_gradient", |s| {
            s.objects[0].emitter =
                Some(Emitter { sky_gradient: Vec3::new(f32::NAN, 0.0, 0.0), ..Emitter::uniform(Vec3::ONE, false) })
        }),
        ("shapes[0] ('wall').parts[0] ('rectangle')", |s| s.objects[0].parts[0].positions[1].y = f32::NAN),
        ("camera.fov_y", |s| s.camera.fov_y_deg = f32::NAN),
    ];
    for (field, poke) in cases {
        let mut s = programmatic_scene();
        poke(&mut s);
        let (f, msg) = validate(&s).expect_err(field);
        assert!(f.starts_with(field), "expected field {field}, got {f}: {msg}");
        let e = SceneData::build(&s).expect_err("build must refuse").to_string();
        assert!(e.contains(field), "{e}");
    }
    let mut s = programmatic_scene();
    s.camera.width = 0;
    assert_eq!(validate(&s).unwrap_err().0, "camera.width/height");
    let mut s = programmatic_scene();
    s.objects[0].parts[0].material = 7;
    assert!(validate(&s).unwrap_err().0.contains("parts[0].material"));
}

/// Degenerate (zero-area) triangles, a zero normal and a degenerate emitter are legal input: the scene loads and
/// renders without a panic and without a non-finite value, and zero-area emitters take no light samples. The OBJ
/// reader drops flat triangles (they render nothing), so the renderer's side is checked on a scene that holds
/// them in memory, and an OBJ of flat triangles only is an error that says so.
#[test]
fn degenerate_triangles_render_finite() {
    let dir = temp_dir("bad-degenerate");
    let obj = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nv 0 0 0\nv 2 2 0\nvn 0 0 1\nvn 0 0 0\n\
               f 1//1 2//1 3//1\nf 1//1 3//1 4//1\n\
               f 1//1 1//1 2//1\nf 1//2 3//2 5//2\nf 5//1 5//1 5//1\nf 1//2 5//2 6//2\n";
    write_file(&dir, "degenerate.obj", obj);
    let shapes = r#"{ "name": "mesh", "type": "obj", "file": "degenerate.obj", "material": "m" },
        { "name": "lamp", "type": "obj", "file": "degenerate.obj", "material": "m",
          "transform": { "translation": [0, 0, 1.5], "rotation_deg": [180, 0, 0], "scale": 0.3 }, "emitter": { "radiance": 4 } }"#;
    let path = write_file(&dir, "degenerate.json", &scene_json(MAT, shapes));
    let mut scene = load_scene(&path).expect("degenerate triangles are legal");
    // Only flat triangles: the reader says what it found.
    write_file(&dir, "collinear.obj", "v 0 0 1\nv 1 0 1\nv 2 0 1\nf 1 2 3\n");
    let err = psdr::scene::load_obj(&dir.join("collinear.obj")).err().expect("no triangle with an area");
    assert!(err.to_string().contains("collinear.obj") && err.to_string().contains("no triangle"), "{err}");
    // In memory the renderer meets them anyway (a mesh made in code, a pose that flattens one).
    let mut mesh = scene.objects[0].parts[0].clone();
    mesh.indices = vec![[0, 1, 2]];
    mesh.positions = vec![Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 1.0)];
    mesh.normals = None;
    scene.objects.push(psdr::scene::Object {
        name: "dead_lamp".into(),
        parts: vec![mesh],
        pose: Default::default(),
        emitter: Some(psdr::scene::Emitter::uniform(Vec3::splat(9.0), false)),
    });
    let raw = &mut scene.objects[0].parts[0];
    raw.positions.push(raw.positions[0]);
    if let Some(ns) = raw.normals.as_mut() {
        ns.push(ns[0]);
    }
    let n = raw.positions.len() as u32 - 1;
    raw.indices.push([0, n, 1]);
    scene.settings.spp = 16;
    let d = SceneData::build(&scene).unwrap();
    // Only triangles with positive area carry light (rotating the lamp's collinear triangles by 180 degrees in
    // f32 may leave them a sliver of area, which is harmless); the exactly collinear lamp is never sampled.
    assert!(d.light_count() >= 2, "the lamp's two real triangles are lights");
    for l in &d.lights[..d.light_count() as usize] {
        let t = &d.triangles[l.triangle as usize];
        let area = 0.5 * Vec3::from(t.e1).cross(Vec3::from(t.e2)).length();
        assert!(area > 0.0 && l.pmf > 0.0, "light on a zero-area triangle");
        assert_ne!(t.object, 2, "the collinear lamp must not be sampled");
    }
    let f = render(&scene);
    assert!(f.is_finite(), "a degenerate triangle produced a non-finite value");
    assert!(f.radiance.iter().any(|&x| x > 0.0), "the lamp lights the mesh");
}

/// A missing scene exits non-zero and names the file.
#[test]
fn cli_render_of_a_missing_scene_fails_with_a_message() {
    let Some(bin) = psdr_tests::psdr_bin() else {
        return;
    };
    let dir = temp_dir("bad-cli");
    let missing = dir.join("missing.json");
    let out = std::process::Command::new(&bin)
        .args(["render", missing.to_str().unwrap(), "-o", dir.join("x.exr").to_str().unwrap(), "--quiet"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "exit status {:?}", out.status);
    assert!(stderr.contains("missing.json"), "stderr: {stderr}");
    assert!(!dir.join("x.exr").exists(), "no output for a failed render");
}

/// An output `psdr render` cannot write is refused before the render, not after it (a 512x384 render at 256
/// spp took two minutes to reach that message): with `--spp 0` also given, the output's error must come first.
#[test]
fn cli_render_to_an_unwritable_format_fails_before_rendering() {
    let Some(bin) = psdr_tests::psdr_bin() else {
        return;
    };
    let dir = temp_dir("bad-cli-ext");
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/fit/truth.json");
    let out = std::process::Command::new(&bin)
        .args(["render", scene.to_str().unwrap(), "-o", dir.join("x.jpg").to_str().unwrap(), "--spp", "0", "--quiet"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "exit status {:?}", out.status);
    assert!(stderr.contains("x.jpg") && stderr.contains(".exr or .png"), "stderr: {stderr}");
    assert!(!stderr.contains("spp"), "the render ran before the output was checked: {stderr}");
}

/// `psdr grad` with one seed prints its estimates and says that there is no standard error (it printed
/// "± NaN"), and zero seeds is rejected by name instead of silently running one.
#[test]
fn cli_grad_with_one_seed_prints_no_nan_and_zero_seeds_is_an_error() {
    let Some(bin) = psdr_tests::psdr_bin() else {
        return;
    };
    let scene = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/cube_room/scene.json"));
    let grad = |replicas: &str| {
        std::process::Command::new(&bin)
            .args(["grad", scene.to_str().unwrap(), "--param", "light/light/radiance", "--spp", "2"])
            .args(["--replicas", replicas, "--fd", "0.5", "--component", "0"])
            .output()
            .unwrap()
    };
    let one = grad("1");
    let stdout = String::from_utf8_lossy(&one.stdout);
    assert!(one.status.success(), "stderr: {}", String::from_utf8_lossy(&one.stderr));
    assert!(stdout.contains("AD +") && stdout.contains("FD +"), "stdout: {stdout}");
    assert!(!stdout.to_lowercase().contains("nan"), "stdout: {stdout}");
    assert!(stdout.contains("no standard error"), "stdout: {stdout}");
    let zero = grad("0");
    let stderr = String::from_utf8_lossy(&zero.stderr);
    assert!(!zero.status.success());
    assert!(stderr.contains("--replicas"), "stderr: {stderr}");
}

/// A value of the wrong form is named by its field path and the spellings it may take, never by serde's
/// internal type names ("data did not match any variant of untagged enum ValueFile").
#[test]
fn json_of_the_wrong_form_names_the_field_path() {
    let dir = temp_dir("bad-json-form");
    let cases = [
        (r#"{ "name": "m", "albedo": "red" }"#, RECT, "materials[0].albedo", "[r, g, b]"),
        (r#"{ "name": "m", "albedo": [1, 2] }"#, RECT, "materials[0].albedo", "found [1,2]"),
        (r#"{ "name": "m", "roughness": { "texture": 3 } }"#, RECT, "materials[0].roughness", "expected a string"),
        (
            MAT,
            r#"{ "name": "w", "type": "rectangle", "size": [2, 2], "material": "m", "transform": { "scale": "big" } }"#,
            "shapes[0].transform.scale",
            "a number or a list of numbers",
        ),
        (
            MAT,
            r#"{ "name": "w", "type": "rectangle", "size": [2, 2], "material": "m", "emitter": { "radiance": true } }"#,
            "shapes[0].emitter.radiance",
            "found true",
        ),
    ];
    for (k, (mat, shape, field, says)) in cases.iter().enumerate() {
        let e = load_err(&dir, &format!("form{k}.json"), &scene_json(mat, shape));
        assert!(e.contains(field) && e.contains(says), "case {k}: {e}");
        assert!(!e.contains("untagged") && !e.contains("ValueFile"), "case {k}: serde's internals in {e}");
    }
}
