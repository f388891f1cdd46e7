//! The object stage's speed and accuracy on furnished rooms rendered by psdr (256x192): rooms with 3 and 6
//! objects from a generated model set (six variants per class: the true model and five same-class distractors),
//! including a lamp on a table, objects cut by the image border and objects occluded by others. From the
//! rendered depth, instance masks and classes (and the true room), `init_objects` retrieves and places every
//! object; the poses are then refined together with the loss of scripts/room.rhai's object stage for 0, 10, 20,
//! 40 and 80 iterations. Reports retrieval accuracy, the worst centre (% of camera distance), yaw (modulo the
//! model's symmetry) and size errors against wall time, and seconds per iteration.
//!
//! Writes benchmarks/results/objects.csv and objects.svg:
//! `cargo run -p psdr-benchmarks --release --bin bench_objects`.

use glam::Vec3;
use psdr::db::ModelSet;
use psdr::report::chart::{grid, Point, Series, XyChart};
use psdr::scene::Object;
use psdr::stages::{init_objects, ObjectInitOptions, ObjectPlacement};
use psdr_tests::furniture::{
    first_number, furnished_room, observed_symmetry, run_refinement, write_model_set, write_refinement_inputs, Item,
};
use psdr_tests::rooms::{room_scene, RoomSpec};
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let dir = std::env::temp_dir().join(format!("psdr-bench-objects-{}", std::process::id()));
    let db_dir = dir.join("db");
    write_model_set(&db_dir);
    let db = ModelSet::from_folder(&db_dir)?;
    let r = RoomSpec { w: 6.0, d: 6.0, h: 2.8, cam: Vec3::new(0.0, 1.6, 2.6), yaw: 0.0, pitch: -18.0, fov: 60.0 };
    let scenarios: Vec<(&str, Vec<Item>)> = vec![
        (
            "3 objects",
            vec![
                Item { model: "sofa_2", at: Vec3::new(0.0, 0.0, -1.6), yaw: 0.0 },
                Item { model: "cabinet_1", at: Vec3::new(1.9, 0.0, -2.7), yaw: 0.0 },
                Item { model: "chair_0", at: Vec3::new(-1.2, 0.0, -0.4), yaw: -30.0 },
            ],
        ),
        (
            "6 objects",
            vec![
                Item { model: "sofa_0", at: Vec3::new(-0.6, 0.0, -2.2), yaw: 15.0 },
                Item { model: "table_0", at: Vec3::new(0.3, 0.0, -0.6), yaw: 10.0 },
                Item { model: "lamp_1", at: Vec3::new(0.6, 0.74, -0.7), yaw: 0.0 },
                Item { model: "chair_5", at: Vec3::new(-1.9, 0.0, 0.4), yaw: 70.0 },
                Item { model: "bookcase_0", at: Vec3::new(1.6, 0.0, -2.75), yaw: 0.0 },
                Item { model: "cabinet_4", at: Vec3::new(2.3, 0.0, -0.2), yaw: -90.0 },
            ],
        ),
    ];
    let (iw, ih) = (256u32, 192u32);
    let mut csv = String::from(
        "scenario,objects_placed,retrieved,iterations,seconds,s_per_iteration,init_s,worst_centre_pct,worst_yaw_deg,worst_size_pct,median_centre_pct\n",
    );
    let mut panels = vec![];
    for (label, items) in &scenarios {
        let (room, classes) = room_scene(&r, &[], false, iw, ih);
        let (truth, f, inst) = furnished_room(&room, &classes, items, &db_dir);
        let t = Instant::now();
        let (placed, skipped) = init_objects(&room, &f.depth, &inst, &db, &ObjectInitOptions::default());
        let init_s = t.elapsed().as_secs_f64();
        println!("{label}: {} placed in {init_s:.2} s, skipped {skipped:?}", placed.len());
        let sdir = dir.join(label.replace(' ', "_"));
        let names = write_refinement_inputs(&sdir, &room, &placed, &inst, &f);
        let errors = |poses: &serde_json::Value, placed: &[(ObjectPlacement, Object)]| -> (usize, [f32; 3], f32) {
            let (mut retrieved, mut worst, mut centres) = (0, [0.0f32; 3], vec![]);
            for (k, it) in items.iter().enumerate() {
                let Some(o) = truth.object_index(it.model) else { continue };
                let Some((p, _)) = placed.iter().find(|(p, _)| p.instance as usize == o + 1) else { continue };
                retrieved += usize::from(p.chosen.model == it.model);
                let q = &poses[&p.name];
                let t: Vec<f32> =
                    q["t"].as_array().map_or(vec![], |a| a.iter().map(|v| v.as_f64().unwrap_or(0.0) as f32).collect());
                let centre = if t.len() == 3 { Vec3::new(t[0], t[1], t[2]) } else { Vec3::from(p.translation) };
                let err = (centre - it.at).length() / (it.at - r.cam).length();
                let sym = observed_symmetry(&room, &classes, items, k, &db_dir, &f);
                let yaw = first_number(&q["yaw"]).to_degrees();
                let yaw_err = (((yaw - it.yaw).rem_euclid(sym) + sym / 2.0).rem_euclid(sym) - sym / 2.0).abs();
                let chosen = db.models.iter().find(|m| m.name == p.chosen.model);
                let truth_model = db.models.iter().find(|m| m.name == it.model);
                let size_err = match (chosen, truth_model) {
                    (Some(c), Some(tm)) => (c.size().y * first_number(&q["scale"]) / tm.size().y - 1.0).abs(),
                    _ => f32::NAN,
                };
                if yaw_err > 10.0 {
                    eprintln!("  {}: yaw {yaw:.1} against {} (modulo {sym})", it.model, it.yaw);
                }
                worst = [worst[0].max(err), worst[1].max(yaw_err), worst[2].max(size_err)];
                centres.push(err);
            }
            centres.sort_by(f32::total_cmp);
            (retrieved, worst, centres.get(centres.len() / 2).copied().unwrap_or(f32::NAN))
        };
        let (mut centre_pts, mut yaw_pts) = (vec![], vec![]);
        for iters in [0usize, 10, 20, 40, 80] {
            let t = Instant::now();
            let poses = run_refinement(&sdir, &names, iters);
            let secs = t.elapsed().as_secs_f64();
            let (retrieved, worst, median) = errors(&poses, &placed);
            let per = if iters > 0 { secs / iters as f64 } else { 0.0 };
            println!(
                "{label}, {iters:>2} iterations: {secs:6.1} s ({per:.3} s/iteration); retrieved {retrieved}/{}; worst centre {:.1} % (median {:.1} %), yaw {:.1} deg, size {:.1} %",
                items.len(),
                worst[0] * 100.0,
                median * 100.0,
                worst[1],
                worst[2] * 100.0
            );
            csv += &format!(
                "{label},{},{retrieved},{iters},{secs:.2},{per:.3},{init_s:.2},{:.2},{:.2},{:.2},{:.2}\n",
                placed.len(),
                worst[0] * 100.0,
                worst[1],
                worst[2] * 100.0,
                median * 100.0
            );
            centre_pts.push(Point::labelled(init_s + secs, (median * 100.0).max(0.01) as f64, iters.to_string()));
            yaw_pts.push(Point::labelled(init_s + secs, worst[1].max(0.01) as f64, iters.to_string()));
        }
        let mut chart =
            XyChart::new(&format!("{label} at {iw}x{ih}"), "seconds (initialisation + refinement)", "error");
        chart.log_y = true;
        chart.caption = "labels: refinement iterations".into();
        chart.series.push(Series::marked("median centre error (% of distance)", centre_pts));
        chart.series.push(Series::marked("worst yaw error (degrees)", yaw_pts));
        panels.push(chart);
    }
    let svg = grid(
        "Object stage: pose error against wall time (2 CPU cores)",
        "generated model set, 5 distractors per class; centre error median over objects, yaw worst (modulo symmetry)",
        &panels,
        2,
        &[],
    );
    psdr_benchmarks::write_results("objects", &csv, &svg)?;
    std::fs::remove_dir_all(&dir).ok();
    Ok(())
}
