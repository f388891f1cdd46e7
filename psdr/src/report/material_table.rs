//! The report's materials: every material of the fitted scene with what it is (a constant albedo, a library
//! material and its tint, a texture) and why, from the decisions the material stage recorded in result.json:
//! the walls joined or kept apart (`joined_materials`), gloss or matte (`gloss`), a model's own look
//! (`object_pictures`), the texture search (`surface_textures`) and the photo's own pattern (`photo_textures`). So a user sees which surfaces
//! the fit modelled beyond a colour, and which it left plain on purpose.

use super::summary::SummaryTable;
use crate::scene::{Color, Scalar, Scene};
use serde_json::{Map, Value};

/// One row per material of `scene`: name, what it is, roughness and specular, the recorded decisions.
pub fn material_table(scene: &Scene, recorded: &Map<String, Value>) -> SummaryTable {
    let rows = scene
        .materials
        .iter()
        .map(|m| {
            let what = match (&m.procedural, m.albedo) {
                (Some(p), _) => {
                    let t = p.tint;
                    format!("library material {} (tint {:.2}, {:.2}, {:.2})", p.graph, t.x, t.y, t.z)
                }
                (None, Color::Constant(a)) => format!("albedo {:.3}, {:.3}, {:.3}", a.x, a.y, a.z),
                (None, Color::Texture(_)) => "albedo texture".into(),
            };
            let scalar = |s: Scalar| match s {
                Scalar::Constant(v) => format!("{v:.2}"),
                Scalar::Texture(_) => "texture".into(),
            };
            vec![
                m.name.clone(),
                what,
                format!("{} / {}", scalar(m.roughness), scalar(m.specular)),
                decisions(&m.name, recorded).join("; "),
            ]
        })
        .collect();
    SummaryTable {
        title: format!(
            "Materials: {} (what the material stage made of each surface and part, and why)",
            scene.materials.len()
        ),
        header: ["material", "what it is", "roughness / specular", "decisions"].map(String::from).to_vec(),
        rows,
    }
}

/// The recorded decisions naming material `name`, in the order the stage takes them.
fn decisions(name: &str, recorded: &Map<String, Value>) -> Vec<String> {
    let mut out = vec![];
    if let Some(j) = recorded.get("joined_materials").filter(|j| j.is_object()) {
        let list = |k: &str| -> Vec<&str> { j[k].as_array().into_iter().flatten().filter_map(Value::as_str).collect() };
        let distance =
            |m: &str| j["distances"].as_array().into_iter().flatten().find(|d| d[0] == m).and_then(|d| d[1].as_f64());
        if j["material"] == name {
            out.push(format!(
                "one material for {} (the photo shows them alike, or not at all)",
                list("members").join(", ")
            ));
        } else if list("apart").contains(&name) {
            let d = distance(name).map_or(String::new(), |d| format!(": {d:.2} from the most seen one"));
            out.push(format!("a wall of its own (unlike the others{d})"));
        }
    }
    for (record, key) in [
        ("gloss", "decision"),
        ("object_pictures", "decision"),
        ("surface_textures", "decision"),
        ("photo_textures", "decision"),
    ] {
        let entries = recorded.get(record).and_then(Value::as_array).into_iter().flatten();
        for e in entries.filter(|e| e["material"] == name) {
            if let Some(d) = e[key].as_str().filter(|d| !d.is_empty()) {
                out.push(d.to_string());
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Camera, Material};
    use glam::Vec3;

    #[test]
    fn each_material_gets_a_row_with_its_decisions() {
        let mut scene = Scene::empty(Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 8, 8));
        scene.materials =
            vec![Material::diffuse("wall", Vec3::splat(0.7)), Material::diffuse("wall_x0", Vec3::new(0.2, 0.3, 0.6))];
        let recorded: Map<String, Value> = serde_json::from_str(
            r#"{ "joined_materials": { "material": "wall", "members": ["wall_x1", "wall_z0"], "apart": ["wall_x0"],
                                       "distances": [["wall_x0", 0.51], ["wall_x1", 0.0]] },
                 "surface_textures": [ { "material": "wall", "decision": "contrast 0.02 under 0.05: homogeneous" } ],
                 "gloss": [ { "material": "wall_x0", "decision": "glossy: roughness 0.20" } ] }"#,
        )
        .unwrap();
        let t = material_table(&scene, &recorded);
        assert_eq!(t.rows.len(), 2);
        assert_eq!(t.rows[0][1], "albedo 0.700, 0.700, 0.700");
        assert_eq!(t.rows[0][2], "1.00 / 0.00");
        assert!(
            t.rows[0][3].starts_with("one material for wall_x1, wall_z0") && t.rows[0][3].contains("contrast 0.02")
        );
        assert_eq!(
            t.rows[1][3],
            "a wall of its own (unlike the others: 0.51 from the most seen one); glossy: roughness 0.20"
        );
        assert!(material_table(&scene, &Map::new()).rows.iter().all(|r| r[3].is_empty()));
    }
}
