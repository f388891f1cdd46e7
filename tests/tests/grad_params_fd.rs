//! Parameter paths address the scene faithfully, and central finite differences (the ground truth for every
//! analytic gradient) are right where the answer is known in closed form.

use psdr::grad::{central_difference, FdOptions, ImageLoss, Output, ParamPath};
use psdr::render::{render_cpu, SceneData};
use psdr::scene::{load_scene, Scene};

fn small_room() -> Scene {
    psdr_tests::example_room(32, 24, 2)
}

#[test]
fn every_parameter_kind_round_trips_through_set_and_get() {
    let mut s = small_room();
    let cases: [(&str, Vec<f32>); 11] = [
        ("light/ceiling_light/radiance", vec![1.0, 2.0, 3.0]),
        ("material/walnut/albedo", vec![0.1, 0.2, 0.3]),
        ("material/walnut/roughness", vec![0.7]),
        ("material/walnut/specular", vec![0.25]),
        ("material/oak_floor/albedo.texel[3,7]", vec![0.5, 0.25, 0.125]),
        ("material/oak_floor/uv_scale", vec![3.0, 4.0]),
        ("material/oak_floor/uv_rotation", vec![30.0]),
        ("object/table/translation", vec![0.1, 0.0, -1.2]),
        ("object/table/yaw", vec![0.3]),
        ("object/table/rotation", vec![0.0, 0.5, 0.1]),
        ("object/table/scale", vec![1.0, 1.5, 0.5]),
    ];
    for (path, v) in cases {
        let p: ParamPath = path.parse().unwrap();
        p.set(&mut s, &v).unwrap();
        let got = p.get(&s).unwrap();
        assert!(got.iter().zip(&v).all(|(a, b)| (a - b).abs() < 1e-5), "{path}: set {v:?}, got {got:?}");
    }
    // Setting yaw keeps the other Euler angles: rotation vector (0, 0.5, 0.1) then yaw 0.9.
    let yaw: ParamPath = "object/table/yaw".parse().unwrap();
    yaw.set(&mut s, &[0.9]).unwrap();
    assert!((yaw.get(&s).unwrap()[0] - 0.9).abs() < 1e-5);
    let verts: ParamPath = "object/chair/vertices".parse().unwrap();
    let mut v = verts.get(&s).unwrap();
    v[4] += 0.25;
    verts.set(&mut s, &v).unwrap();
    assert_eq!(verts.get(&s).unwrap(), v);
}

#[test]
fn bad_parameters_are_refused_with_the_reason() {
    let mut s = small_room();
    let err = |path: &str, v: &[f32], s: &mut Scene| match path.parse::<ParamPath>() {
        Err(e) => e.to_string(),
        Ok(p) => p.set(s, v).unwrap_err().to_string(),
    };
    assert!(err("object/nope/translation", &[0.0; 3], &mut s).contains("no object named 'nope'"));
    assert!(err("object/table/translation", &[0.0; 2], &mut s).contains("expected 3 values"));
    assert!(err("object/table/translation", &[f32::NAN, 0.0, 0.0], &mut s).contains("not finite"));
    assert!(err("light/table/radiance", &[1.0; 3], &mut s).contains("does not emit"));
    assert!(err("material/oak_floor/albedo", &[0.5; 3], &mut s).contains("uses a texture"));
    assert!(err("material/walnut/albedo.texel[0,0]", &[0.5; 3], &mut s).contains("no texture"));
    assert!(err("material/oak_floor/albedo.texel[999,0]", &[0.5; 3], &mut s).contains("outside"));
    assert!(err("object/table/colour", &[0.5; 3], &mut s).contains("unknown parameter"));
}

/// With one light every path's contribution is proportional to its radiance, so with the same seed
/// d(mean radiance)/d(Le_c) = (sum of channel c) / (3 N Le_c) exactly, up to f32 rounding of the render
/// (relative 1e-3 allows for the step's rounding; any bug in FD bookkeeping is off by O(1)).
#[test]
fn finite_differences_match_the_closed_form_for_a_linear_parameter() {
    let s = small_room();
    let p: ParamPath = "light/ceiling_light/radiance".parse().unwrap();
    let le = p.get(&s).unwrap();
    let frame = render_cpu(&SceneData::build(&s).unwrap(), &s.settings, &|_, _| {});
    let n = frame.pixel_count() as f64;
    let opts = FdOptions { step: 0.5, replicas: 1, components: vec![] };
    let fd = central_difference(&s, &p, &ImageLoss::Mean(Output::Radiance), &opts, psdr_tests::fd_backend().as_mut())
        .unwrap();
    for (c, (&le_c, &fd_c)) in le.iter().zip(&fd.mean).enumerate() {
        let sum: f64 = frame.radiance.iter().skip(c).step_by(3).map(|&x| x as f64).sum();
        let exact = sum / (3.0 * n * le_c as f64);
        assert!((fd_c - exact).abs() < 1e-3 * exact, "channel {c}: FD {fd_c} vs exact {exact}");
    }
}

/// A parameter that cannot affect the image (the albedo of a material no part uses) has a zero FD gradient,
/// bit for bit: same seed, same image.
#[test]
fn finite_differences_are_zero_for_an_unused_parameter() {
    let mut s = small_room();
    s.materials.push(psdr::scene::Material::diffuse("unused", glam::Vec3::splat(0.5)));
    let p: ParamPath = "material/unused/albedo".parse().unwrap();
    let opts = FdOptions { step: 0.1, replicas: 2, components: vec![0] };
    let fd = central_difference(&s, &p, &ImageLoss::Mean(Output::Radiance), &opts, psdr_tests::fd_backend().as_mut())
        .unwrap();
    assert_eq!(fd.mean, vec![0.0]);
}

/// A scene file can mark the parameters that require gradients; unknown ones are refused naming the field.
#[test]
fn scene_files_mark_parameters_that_require_gradients() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/room/scene.json");
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let dir = std::env::temp_dir().join(format!("psdr_requires_grad_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Asset paths are relative to the example's folder: point them back there.
    let room_dir = std::path::Path::new(path).parent().unwrap().canonicalize().unwrap();
    let write = |json: &serde_json::Value| {
        let text = json.to_string().replace("\"textures/", &format!("\"{}/textures/", room_dir.display()));
        let text = text.replace("\"../models/", &format!("\"{}/../models/", room_dir.display()));
        let p = dir.join("scene.json");
        std::fs::write(&p, text).unwrap();
        p
    };
    json["requires_grad"] = serde_json::json!(["object/table/translation", "material/walnut/roughness"]);
    let s = load_scene(&write(&json)).unwrap();
    let names: Vec<String> = s.requires_grad.iter().map(|p| p.to_string()).collect();
    assert_eq!(names, ["object/table/translation", "material/walnut/roughness"]);
    json["requires_grad"] = serde_json::json!(["object/table/translation", "object/tabel/yaw"]);
    let e = load_scene(&write(&json)).unwrap_err().to_string();
    assert!(e.contains("requires_grad[1]") && e.contains("no object named 'tabel'"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}
