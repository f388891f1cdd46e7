//! The room from relative depth that is not affine in distance, on the real-furniture rooms of
//! `bench_real_rooms` (Sweet Home 3D models, 512x384, their true metric depth, masks and fov beside each
//! photo; run that bench first, or set BENCH_REAL_ROOMS_DIR). Each room's true depth is turned into relative
//! depth three ways: disparity (affine in inverse depth, what the affine calibration assumes), disparity
//! through a power of 0.6 (a network's compression of the far range) and the same with a 4 % bias across the
//! image. For each, the affine calibration's room (`calibrate_relative_depth` + `init_room`) and the choice
//! the observations make against the depth-free layout (`check_against_layout`): camera pitch error against
//! the room fitted to the true depth, median relative error of the metric depth over every pixel (the truth
//! at the 1.5 m camera-height prior's scale), which box was kept and why (both boxes' mask IoU), and seconds.
//! Writes benchmarks/results/room_layout.csv and room_layout.svg:
//! `cargo run -p psdr-benchmarks --release --bin bench_room_layout [-- --write-depth DIR]` (DIR gets each
//! room's distorted depth as ROOM.power06_bias.exr, for `psdr run ... --depth F --depth-units disparity`).

use psdr::base::Intrinsics;
use psdr::stages::{init_room, RoomInitOptions};
use psdr::vision::DepthUnits;
use psdr::vision::{calibrate_relative_depth, check_against_layout, load_depth, load_instances, load_photo};
use std::path::{Path, PathBuf};
use std::time::Instant;

fn median(mut v: Vec<f32>) -> f32 {
    v.sort_by(f32::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f32::NAN)
}

fn main() -> anyhow::Result<()> {
    let dir = std::env::var_os("BENCH_REAL_ROOMS_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/real_rooms"));
    let mut rooms: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(|e| anyhow::anyhow!("{}: {e} (run bench_real_rooms first to generate the rooms)", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("photo.png").is_file())
        .collect();
    rooms.sort();
    let args: Vec<String> = std::env::args().collect();
    let write_depth = args.iter().position(|a| a == "--write-depth").and_then(|i| args.get(i + 1)).map(PathBuf::from);
    let mut csv = String::from(
        "room,distortion,kept,box_iou_affine,box_iou_layout,frame,pitch_err_affine_deg,pitch_err_kept_deg,\
         depth_err_affine_pct,depth_err_kept_pct,rank_correlation,s_affine,s_layout\n",
    );
    let distortions: [(&str, f32, f32); 3] =
        [("affine", 1.0, 0.0), ("power 0.6", 0.6, 0.0), ("power 0.6 + 4 % bias", 0.6, 0.08)];
    let mut bars: Vec<(String, Vec<f64>)> = vec![];
    for room in &rooms {
        let name = room.file_name().and_then(|n| n.to_str()).unwrap_or("?").to_string();
        let photo = load_photo(&room.join("photo.png"))?;
        let truth = load_depth(&room.join("photo.depth.exr"), DepthUnits::Metres)?;
        let (inst, _) = load_instances(&room.join("photo.masks.png"), Some(&room.join("photo.labels.json")), None)?;
        let cam: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(room.join("photo.camera.json"))?)?;
        let fov = cam["fov_y_deg"].as_f64().unwrap_or(55.0) as f32;
        let (w, h) = (photo.width, photo.height);
        let k = Intrinsics::new(w, h, fov);
        let mask = |c: &str| inst.class_mask(c).into_iter().map(|v| v > 0.5).collect::<Vec<bool>>();
        let (floor, walls, ceiling) = (mask("floor"), mask("wall"), mask("ceiling"));
        let masks = [&floor[..], &walls[..], &ceiling[..]];
        let z = &truth.image.data;
        let true_room = init_room(z, &floor, &walls, &ceiling, &k, &RoomInitOptions::default())?;
        let scale = 1.5 / true_room.camera_height;
        let depth_err = |d: &[f32]| {
            median((0..d.len()).filter(|&i| z[i] > 0.0).map(|i| (d[i] - z[i] * scale).abs() / (z[i] * scale)).collect())
        };
        for (label, power, bias) in distortions {
            let rel: Vec<f32> = (0..w * h)
                .map(|i| {
                    let x = (i % w) as f32 / w as f32 - 0.5;
                    if z[i] > 0.0 {
                        (1.0 / z[i]).powf(power) * (1.0 + bias * x)
                    } else {
                        0.0
                    }
                })
                .collect();
            let t = Instant::now();
            let (affine, _) = calibrate_relative_depth(&rel, DepthUnits::Disparity, masks, &k, 1.5, 1)?;
            let affine_room = init_room(&affine, &floor, &walls, &ceiling, &k, &RoomInitOptions::default())?;
            let s_affine = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let l = check_against_layout(&photo, fov, &rel, DepthUnits::Disparity, &affine, masks, &k, 1.5);
            let s_layout = t.elapsed().as_secs_f64();
            let pitch_affine = (affine_room.pitch_deg - true_room.pitch_deg).abs();
            let (kept, iou_a, iou_l, frame, pitch_kept, depth_kept, rank) = match &l {
                Ok(l) => {
                    let c = &l.check;
                    let (pitch, depth) = match (&l.room, &l.metres) {
                        (Some(r), Some(m)) => ((r.pitch_deg - true_room.pitch_deg).abs(), depth_err(m)),
                        _ => (pitch_affine, depth_err(&affine)),
                    };
                    let kept = if c.used { "layout" } else { "affine" };
                    (kept, c.box_iou_affine, c.box_iou_layout, c.frame.clone(), pitch, depth, c.rank_correlation)
                }
                Err(e) => {
                    ("affine", f32::NAN, f32::NAN, format!("no layout: {e}"), pitch_affine, depth_err(&affine), None)
                }
            };
            let depth_affine = depth_err(&affine);
            println!(
                "{name} {label}: kept {kept} (IoU {iou_a:.3} / {iou_l:.3}, frame {frame}); pitch error {pitch_affine:.2} -> \
                 {pitch_kept:.2} deg; depth error {:.2} -> {:.2} %; {s_affine:.2} + {s_layout:.2} s",
                depth_affine * 100.0,
                depth_kept * 100.0
            );
            let frame_csv = frame.replace(',', ";");
            csv += &format!(
                "{name},{label},{kept},{iou_a:.4},{iou_l:.4},{frame_csv},{pitch_affine:.3},{pitch_kept:.3},{:.2},{:.2},{},{s_affine:.3},{s_layout:.3}\n",
                depth_affine * 100.0,
                depth_kept * 100.0,
                rank.map_or(String::new(), |r| format!("{r:.4}"))
            );
            if let Some(out) = write_depth.as_ref().filter(|_| label == "power 0.6 + 4 % bias") {
                std::fs::create_dir_all(out)?;
                let path = out.join(format!("{name}.power06_bias.exr"));
                psdr::output::write_exr_channels(&path, w as u32, h as u32, &[("Z".into(), rel.clone())])?;
            }
            if label == "power 0.6 + 4 % bias" {
                bars.push((name.clone(), vec![depth_affine as f64 * 100.0, depth_kept as f64 * 100.0]));
            }
        }
    }
    let svg = psdr::report::chart::BarChart {
        title: "Room from network-like depth (disparity^0.6, 4 % bias): median depth error per real room".into(),
        unit: "%".into(),
        series: vec!["affine calibration".into(), "kept (layout where it fits the masks better)".into()],
        rows: bars,
        stacked: false,
    }
    .svg();
    psdr_benchmarks::write_results("room_layout", &csv, &svg)?;
    Ok(())
}
