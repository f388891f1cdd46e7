//! A material per surface, where the photo shows the surfaces unlike: the
//! room box starts with one "wall" material on its four walls, and a tiled or papered wall beside painted ones
//! needs each wall its own (`own_materials`). Once each is divided out of the photo, the walls the photo
//! shows alike (and those it does not show) are one material again (`join_alike_materials`): fitted alone,
//! each wall's albedo would take up the lights' misfit on it, and a wall behind the camera would be fitted by
//! nothing.

use crate::error::{Error, Result};
use crate::scene::{Color, ParamPath, Scene};
use glam::Vec3;
use serde::Serialize;

/// One object's part given a material of its own.
#[derive(Clone, Debug, Serialize)]
pub struct OwnMaterial {
    pub object: String,
    /// The material it shared.
    pub from: String,
    /// Its own material's name: the object's, or `object:part` when the object has several parts.
    pub material: String,
}

/// Each listed object's parts a copy of the material they share with any other part (same values, named after
/// the object); a material no part uses afterwards is removed (the room's "wall" once its four walls have
/// their own), and `requires_grad` entries naming it name each copy instead. Parts that already have a
/// material of their own keep it. Errors name an object the scene does not have.
pub fn own_materials(scene: &mut Scene, objects: &[String]) -> Result<Vec<OwnMaterial>> {
    let mut out = vec![];
    let mut split = vec![false; scene.materials.len()];
    let mut users = vec![0usize; scene.materials.len()];
    for part in scene.objects.iter().flat_map(|o| &o.parts) {
        if let Some(u) = users.get_mut(part.material) {
            *u += 1;
        }
    }
    for name in objects {
        let oi = scene
            .objects
            .iter()
            .position(|o| &o.name == name)
            .ok_or_else(|| Error::Invalid(format!("own_materials: the scene has no object '{name}'")))?;
        for pi in 0..scene.objects[oi].parts.len() {
            let m = scene.objects[oi].parts[pi].material;
            // Shared as the scene came: the last wall to be split counts as sharing, too.
            if m >= users.len() || users[m] < 2 {
                continue;
            }
            let object = &scene.objects[oi];
            let base = if object.parts.len() == 1 {
                object.name.clone()
            } else {
                format!("{}:{}", object.name, object.parts[pi].name)
            };
            let own = unique_name(scene, &base);
            let mut material = scene.materials[m].clone();
            out.push(OwnMaterial { object: object.name.clone(), from: material.name.clone(), material: own.clone() });
            material.name = own;
            scene.materials.push(material);
            scene.objects[oi].parts[pi].material = scene.materials.len() - 1;
            split[m] = true;
        }
    }
    let used = |m: usize| scene.objects.iter().flat_map(|o| &o.parts).any(|p| p.material == m);
    let removed: Vec<usize> = (0..split.len()).filter(|&m| split[m] && !used(m)).collect();
    let renames: Vec<(String, Vec<String>)> = removed
        .iter()
        .map(|&m| {
            let old = scene.materials[m].name.clone();
            let copies = out.iter().filter(|c| c.from == old).map(|c| c.material.clone()).collect();
            (old, copies)
        })
        .collect();
    remove_materials(scene, &removed, &renames);
    Ok(out)
}

fn unique_name(scene: &Scene, base: &str) -> String {
    let taken = |n: &str| scene.materials.iter().any(|m| m.name == n);
    if !taken(base) {
        return base.to_string();
    }
    (2..).map(|k| format!("{base}_{k}")).find(|n| !taken(n)).expect("some suffix is free")
}

/// Removes the materials at `removed` (no part uses them any more), renumbering the parts' indices, and
/// rewrites `requires_grad` entries naming a renamed or removed material (`renames`: old name, new names).
fn remove_materials(scene: &mut Scene, removed: &[usize], renames: &[(String, Vec<String>)]) {
    let mut index = vec![usize::MAX; scene.materials.len()];
    let mut kept = vec![];
    for (m, material) in std::mem::take(&mut scene.materials).into_iter().enumerate() {
        if !removed.contains(&m) {
            index[m] = kept.len();
            kept.push(material);
        }
    }
    scene.materials = kept;
    for part in scene.objects.iter_mut().flat_map(|o| o.parts.iter_mut()) {
        part.material = index[part.material];
    }
    let mut paths = vec![];
    for path in std::mem::take(&mut scene.requires_grad) {
        let text = path.to_string();
        match renames.iter().find(|(old, _)| text.starts_with(&format!("material/{old}/"))) {
            None => paths.push(path),
            Some((old, new)) => {
                let rest = &text[format!("material/{old}/").len()..];
                for n in new {
                    if let Ok(p) = format!("material/{n}/{rest}").parse::<ParamPath>() {
                        if !paths.contains(&p) {
                            paths.push(p);
                        }
                    }
                }
            }
        }
    }
    scene.requires_grad = paths;
}

/// Materials of a group joined back into one (`join_alike_materials`).
#[derive(Clone, Debug, Serialize)]
pub struct JoinedMaterials {
    /// The joined material's name.
    pub material: String,
    /// The group's materials it stands for (the photo shows them alike, or not at all).
    pub members: Vec<String>,
    /// Those left on their own: the photo shows them unlike the most seen (or textured already).
    pub apart: Vec<String>,
    /// The joined albedo: the seen members' own, weighted by their pixels.
    pub albedo: [f32; 3],
    /// Each seen member's albedo distance from the most seen's, relative to its length.
    pub distances: Vec<(String, f32)>,
}

/// Joins a group of materials (the walls after `own_materials` and one albedo division) back into one named
/// `name`, where the photo shows no difference between them: the most seen member and every other seen one
/// whose constant albedo lies within `tolerance` of its (relative RGB distance), plus every member with no
/// seen pixel (nothing says it differs: it looks like the wall the photo shows most). The joined material is
/// the most seen member's, renamed, at its members' pixel-weighted mean albedo; the others are removed. So
/// alike walls stay one material ("model no more than a scene needs": per-wall albedos fitted alone take up
/// the lights' misfit, each wall its own), and a wall painted or papered unlike the others keeps its own.
/// `seen`: material names and their pixel counts, as the material segments give them. Returns None where no
/// member is seen or the most seen is textured. Errors name a member the scene does not have.
pub fn join_alike_materials(
    scene: &mut Scene,
    seen: &[(String, f64)],
    group: &[String],
    tolerance: f32,
    name: &str,
) -> Result<Option<JoinedMaterials>> {
    let index = |n: &str| {
        scene
            .materials
            .iter()
            .position(|m| m.name == n)
            .ok_or_else(|| Error::Invalid(format!("join_alike_materials: the scene has no material '{n}'")))
    };
    let members = group.iter().map(|n| index(n)).collect::<Result<Vec<_>>>()?;
    let pixels = |m: usize| seen.iter().filter(|(s, _)| *s == scene.materials[m].name).map(|(_, p)| *p).sum::<f64>();
    let Some(&most) = members.iter().filter(|&&m| pixels(m) > 0.0).max_by(|&&a, &&b| pixels(a).total_cmp(&pixels(b)))
    else {
        return Ok(None);
    };
    let Color::Constant(reference) = scene.materials[most].albedo else {
        return Ok(None);
    };
    let (mut joined, mut apart, mut distances) = (vec![], vec![], vec![]);
    for &m in &members {
        let distance = match scene.materials[m].albedo {
            Color::Constant(a) => (a - reference).length() / reference.length().max(1e-6),
            _ => f32::INFINITY,
        };
        if pixels(m) > 0.0 {
            distances.push((scene.materials[m].name.clone(), distance));
        }
        if pixels(m) == 0.0 || distance <= tolerance {
            joined.push(m);
        } else {
            apart.push(m);
        }
    }
    let (mut sum, mut weight) = (Vec3::ZERO, 0.0f64);
    for &m in &joined {
        if let Color::Constant(a) = scene.materials[m].albedo {
            sum += a * pixels(m) as f32;
            weight += pixels(m);
        }
    }
    let albedo = sum / weight as f32;
    let member_names: Vec<String> = joined.iter().map(|&m| scene.materials[m].name.clone()).collect();
    let taken = scene.materials.iter().enumerate().any(|(i, m)| m.name == name && !joined.contains(&i));
    let material = if taken { unique_name(scene, name) } else { name.to_string() };
    for part in scene.objects.iter_mut().flat_map(|o| o.parts.iter_mut()) {
        if joined.contains(&part.material) {
            part.material = most;
        }
    }
    scene.materials[most].albedo = Color::Constant(albedo);
    let renames: Vec<(String, Vec<String>)> =
        member_names.iter().map(|n| (n.clone(), vec![material.clone()])).collect();
    scene.materials[most].name = material.clone();
    let removed: Vec<usize> = joined.iter().copied().filter(|&m| m != most).collect();
    remove_materials(scene, &removed, &renames);
    Ok(Some(JoinedMaterials {
        material,
        members: member_names,
        apart: apart.iter().map(|&m| scene_name_after(scene, m, &removed)).collect(),
        albedo: albedo.to_array(),
        distances,
    }))
}

/// The name of material `m` (an index from before `removed` went) in the scene as it is now.
fn scene_name_after(scene: &Scene, m: usize, removed: &[usize]) -> String {
    scene.materials[m - removed.iter().filter(|&&r| r < m).count()].name.clone()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{rectangle_mesh, Camera, Material, Object, Pose};
    use glam::Vec3;

    fn room() -> Scene {
        let mut s = Scene::empty(Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 8, 8));
        s.materials = vec![Material::diffuse("floor", Vec3::splat(0.4)), Material::diffuse("wall", Vec3::splat(0.7))];
        for (name, m) in [("floor", 0), ("wall_x0", 1), ("wall_x1", 1), ("wall_z0", 1)] {
            let mut part = rectangle_mesh(1.0, 1.0);
            part.material = m;
            s.objects.push(Object { name: name.into(), parts: vec![part], pose: Pose::default(), emitter: None });
        }
        s.requires_grad = vec!["material/wall/albedo".parse().unwrap(), "material/floor/albedo".parse().unwrap()];
        s
    }

    fn material_of<'a>(s: &'a Scene, object: &str) -> &'a Material {
        &s.materials[s.objects.iter().find(|o| o.name == object).unwrap().parts[0].material]
    }

    #[test]
    fn each_wall_gets_its_own_copy_and_the_shared_one_goes() {
        let mut s = room();
        let names: Vec<String> = ["wall_x0", "wall_x1", "wall_z0", "floor"].map(String::from).to_vec();
        let done = own_materials(&mut s, &names).unwrap();
        // The floor's material was its own already.
        assert_eq!(done.len(), 3, "{done:?}");
        let mut all: Vec<&str> = s.materials.iter().map(|m| m.name.as_str()).collect();
        all.sort();
        assert_eq!(all, ["floor", "wall_x0", "wall_x1", "wall_z0"]);
        for w in ["wall_x0", "wall_x1", "wall_z0"] {
            assert_eq!(material_of(&s, w).name, w);
            assert_eq!(material_of(&s, w).albedo, Material::diffuse("x", Vec3::splat(0.7)).albedo);
        }
        assert_eq!(material_of(&s, "floor").name, "floor");
        let grads: Vec<String> = s.requires_grad.iter().map(|p| p.to_string()).collect();
        assert_eq!(grads.len(), 4, "{grads:?}");
        assert!(
            grads.contains(&"material/wall_z0/albedo".to_string())
                && grads.contains(&"material/floor/albedo".to_string())
        );
        // Again: nothing left to split.
        assert!(own_materials(&mut s, &names).unwrap().is_empty());
        assert!(own_materials(&mut s, &["sofa".to_string()]).unwrap_err().to_string().contains("sofa"));
    }

    #[test]
    fn a_shared_material_another_object_keeps_stays() {
        let mut s = room();
        let done = own_materials(&mut s, &["wall_x0".to_string()]).unwrap();
        assert_eq!(done.len(), 1);
        assert_eq!(material_of(&s, "wall_x1").name, "wall");
        assert_eq!(material_of(&s, "wall_x0").name, "wall_x0");
    }

    #[test]
    fn alike_walls_join_and_an_unlike_one_stays_apart() {
        let mut s = room();
        let walls: Vec<String> = ["wall_x0", "wall_x1", "wall_z0"].map(String::from).to_vec();
        own_materials(&mut s, &walls).unwrap();
        let set = |s: &mut Scene, n: &str, v: Vec3| {
            s.materials.iter_mut().find(|m| m.name == n).unwrap().albedo = Color::Constant(v);
        };
        set(&mut s, "wall_x0", Vec3::new(0.2, 0.3, 0.6));
        set(&mut s, "wall_x1", Vec3::new(0.72, 0.7, 0.6));
        set(&mut s, "wall_z0", Vec3::new(0.8, 0.74, 0.66));
        s.requires_grad = vec!["material/wall_x1/albedo".parse().unwrap()];
        // wall_z0 unseen, wall_x1 the most seen, wall_x0 blue.
        let seen = vec![("wall_x0".to_string(), 200.0), ("wall_x1".to_string(), 300.0), ("floor".to_string(), 900.0)];
        let j = join_alike_materials(&mut s, &seen, &walls, 0.25, "wall").unwrap().unwrap();
        assert_eq!(j.material, "wall");
        assert_eq!(j.members, ["wall_x1", "wall_z0"]);
        assert_eq!(j.apart, ["wall_x0"]);
        // Only the seen member weighs: wall_x1's albedo.
        assert_eq!(j.albedo, [0.72, 0.7, 0.6]);
        assert_eq!(material_of(&s, "wall_x1").name, "wall");
        assert_eq!(material_of(&s, "wall_z0").name, "wall");
        assert_eq!(material_of(&s, "wall_x0").name, "wall_x0");
        assert_eq!(s.materials.len(), 3, "floor, wall, wall_x0");
        assert_eq!(s.requires_grad[0].to_string(), "material/wall/albedo");
        // Two seen alike: the pixel-weighted mean.
        let mut t = room();
        own_materials(&mut t, &walls).unwrap();
        set(&mut t, "wall_x0", Vec3::splat(0.6));
        set(&mut t, "wall_x1", Vec3::splat(0.66));
        let seen = vec![("wall_x0".to_string(), 100.0), ("wall_x1".to_string(), 300.0)];
        let j = join_alike_materials(&mut t, &seen, &walls, 0.25, "wall").unwrap().unwrap();
        assert!(j.apart.is_empty() && j.members.len() == 3);
        assert!((j.albedo[0] - 0.645).abs() < 1e-5, "{:?}", j.albedo);
        assert_eq!(t.materials.len(), 2);
        // None seen: nothing to join on.
        let mut u = room();
        own_materials(&mut u, &walls).unwrap();
        assert!(join_alike_materials(&mut u, &[], &walls, 0.25, "wall").unwrap().is_none());
        assert!(join_alike_materials(&mut u, &[], &["wall".to_string()], 0.25, "wall").is_err());
    }
}
