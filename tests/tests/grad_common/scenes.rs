//! Small scenes shared by the gradient tests.

use super::scene_from_json;
use psdr::scene::{load_scene, Scene};

/// A coloured, rotated box against a black background, lit from above.
pub fn box_in_the_dark() -> Scene {
    scene_from_json(
        "box",
        r#"{ "format": "psdr-scene", "version": 1,
      "camera": { "origin": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov_y": 40, "width": 48, "height": 36 },
      "render": { "spp": 128, "max_depth": 2 },
      "materials": [ { "name": "red", "albedo": [0.8, 0.2, 0.1], "roughness": 0.4, "specular": 0.5 },
                     { "name": "white", "albedo": 0.8, "specular": 0 } ],
      "shapes": [
        { "name": "box", "type": "box", "size": [0.6, 0.5, 0.7], "material": "red",
          "transform": { "translation": [0.2, 0.1, -3], "rotation_deg": [20, 30, 0] } },
        { "name": "lamp", "type": "rectangle", "size": [1, 1], "material": "white",
          "transform": { "translation": [0, 3, -3], "rotation_deg": [90, 0, 0] }, "emitter": { "radiance": 4 } } ] }"#,
    )
}

/// A floor lit from above with a box between the light and the floor; the camera sees only floor, around the
/// shadow, never the box.
pub fn shadow_scene(max_depth: u32) -> Scene {
    scene_from_json(
        "shadow",
        &format!(
            r#"{{ "format": "psdr-scene", "version": 1,
      "camera": {{ "origin": [0, 0.6, 1.2], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 30, "width": 40, "height": 30 }},
      "render": {{ "spp": 64, "max_depth": {max_depth} }},
      "materials": [ {{ "name": "floor", "albedo": 0.6, "specular": 0 }}, {{ "name": "grey", "albedo": 0.5, "specular": 0 }} ],
      "shapes": [
        {{ "name": "floor", "type": "rectangle", "size": [6, 6], "material": "floor", "transform": {{ "rotation_deg": [-90, 0, 0] }} }},
        {{ "name": "blocker", "type": "box", "size": [0.3, 0.05, 0.3], "material": "grey",
           "transform": {{ "translation": [0.05, 1.2, -0.1], "rotation_deg": [0, 25, 0] }} }},
        {{ "name": "lamp", "type": "rectangle", "size": [0.6, 0.6], "material": "grey",
           "transform": {{ "translation": [0, 2.2, 0], "rotation_deg": [90, 0, 0] }}, "emitter": {{ "radiance": 6 }} }} ] }}"#
        ),
    )
}

/// The camera sees only a wall; the wall is lit by light bouncing off the floor, where a blocker casts a
/// shadow. The blocker is invisible to the camera and to the lit part of the wall's direct light.
pub fn indirect_scene() -> Scene {
    scene_from_json(
        "indirect",
        r#"{ "format": "psdr-scene", "version": 1,
      "camera": { "origin": [0, 0.5, 1.5], "target": [0, 0.5, -1], "up": [0, 1, 0], "fov_y": 20, "width": 32, "height": 24 },
      "render": { "spp": 64, "max_depth": 3 },
      "materials": [ { "name": "white", "albedo": 0.8, "specular": 0 } ],
      "shapes": [
        { "name": "floor", "type": "rectangle", "size": [6, 6], "material": "white", "transform": { "rotation_deg": [-90, 0, 0] } },
        { "name": "wall", "type": "rectangle", "size": [6, 3], "material": "white", "transform": { "translation": [0, 1.5, -1] } },
        { "name": "blocker", "type": "box", "size": [0.4, 0.05, 0.4], "material": "white",
          "transform": { "translation": [0, 1.0, 0.3] } },
        { "name": "lamp", "type": "rectangle", "size": [0.5, 0.5], "material": "white",
          "transform": { "translation": [0, 2.0, 0.3], "rotation_deg": [90, 0, 0] }, "emitter": { "radiance": 8 } } ] }"#,
    )
}

/// A red box the camera sees, under a light, over a floor: its shadow is seen directly and after a bounce off
/// the box's own faces (camera path vertices on the moving object, then on the floor in its penumbra).
pub fn shadow_seen_off_the_occluder() -> Scene {
    scene_from_json(
        "seen",
        r#"{ "format": "psdr-scene", "version": 1,
      "camera": { "origin": [0.3, 1.1, 2.0], "target": [0, 0.5, 0.0], "up": [0, 1, 0], "fov_y": 40, "width": 32, "height": 24 },
      "render": { "spp": 32, "max_depth": 3 },
      "materials": [ { "name": "white", "albedo": 0.8, "specular": 0 }, { "name": "red", "albedo": [0.8, 0.3, 0.2], "specular": 0 } ],
      "shapes": [
        { "name": "floor", "type": "rectangle", "size": [6, 6], "material": "white", "transform": { "rotation_deg": [-90, 0, 0] } },
        { "name": "wall", "type": "rectangle", "size": [6, 3], "material": "white", "transform": { "translation": [0, 1.5, -1] } },
        { "name": "blocker", "type": "box", "size": [0.4, 0.3, 0.4], "material": "red",
          "transform": { "translation": [0, 0.7, 0.1], "rotation_deg": [0, 20, 0] } },
        { "name": "lamp", "type": "rectangle", "size": [0.5, 0.5], "material": "white",
          "transform": { "translation": [0, 2.0, 0.1], "rotation_deg": [90, 0, 0] }, "emitter": { "radiance": 8 } } ] }"#,
    )
}

/// A flat-shaded coloured cube on the floor of a closed room under a ceiling light (the case where projective
/// methods fail: creases between differently lit faces, and the contact edge with the floor): the shipped
/// examples/cube_room (also bench_grad's scene) at 48x36 and 32 spp, the cube raised by `lift`.
pub fn room_with_cube(lift: f32) -> Scene {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/cube_room/scene.json");
    let mut s = load_scene(std::path::Path::new(path)).expect("examples/cube_room loads");
    (s.camera.width, s.camera.height, s.settings.spp) = (48, 36, 32);
    let cube = s.object_index("cube").expect("the example has a cube");
    s.objects[cube].pose.translation.y += lift;
    s
}

/// A 2 m floor of oak planks (texture 64 texels, uv scale 2) under a lamp, seen from above at 32x32.
pub fn planks() -> Scene {
    scene_from_json(
        "procedural",
        r#"{
      "format": "psdr-scene", "version": 1,
      "camera": { "origin": [0, 2, 0.01], "target": [0, 0, 0], "up": [0, 0, -1], "fov_y": 50, "width": 32, "height": 32 },
      "render": { "spp": 8, "max_depth": 3 },
      "materials": [ { "name": "floor", "specular": 0, "uv_transform": { "scale": 2 },
                       "procedural": { "graph": "oak_planks", "size": 64, "tint": [0.9, 1.0, 1.1],
                                       "params": { "gap": 0.03, "variation": 0.5 } } },
                     { "name": "white", "albedo": 0.8, "specular": 0 } ],
      "shapes": [
        { "name": "floor", "type": "rectangle", "size": [2, 2], "material": "floor", "transform": { "rotation_deg": [-90, 0, 0] } },
        { "name": "lamp", "type": "rectangle", "size": [1, 1], "material": "white",
          "transform": { "translation": [0.5, 1.5, 0], "rotation_deg": [90, 0, 0] }, "emitter": { "radiance": 5 } }
      ]
    }"#,
    )
}

/// The same floor with its material's fields given (checker.exr: RGB albedo; rough.exr: 1-channel roughness
/// from 0.2 to 0.8; bumps.exr: a normal map).
pub fn textured_floor_with(material: &str) -> Scene {
    static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let k = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("psdr_grad_texel_{}_{k}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let texels: Vec<f32> = (0..16).map(|i| 0.2 + 0.04 * i as f32).collect();
    let ch = |k: usize| texels.iter().map(|v| v * [1.0, 0.9, 0.8][k]).collect::<Vec<f32>>();
    psdr::output::write_exr_channels(
        &dir.join("checker.exr"),
        4,
        4,
        &[("R".into(), ch(0)), ("G".into(), ch(1)), ("B".into(), ch(2))],
    )
    .unwrap();
    let rough: Vec<f32> = (0..16).map(|i| 0.2 + 0.04 * i as f32).collect();
    psdr::output::write_exr_channels(&dir.join("rough.exr"), 4, 4, &[("R".into(), rough)]).unwrap();
    // Tangent-space normals tilted up to ~15° in varying directions.
    let tilt: Vec<[f32; 3]> = (0..16)
        .map(|i| {
            let a = i as f32 * 2.4;
            let n = glam::Vec3::new(0.25 * a.cos(), 0.25 * a.sin(), 1.0).normalize() * 0.5 + glam::Vec3::splat(0.5);
            n.to_array()
        })
        .collect();
    let plane = |k: usize| tilt.iter().map(|c| c[k]).collect::<Vec<f32>>();
    psdr::output::write_exr_channels(
        &dir.join("bumps.exr"),
        4,
        4,
        &[("R".into(), plane(0)), ("G".into(), plane(1)), ("B".into(), plane(2))],
    )
    .unwrap();
    let scene = format!(
        r#"{{
      "format": "psdr-scene", "version": 1,
      "camera": {{ "origin": [0, 2, 0.01], "target": [0, 0, 0], "up": [0, 0, -1], "fov_y": 50, "width": 32, "height": 32 }},
      "render": {{ "spp": 8, "max_depth": 3 }},
      "materials": [ {{ "name": "floor", {material} }},
                     {{ "name": "white", "albedo": 0.8, "specular": 0 }} ],
      "shapes": [
        {{ "name": "floor", "type": "rectangle", "size": [2, 2], "material": "floor", "transform": {{ "rotation_deg": [-90, 0, 0] }} }},
        {{ "name": "lamp", "type": "rectangle", "size": [1, 1], "material": "white",
          "transform": {{ "translation": [0.5, 1.5, 0], "rotation_deg": [90, 0, 0] }}, "emitter": {{ "radiance": 5 }} }}
      ]
    }}"#
    );
    std::fs::write(dir.join("scene.json"), scene).unwrap();
    let s = load_scene(&dir.join("scene.json")).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    s
}
