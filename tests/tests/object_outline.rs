//! Outline descriptors rank a class before any model is rendered. Six chairs of one real size (0.5 x 0.9 x
//! 0.5 m: size says nothing) but different outlines (with a back, a block, a tall stool, with arms, on a solid
//! base, a high seat), four of them placed in a room at various yaws, and only two candidates rendered per
//! instance (`max_candidates: 2`): with silhouettes the true model must be among the two for every instance;
//! ranked by size alone only catalog order picks the two. Also: `psdr db build` stores the descriptors, and
//! they equal the ones rendered on demand.

use glam::Vec3;
use psdr::db::{build_db, model_silhouettes, ModelSet};
use psdr::stages::{init_objects, ObjectInitOptions};
use psdr_tests::furniture::{furnished_room, write_model_set, BoxModel, Item};
use psdr_tests::rooms::{room_scene, RoomSpec};
use psdr_tests::temp_dir;

/// Six chairs whose outlines differ at one bounding box.
fn chairs() -> Vec<(&'static str, String)> {
    let legs = |m: &mut BoxModel, top: f32| {
        for (x, z) in [(-0.22, -0.22), (0.22, -0.22), (-0.22, 0.22), (0.22, 0.22)] {
            m.add([x - 0.03, 0.0, z - 0.03], [x + 0.03, top, z + 0.03]);
        }
    };
    let mut back = BoxModel::default();
    legs(&mut back, 0.4);
    back.add([-0.25, 0.4, -0.25], [0.25, 0.45, 0.25]).add([-0.25, 0.45, -0.25], [0.25, 0.9, -0.2]);
    let mut block = BoxModel::default();
    block.add([-0.25, 0.0, -0.25], [0.25, 0.9, 0.25]);
    let mut stool = BoxModel::default();
    legs(&mut stool, 0.85);
    stool.add([-0.25, 0.85, -0.25], [0.25, 0.9, 0.25]);
    let mut arms = BoxModel::default();
    legs(&mut arms, 0.4);
    arms.add([-0.25, 0.4, -0.25], [0.25, 0.45, 0.25]).add([-0.25, 0.45, -0.25], [0.25, 0.9, -0.2]);
    arms.add([-0.25, 0.45, -0.25], [-0.2, 0.65, 0.25]).add([0.2, 0.45, -0.25], [0.25, 0.65, 0.25]);
    let mut sled = BoxModel::default();
    sled.add([-0.25, 0.0, -0.25], [0.25, 0.45, 0.25]).add([-0.25, 0.45, -0.25], [0.25, 0.9, -0.2]);
    let mut high = BoxModel::default();
    legs(&mut high, 0.65);
    high.add([-0.25, 0.65, -0.25], [0.25, 0.7, 0.25]).add([-0.25, 0.7, -0.25], [0.25, 0.9, -0.2]);
    vec![
        ("chair_back", back.obj()),
        ("chair_block", block.obj()),
        ("chair_stool", stool.obj()),
        ("chair_arms", arms.obj()),
        ("chair_sled", sled.obj()),
        ("chair_high", high.obj()),
    ]
}

#[test]
fn outlines_pick_the_true_model_among_equal_sizes() {
    let dir = temp_dir("object-outline");
    let db_dir = dir.join("db");
    std::fs::create_dir_all(&db_dir).unwrap();
    let mut models = vec![];
    for (name, obj) in chairs() {
        std::fs::write(db_dir.join(format!("{name}.obj")), obj).unwrap();
        models.push(serde_json::json!({"file": format!("{name}.obj"), "category": "chair", "size": [0.5, 0.9, 0.5]}));
    }
    std::fs::write(db_dir.join("catalog.json"), serde_json::json!({ "models": models }).to_string()).unwrap();
    let db = ModelSet::from_folder(&db_dir).unwrap();
    let r = RoomSpec { w: 6.0, d: 6.0, h: 2.8, cam: Vec3::new(0.0, 1.6, 2.6), yaw: 0.0, pitch: -18.0, fov: 60.0 };
    let items = [
        Item { model: "chair_arms", at: Vec3::new(-1.0, 0.0, -1.0), yaw: 20.0 },
        Item { model: "chair_stool", at: Vec3::new(0.2, 0.0, -1.5), yaw: 0.0 },
        Item { model: "chair_sled", at: Vec3::new(1.2, 0.0, -0.5), yaw: -40.0 },
        Item { model: "chair_high", at: Vec3::new(-0.3, 0.0, 0.2), yaw: 150.0 },
    ];
    let (room, classes) = room_scene(&r, &[], false, 160, 120);
    let (truth, f, inst) = furnished_room(&room, &classes, &items, &db_dir);
    let run = |weight: f32| {
        let opts = ObjectInitOptions { max_candidates: 2, silhouette_weight: weight, ..Default::default() };
        init_objects(&room, &f.depth, &inst, &db, &opts).0
    };
    let (outlined, sized) = (run(1.0), run(0.0));
    let (mut with_outline, mut by_size) = (0, 0);
    for it in &items {
        let id = (truth.object_index(it.model).unwrap() + 1) as u16;
        let among = |placed: &[(psdr::stages::ObjectPlacement, psdr::scene::Object)]| {
            let (q, _) = placed.iter().find(|(q, _)| q.instance == id).expect("every chair is placed");
            eprintln!(
                "  {}: candidates {} {:?} + {:?}",
                it.model,
                q.chosen.model,
                q.chosen.outline_iou,
                q.alternatives.iter().map(|a| (&a.model, a.outline_iou)).collect::<Vec<_>>()
            );
            q.chosen.model == it.model || q.alternatives.iter().any(|a| a.model == it.model)
        };
        with_outline += usize::from(among(&outlined));
        by_size += usize::from(among(&sized));
    }
    eprintln!("true model among 2 candidates: outlines {with_outline} of {}, size alone {by_size}", items.len());
    assert!(with_outline == items.len() && by_size < with_outline, "{with_outline} vs {by_size}");
}

#[test]
fn the_database_stores_the_descriptors_it_would_render() {
    let dir = temp_dir("object-outline-db");
    write_model_set(&dir.join("src"));
    build_db(&[dir.join("src")], &dir.join("db"), false).unwrap();
    let db = ModelSet::from_folder(&dir.join("db")).unwrap();
    assert_eq!(db.models.len(), 36);
    for e in db.models.iter().step_by(7) {
        let stored = e.silhouettes.clone().expect("catalog.json holds the silhouettes");
        assert_eq!(stored, model_silhouettes(&e.load_parts().unwrap()).unwrap(), "{}", e.name);
        assert_eq!(stored.len(), 16);
    }
}
