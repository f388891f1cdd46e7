//! The object stage on furnished rooms rendered by psdr (160x120): 4-5 objects per room from a generated model
//! set (six variants per class: the true one and five distractors), among them a lamp on a table, objects cut
//! by the image border (3) and objects hidden by others (up to 40 %; the test checks its scenes hold both). From
//! the rendered depth, instance masks and classes (and the true room, the room stage's output), `init_objects`
//! retrieves and places every object, then the poses are refined together (40 iterations) with the loss of
//! scripts/room.rhai's object stage. Stated, over every placed object, cut or hidden ones included: the true
//! model in at least 80 % of the instances (measured: 11 of 12; the miss is a chair 5 cm narrower), centres
//! within 5 % of the camera distance, yaw within 10 degrees modulo the symmetry the view shows
//! (`observed_symmetry`), size within 10 % (measured: 0.5 %, 2.5 degrees, 2.8 %).

use glam::Vec3;
use psdr::db::ModelSet;
use psdr::stages::{init_objects, ObjectInitOptions};
use psdr_tests::furniture::{
    first_number, furnished_room, observed_symmetry, run_refinement, stage_rooms, write_model_set,
    write_refinement_inputs,
};
use psdr_tests::rooms::room_scene;
use psdr_tests::temp_dir;

#[test]
fn furnished_rooms_are_retrieved_placed_and_refined() {
    let dir = temp_dir("object-stage");
    let db_dir = dir.join("db");
    write_model_set(&db_dir);
    let db = ModelSet::from_folder(&db_dir).unwrap();
    let (r, rooms) = stage_rooms();
    let (iw, ih) = (160u32, 120u32);
    let (mut instances_total, mut retrieved) = (0, 0);
    let mut worst = [0.0f32; 3];
    let (mut max_hidden, mut cut_count) = (0.0f32, 0);
    for (ri, items) in rooms.iter().enumerate() {
        let (room, classes) = room_scene(&r, &[], false, iw, ih);
        let (truth, f, inst) = furnished_room(&room, &classes, items, &db_dir);
        let (placed, skipped) = init_objects(&room, &f.depth, &inst, &db, &ObjectInitOptions::default());
        eprintln!("room {ri}: {} placed, skipped {skipped:?}", placed.len());
        // Refinement through the script, on the initialised objects.
        let rdir = dir.join(format!("room{ri}"));
        let names = write_refinement_inputs(&rdir, &room, &placed, &inst, &f);
        let t = std::time::Instant::now();
        let poses = run_refinement(&rdir, &names, 40);
        eprintln!("  refined {} objects in {:.1} s", names.len(), t.elapsed().as_secs_f32());
        for (k, it) in items.iter().enumerate() {
            let o = truth.object_index(it.model).unwrap();
            let Some((p, _)) = placed.iter().find(|(p, _)| p.instance as usize == o + 1) else {
                let visible = f.object_id.iter().filter(|&&i| i == o as u32).count();
                eprintln!("  {}: not placed ({visible} pixels visible)", it.model);
                assert!(visible < 100, "{} visible with {visible} pixels but not placed", it.model);
                continue;
            };
            instances_total += 1;
            // How much of it others hide (its pixels rendered alone against those seen), and whether the
            // frame cuts it.
            let (_, alone, _) = furnished_room(&room, &classes, &[*it], &db_dir);
            let alone = alone.object_id.iter().filter(|&&i| i == room.objects.len() as u32).count();
            let seen = f.object_id.iter().filter(|&&i| i == o as u32).count();
            let hidden = 1.0 - seen as f32 / alone.max(1) as f32;
            let cut = (0..(iw * ih) as usize).any(|px| {
                let (x, y) = (px % iw as usize, px / iw as usize);
                inst.ids[px] == p.instance && (x == 0 || y == 0 || x + 1 == iw as usize || y + 1 == ih as usize)
            });
            max_hidden = max_hidden.max(hidden);
            cut_count += usize::from(cut);
            retrieved += usize::from(p.chosen.model == it.model);
            let q = &poses[&p.name];
            let t: Vec<f32> = q["t"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap() as f32).collect();
            let centre = Vec3::new(t[0], t[1], t[2]);
            let dist = (it.at - r.cam).length();
            let err = (centre - it.at).length() / dist;
            let sym = observed_symmetry(&room, &classes, items, k, &db_dir, &f);
            let yaw = first_number(&q["yaw"]).to_degrees();
            let yaw_err = (((yaw - it.yaw).rem_euclid(sym) + sym / 2.0).rem_euclid(sym) - sym / 2.0).abs();
            // Size: the retrieved model's size times its scale against the true model's.
            let chosen = db.models.iter().find(|m| m.name == p.chosen.model).unwrap();
            let true_model = db.models.iter().find(|m| m.name == it.model).unwrap();
            let size_err = (chosen.size().y * first_number(&q["scale"]) / true_model.size().y - 1.0).abs();
            eprintln!(
                "  {}{}, {:.0} % hidden: retrieved {} (init iou {:.2}, support {}), centre {:.1} % of {dist:.1} m, yaw {yaw:.1} vs {} ({yaw_err:.1} modulo {sym}), size {:.1} %",
                it.model, if cut { " (cut by the border)" } else { "" }, hidden * 100.0, p.chosen.model, p.chosen.iou, p.support, err * 100.0, it.yaw, size_err * 100.0
            );
            assert!(centre.is_finite() && yaw.is_finite() && size_err.is_finite(), "{}: non-finite pose", it.model);
            worst = [worst[0].max(err), worst[1].max(yaw_err), worst[2].max(size_err)];
        }
    }
    eprintln!(
        "retrieved {retrieved} of {instances_total}; worst centre {:.1} %, yaw {:.1} degrees, size {:.1} %",
        worst[0] * 100.0,
        worst[1],
        worst[2] * 100.0
    );
    // The scenes hold what the acceptance names: objects cut by the border, one hidden by at least 30 %.
    assert!(cut_count >= 2 && max_hidden >= 0.3, "{cut_count} cut, at most {:.0} % hidden", max_hidden * 100.0);
    assert!(retrieved * 5 >= instances_total * 4, "retrieval {retrieved} of {instances_total}");
    assert!(worst[0] < 0.05 && worst[1] < 10.0 && worst[2] < 0.1, "{worst:?}");
}
