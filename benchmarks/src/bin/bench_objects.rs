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

use glam::{Quat, Vec3};
use psdr::backend::CpuBackend;
use psdr::db::ModelSet;
use psdr::render::{render_cpu, SceneData};
use psdr::report::chart::{grid, Point, Series, XyChart};
use psdr::scene::{load_obj, save_scene, Material, Object, Pose, Scene};
use psdr::script::{run_script, RunOptions, ScriptRun};
use psdr::stages::{init_objects, ObjectInitOptions, ObjectPlacement};
use psdr::vision::{canonical_class, Instance, Instances};
use psdr_tests::furniture::{refine_script, write_model_set};
use psdr_tests::rooms::{room_scene, RoomSpec};
use std::path::Path;
use std::time::Instant;

struct Item {
    model: &'static str,
    at: Vec3,
    yaw: f32,
}

fn symmetry(class: &str) -> f32 {
    match class {
        "table" => 180.0,
        "lamp" => 90.0,
        _ => 360.0,
    }
}

fn first(v: &serde_json::Value) -> f32 {
    v.as_array().map_or_else(|| v.as_f64().unwrap_or(f64::NAN), |a| a[0].as_f64().unwrap_or(f64::NAN)) as f32
}

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
        let (room, mut classes) = room_scene(&r, &[], false, iw, ih);
        let mut truth: Scene = room.clone();
        truth.materials.push(Material::diffuse("wood", Vec3::splat(0.4)));
        let m = truth.materials.len() - 1;
        for it in items {
            let mut parts = load_obj(&db_dir.join(format!("{}.obj", it.model)))?.parts;
            parts.iter_mut().for_each(|p| p.material = m);
            truth.objects.push(Object {
                name: it.model.into(),
                parts,
                pose: Pose {
                    translation: it.at,
                    rotation: Quat::from_rotation_y(it.yaw.to_radians()),
                    scale: Vec3::ONE,
                },
                emitter: None,
            });
            classes.push(it.model.split('_').next().unwrap_or("object").into());
        }
        truth.settings.max_depth = 1;
        let f = render_cpu(&SceneData::build(&truth)?, &truth.settings, &|_, _| {});
        let n = (iw * ih) as usize;
        let mut inst = Instances { width: iw as usize, height: ih as usize, ids: vec![0; n], instances: vec![] };
        for (o, class) in classes.iter().enumerate() {
            let pixels = f.object_id.iter().filter(|&&i| i == o as u32).count();
            // Object 6 is the test room's ceiling light.
            if pixels == 0 || o == 6 {
                continue;
            }
            let id = o as u16 + 1;
            for (p, &i) in f.object_id.iter().enumerate() {
                if i == o as u32 {
                    inst.ids[p] = id;
                }
            }
            let (c, kind) = canonical_class(class);
            inst.instances.push(Instance { id, label: Some(class.clone()), class: c.into(), kind, pixels });
        }
        let t = Instant::now();
        let (placed, skipped) = init_objects(&room, &f.depth, &inst, &db, &ObjectInitOptions::default());
        let init_s = t.elapsed().as_secs_f64();
        println!("{label}: {} placed in {init_s:.2} s, skipped {skipped:?}", placed.len());
        let sdir = dir.join(label.replace(' ', "_"));
        std::fs::create_dir_all(&sdir)?;
        let mut start = room.clone();
        let mut names = vec![];
        for (p, mut o) in placed.clone() {
            start.materials.push(Material::diffuse(&p.name, Vec3::splat(0.5)));
            let mi = start.materials.len() - 1;
            o.parts.iter_mut().for_each(|q| q.material = mi);
            start.objects.push(o);
            let mask: Vec<f32> = inst.ids.iter().map(|&v| (v == p.instance) as u32 as f32).collect();
            psdr::output::write_exr_channels(
                &sdir.join(format!("{}.mask.exr", p.name)),
                iw,
                ih,
                &[("Y".into(), mask)],
            )?;
            names.push(p.name.clone());
        }
        start.settings.max_depth = 1;
        psdr::output::write_exr_channels(&sdir.join("depth.exr"), iw, ih, &[("Z".into(), f.depth.clone())])?;
        psdr::output::write_png_srgb(&sdir.join("photo.png"), iw, ih, &f.radiance)?;
        save_scene(&start, &sdir.join("start.json"))?;
        let errors = |poses: &serde_json::Value, placed: &[(ObjectPlacement, Object)]| -> (usize, [f32; 3], f32) {
            let (mut retrieved, mut worst, mut centres) = (0, [0.0f32; 3], vec![]);
            for it in items.iter() {
                let class = it.model.split('_').next().unwrap_or("object");
                let Some(o) = truth.object_index(it.model) else { continue };
                let Some((p, _)) = placed.iter().find(|(p, _)| p.instance as usize == o + 1) else { continue };
                retrieved += usize::from(p.chosen.model == it.model);
                let q = &poses[&p.name];
                let t: Vec<f32> =
                    q["t"].as_array().map_or(vec![], |a| a.iter().map(|v| v.as_f64().unwrap_or(0.0) as f32).collect());
                let centre = if t.len() == 3 { Vec3::new(t[0], t[1], t[2]) } else { Vec3::from(p.translation) };
                let err = (centre - it.at).length() / (it.at - r.cam).length();
                let sym = symmetry(class);
                let yaw = first(&q["yaw"]).to_degrees();
                let yaw_err = (((yaw - it.yaw).rem_euclid(sym) + sym / 2.0).rem_euclid(sym) - sym / 2.0).abs();
                let chosen = db.models.iter().find(|m| m.name == p.chosen.model);
                let truth_model = db.models.iter().find(|m| m.name == it.model);
                let size_err = match (chosen, truth_model) {
                    (Some(c), Some(tm)) => (c.size().y * first(&q["scale"]) / tm.size().y - 1.0).abs(),
                    _ => f32::NAN,
                };
                worst = [worst[0].max(err), worst[1].max(yaw_err), worst[2].max(size_err)];
                centres.push(err);
            }
            centres.sort_by(f32::total_cmp);
            (retrieved, worst, centres.get(centres.len() / 2).copied().unwrap_or(f32::NAN))
        };
        let (mut centre_pts, mut yaw_pts) = (vec![], vec![]);
        for iters in [0usize, 10, 20, 40, 80] {
            std::fs::write(sdir.join("refine.rhai"), refine_script(&names, iters))?;
            let out = sdir.join(format!("out{iters}"));
            let t = Instant::now();
            run_script(
                ScriptRun {
                    script: sdir.join("refine.rhai"),
                    photo: sdir.join("photo.png"),
                    out: out.clone(),
                    sets: vec![],
                    options: RunOptions { quiet: true, preview_spp: 1, ..Default::default() },
                    command: "bench_objects".into(),
                },
                Box::new(CpuBackend),
            )?;
            let secs = t.elapsed().as_secs_f64();
            let res: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("result.json"))?)?;
            let (retrieved, worst, median) = errors(&res["recorded"]["poses"], &placed);
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
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/objects.csv");
    std::fs::create_dir_all(out.parent().unwrap())?;
    std::fs::write(&out, &csv)?;
    std::fs::write(out.with_extension("svg"), svg + "\n")?;
    println!("wrote {} and {}", out.display(), out.with_extension("svg").display());
    std::fs::remove_dir_all(&dir).ok();
    Ok(())
}
