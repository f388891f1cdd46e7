//! A furnished room of real Sweet Home 3D models, what users fit: an armchair, a sofa and an oak table from the
//! installed libraries (Debian `sweethome3d-furniture`, BlendSwap CC0 models, through psdr's model database),
//! about 28k flat-shaded and smooth triangles in a 4.5 x 2.7 x 5.5 m room under a ceiling light. For the
//! gradient tests and benchmarks of the secondary boundary at scale (issue "Secondary boundary at scale").

use crate::rooms::{room_scene, RoomSpec};
use glam::{Quat, Vec3};
use psdr::db::{default_db, ModelSet};
use psdr::scene::{auto_smooth, Material, Object, Pose, Scene};
use std::path::Path;

/// The models (catalog names and files) and where they stand: (name, file stem, x, z, yaw degrees).
pub const FURNISHING: [(&str, &str, f32, f32, f32); 3] = [
    ("armchair", "armchair", -0.9, -1.2, 25.0),
    ("sofa", "sofa2", 0.7, -1.9, -10.0),
    ("table", "oakTable", 0.4, -0.5, 5.0),
];

/// The room at `w` x `h` pixels and `spp`, or None when the Sweet Home 3D libraries are not installed.
pub fn sweet_home_room(w: u32, h: u32, spp: u32) -> Option<Scene> {
    sweet_home_room_smoothed(w, h, spp, None)
}

/// The same room with the models' flat faces smoothed across edges below `smooth_angle` degrees
/// (`scene::auto_smooth`), when given.
pub fn sweet_home_room_smoothed(w: u32, h: u32, spp: u32, smooth_angle: Option<f32>) -> Option<Scene> {
    if !Path::new(psdr::db::SWEET_HOME_3D_FURNITURE).is_dir() {
        return None;
    }
    let db = default_db(None, Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/models").as_path()).ok()?;
    let set = ModelSet::from_folder(&db).ok()?;
    let spec = RoomSpec { w: 4.5, d: 5.5, h: 2.7, cam: Vec3::new(0.2, 1.5, 2.0), yaw: 5.0, pitch: -18.0, fov: 60.0 };
    let (mut scene, _) = room_scene(&spec, &[], false, w, h);
    scene.settings.spp = spp;
    for (name, stem, x, z, yaw) in FURNISHING {
        let entry = set.models.iter().find(|m| m.path.file_stem().is_some_and(|s| s == stem))?;
        let mut parts = entry.load_parts().ok()?;
        if let Some(angle) = smooth_angle {
            parts = parts.iter().map(|p| if p.normals.is_none() { auto_smooth(p, angle) } else { p.clone() }).collect();
        }
        let albedo = match name {
            "armchair" => Vec3::new(0.55, 0.2, 0.12),
            "sofa" => Vec3::new(0.2, 0.3, 0.5),
            _ => Vec3::new(0.5, 0.35, 0.2),
        };
        // One material per part (OBJECT:PART, as the pipeline names them), all of the object's colour.
        for p in parts.iter_mut() {
            scene.materials.push(Material::diffuse(&format!("{name}:{}", p.name), albedo));
            p.material = scene.materials.len() - 1;
        }
        let pose = Pose {
            translation: Vec3::new(x, 0.0, z),
            rotation: Quat::from_rotation_y(yaw.to_radians()),
            ..Pose::default()
        };
        scene.objects.push(Object { name: name.to_string(), parts, pose, emitter: None });
    }
    Some(scene)
}
