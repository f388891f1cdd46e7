//! The object stage's initialisation and retrieval on a room rendered by psdr: the example furniture (table,
//! chair, cabinet) placed at known poses, a model folder holding the true models and five distractors per class
//! (the same models stretched along their axes), and the rendered depth and instance ids as observations.
//! Stated: the true model retrieved, the centre within 5 % of the camera distance, yaw within 10 degrees (modulo the model's symmetry), scale
//! within 10 % (measured: 0.9 % / 1 degree / 0.1 % at worst); top-5 alternatives kept in score order.

use glam::Vec3;
use psdr::db::ModelSet;
use psdr::stages::{init_objects, ObjectInitOptions};
use psdr_tests::furniture::{furnished_room, stretched_obj, symmetry, Item};
use psdr_tests::rooms::{room_scene, RoomSpec};
use psdr_tests::temp_dir;
use std::path::{Path, PathBuf};

fn example_model(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/models").join(format!("{name}.obj"))
}

/// The model folder: the three example models and, per class, five copies stretched by other proportions.
fn model_folder(dir: &Path) -> PathBuf {
    let db = dir.join("db");
    std::fs::create_dir_all(&db).unwrap();
    let stretches = [[1.4, 1.0, 1.0], [1.0, 1.5, 1.0], [0.7, 1.0, 1.3], [1.0, 0.6, 1.0], [1.3, 1.3, 0.7]];
    for name in ["table", "chair", "cabinet"] {
        let text = std::fs::read_to_string(example_model(name)).unwrap();
        std::fs::write(db.join(format!("{name}.obj")), &text).unwrap();
        for (k, s) in stretches.iter().enumerate() {
            let stretched = stretched_obj(&text, *s);
            std::fs::write(db.join(format!("{name}_{k}.obj")), stretched).unwrap();
        }
    }
    db
}

/// The example models as the truth's models (and a cabinet 4.5 times as tall), in a folder of their own.
fn truth_folder(dir: &Path) -> PathBuf {
    let t = dir.join("truth");
    std::fs::create_dir_all(&t).unwrap();
    for name in ["table", "chair", "cabinet"] {
        std::fs::copy(example_model(name), t.join(format!("{name}.obj"))).unwrap();
    }
    let tall = stretched_obj(&std::fs::read_to_string(example_model("cabinet")).unwrap(), [1.0, 4.5, 1.0]);
    std::fs::write(t.join("cabinet_tall.obj"), tall).unwrap();
    t
}

#[test]
fn objects_are_placed_and_the_true_models_retrieved() {
    let dir = temp_dir("object-init");
    let db = ModelSet::from_folder(&model_folder(&dir)).unwrap();
    assert_eq!(db.models.len(), 18);
    assert_eq!(db.of_class("chair").len(), 6);
    let r = RoomSpec { w: 5.0, d: 5.0, h: 2.7, cam: Vec3::new(0.0, 1.6, 2.2), yaw: 0.0, pitch: -20.0, fov: 60.0 };
    let items = [
        Item { model: "table", at: Vec3::new(0.3, 0.0, -0.4), yaw: 30.0 },
        Item { model: "chair", at: Vec3::new(-1.1, 0.0, 0.3), yaw: -60.0 },
        Item { model: "cabinet", at: Vec3::new(1.4, 0.0, -1.9), yaw: 0.0 },
    ];
    let (room, room_classes) = room_scene(&r, &[], false, 256, 192);
    let (scene, f, inst) = furnished_room(&room, &room_classes, &items, &truth_folder(&dir));
    let t = std::time::Instant::now();
    let (placed, skipped) = init_objects(&scene, &f.depth, &inst, &db, &ObjectInitOptions::default());
    eprintln!("{} placed in {:.2} s; skipped {skipped:?}", placed.len(), t.elapsed().as_secs_f32());
    assert_eq!(placed.len(), 3);
    for it in &items {
        let (p, _) = placed.iter().find(|(p, _)| p.class == it.class()).unwrap();
        let dist = (it.at - r.cam).length();
        let err = (Vec3::from(p.translation) - it.at).length();
        let m = symmetry(it.class());
        let yaw_err = ((p.yaw_deg - it.yaw).rem_euclid(m) + m / 2.0).rem_euclid(m) - m / 2.0;
        eprintln!(
            "{}: model {} (iou {:.3}), centre off {:.3} m ({:.1} % of {:.2} m), yaw {:.0} vs {:.0}, scale {:.3}; \
             alternatives {:?}",
            it.model,
            p.chosen.model,
            p.chosen.iou,
            err,
            100.0 * err / dist,
            dist,
            p.yaw_deg,
            it.yaw,
            p.scale,
            p.alternatives.iter().map(|a| (&a.model, a.score)).collect::<Vec<_>>()
        );
        assert_eq!(p.chosen.model, it.model, "retrieval among 5 distractors");
        assert_eq!(p.alternatives.len(), 4, "top-5 kept");
        assert!(err < 0.05 * dist, "centre");
        assert!(yaw_err.abs() < 10.0, "yaw");
        assert!((p.scale - 1.0).abs() < 0.1, "scale");
        assert!(p.alternatives.iter().all(|a| a.score <= p.chosen.score));
    }
}

/// Stability where the observations are poor: an instance whose depth is missing, two chairs of one class
/// touching, an object taller than the room. Stated: the first is skipped with the reason, the touching chairs
/// are two objects (instances, not classes, make objects), the tall one is placed with a finite pose and its
/// scale held to [0.3, 3]; nothing is NaN.
#[test]
fn poor_observations_give_stated_behaviour() {
    let dir = temp_dir("object-stability");
    let db = ModelSet::from_folder(&model_folder(&dir)).unwrap();
    let r = RoomSpec { w: 5.0, d: 5.0, h: 2.7, cam: Vec3::new(0.0, 1.6, 2.2), yaw: 0.0, pitch: -15.0, fov: 60.0 };
    // The cabinet 4.5 times its height: 4 m in a 2.7 m room (it pokes through the ceiling).
    let items = [
        Item { model: "chair", at: Vec3::new(-0.5, 0.0, -0.5), yaw: 0.0 },
        Item { model: "chair", at: Vec3::new(-0.06, 0.0, -0.5), yaw: 0.0 },
        Item { model: "table", at: Vec3::new(1.2, 0.0, -0.8), yaw: 0.0 },
        Item { model: "cabinet_tall", at: Vec3::new(-1.5, 0.0, -2.0), yaw: 0.0 },
    ];
    let (room, room_classes) = room_scene(&r, &[], false, 256, 192);
    let (scene, f, inst) = furnished_room(&room, &room_classes, &items, &truth_folder(&dir));
    // The table's depth is missing.
    let table_id = (scene.object_index("table").unwrap() + 1) as u16;
    let depth: Vec<f32> = f.depth.iter().zip(&inst.ids).map(|(&z, &id)| if id == table_id { 0.0 } else { z }).collect();
    let (placed, skipped) = init_objects(&scene, &depth, &inst, &db, &ObjectInitOptions::default());
    eprintln!(
        "placed {:?}\nskipped {skipped:?}",
        placed.iter().map(|(p, _)| (&p.name, p.translation, p.scale)).collect::<Vec<_>>()
    );
    let table = skipped.iter().find(|s| s.instance == table_id).expect("the table without depth is skipped");
    assert!(table.reason.contains("depth"), "{}", table.reason);
    assert_eq!(placed.iter().filter(|(p, _)| p.class == "chair").count(), 2, "two touching chairs, two objects");
    let chairs: Vec<Vec3> =
        placed.iter().filter(|(p, _)| p.class == "chair").map(|(p, _)| Vec3::from(p.translation)).collect();
    assert!((chairs[0] - chairs[1]).length() > 0.25, "the chairs are placed apart: {chairs:?}");
    let (tall, _) = placed.iter().find(|(p, _)| p.class == "cabinet").expect("the tall cabinet is placed");
    assert!((0.3..=3.0).contains(&tall.scale), "scale {}", tall.scale);
    for (p, o) in &placed {
        assert!(p.translation.iter().all(|v| v.is_finite()) && p.yaw_deg.is_finite() && p.scale.is_finite(), "{p:?}");
        assert!(o.parts.iter().flat_map(|q| &q.positions).all(|v| v.is_finite()));
    }
}

/// A segmenter's split: a sofa behind a bookcase, its instance cut in two at the bookcase (no pixel of one
/// piece touches the other). The pieces are merged into one instance, the merge is logged among the skipped
/// instances, the sofa gets one model (the true one) and the refinement target covers both pieces.
#[test]
fn split_pieces_of_one_object_are_merged() {
    use psdr_tests::furniture::{stage_rooms, write_model_set};
    let dir = temp_dir("object-merge");
    write_model_set(&dir);
    let db = ModelSet::from_folder(&dir).unwrap();
    let (r, _) = stage_rooms();
    let items = [
        Item { model: "sofa_2", at: Vec3::new(0.0, 0.0, -1.6), yaw: 0.0 },
        Item { model: "bookcase_1", at: Vec3::new(0.0, 0.0, -0.4), yaw: 0.0 },
    ];
    let (room, classes) = room_scene(&r, &[], false, 160, 120);
    let (truth, f, mut inst) = furnished_room(&room, &classes, &items, &dir);
    let sofa = (truth.object_index("sofa_2").unwrap() + 1) as u16;
    let shelf = (truth.object_index("bookcase_1").unwrap() + 1) as u16;
    // The piece right of the bookcase's centre becomes a new instance.
    let cols: Vec<usize> = (0..inst.ids.len()).filter(|&p| inst.ids[p] == shelf).map(|p| p % inst.width).collect();
    let middle = (cols.iter().min().unwrap() + cols.iter().max().unwrap()) / 2;
    let piece = 99u16;
    let moved = (0..inst.ids.len()).filter(|&p| inst.ids[p] == sofa && p % inst.width > middle).count();
    for p in 0..inst.ids.len() {
        if inst.ids[p] == sofa && p % inst.width > middle {
            inst.ids[p] = piece;
        }
    }
    let mut extra = inst.instances.iter().find(|i| i.id == sofa).unwrap().clone();
    (extra.id, extra.pixels) = (piece, moved);
    inst.instances.iter_mut().find(|i| i.id == sofa).unwrap().pixels -= moved;
    inst.instances.push(extra);
    let (placed, skipped) = init_objects(&room, &f.depth, &inst, &db, &ObjectInitOptions::default());
    let sofas: Vec<_> = placed.iter().filter(|(p, _)| p.class == "sofa").map(|(p, _)| p).collect();
    assert_eq!(sofas.len(), 1, "one sofa: {sofas:?}");
    let s = sofas[0];
    assert!(s.merged.len() == 1 && [sofa, piece].contains(&s.merged[0]), "{s:?}");
    assert_eq!(s.chosen.model, "sofa_2");
    let log = skipped.iter().find(|k| k.instance == s.merged[0]).expect("the merge is logged");
    assert!(log.reason.contains("merged into"), "{}", log.reason);
    eprintln!("{}", log.reason);
    // Not merging leaves two half sofas.
    let opts = ObjectInitOptions { merge_bridges: 0, ..Default::default() };
    let (apart, _) = init_objects(&room, &f.depth, &inst, &db, &opts);
    assert_eq!(apart.iter().filter(|(p, _)| p.class == "sofa").count(), 2);
}

/// An object whose mask touches nothing but wall: a cabinet mounted 1.4 m up the back wall. It is placed at
/// the height its points show (not stood on the floor and stretched), its support "raised".
#[test]
fn an_object_with_wall_under_it_is_mounted() {
    use psdr_tests::furniture::{stage_rooms, write_model_set};
    let dir = temp_dir("object-mounted");
    write_model_set(&dir);
    let db = ModelSet::from_folder(&dir).unwrap();
    let (r, _) = stage_rooms();
    let items = [Item { model: "cabinet_0", at: Vec3::new(0.5, 1.4, -2.75), yaw: 0.0 }];
    let (room, classes) = room_scene(&r, &[], false, 160, 120);
    let (_, f, inst) = furnished_room(&room, &classes, &items, &dir);
    let (placed, _) = init_objects(&room, &f.depth, &inst, &db, &ObjectInitOptions::default());
    let (p, _) = &placed[0];
    eprintln!("{p:?}");
    assert_eq!(p.support, "raised");
    assert!((p.translation[1] - 1.4).abs() < 0.1, "base at {} m", p.translation[1]);
    assert!((p.scale - 1.0).abs() < 0.2, "scale {}", p.scale);
}

/// A chair whose top is thin: a frame of 2 cm bars 0.3 m above its solid back, a pixel or so wide here, which
/// the mask shrunk by a pixel (where the points come from) loses. Real room05's bentwood chair: its points
/// stopped at 0.57 m for 0.75, its model was tried only at 0.77 of its size and another chair won. Stated: the
/// thin-topped chair retrieved among the generator's six chairs, at its size within 10 %; with the rule off it
/// is not.
#[test]
fn a_chair_with_a_thin_top_is_retrieved_at_its_size() {
    use psdr_tests::furniture::{stage_rooms, variant, BoxModel};
    let dir = temp_dir("object-thin-top");
    let db_dir = dir.join("db");
    std::fs::create_dir_all(&db_dir).unwrap();
    for k in 0..6 {
        std::fs::write(db_dir.join(format!("chair_{k}.obj")), variant("chair", k)).unwrap();
    }
    let (w, seat, back, bar) = (0.46, 0.45, 0.8, 0.02);
    let mut m = BoxModel::default();
    m.add([-w / 2.0, seat - 0.05, -w / 2.0], [w / 2.0, seat, w / 2.0]);
    m.add([-w / 2.0, seat, -w / 2.0], [w / 2.0, back, -w / 2.0 + 0.05]);
    for (sx, sz) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
        let (x, z) = (sx * (w / 2.0 - 0.03), sz * (w / 2.0 - 0.03));
        m.add([x - 0.025, 0.0, z - 0.025], [x + 0.025, seat - 0.05, z + 0.025]);
    }
    let (top, z0) = (back + 0.3, -w / 2.0 + 0.015);
    for x in [-w / 2.0 + 0.02, w / 2.0 - 0.02 - bar] {
        m.add([x, back, z0], [x + bar, top, z0 + bar]);
    }
    m.add([-w / 2.0 + 0.02, top - bar, z0], [w / 2.0 - 0.02, top, z0 + bar]);
    std::fs::write(db_dir.join("chair_thin.obj"), m.obj()).unwrap();
    let db = ModelSet::from_folder(&db_dir).unwrap();
    let (r, _) = stage_rooms();
    let items = [Item { model: "chair_thin", at: Vec3::new(0.7, 0.0, 0.1), yaw: 20.0 }];
    let (room, classes) = room_scene(&r, &[], false, 256, 192);
    let (_, f, inst) = furnished_room(&room, &classes, &items, &db_dir);
    let (placed, _) = init_objects(&room, &f.depth, &inst, &db, &ObjectInitOptions::default());
    let (p, _) = &placed[0];
    eprintln!(
        "{} at scale {:.3} (iou {:.3}); alternatives {:?}",
        p.chosen.model, p.scale, p.chosen.iou, p.alternatives
    );
    assert_eq!(p.chosen.model, "chair_thin");
    assert!((p.scale - 1.0).abs() < 0.1, "scale {}", p.scale);
    // The points' top alone (the rule off) sizes every chair to the solid back, and the thin one loses.
    let off = ObjectInitOptions { thin_top: f32::INFINITY, ..ObjectInitOptions::default() };
    let (placed, _) = init_objects(&room, &f.depth, &inst, &db, &off);
    assert_ne!(placed[0].0.chosen.model, "chair_thin", "the test's chair must need the rule");
}
