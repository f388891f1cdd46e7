//! The observation estimators' speed against accuracy on rooms rendered by psdr (the tests' rooms: checker
//! floor, panelled walls, furniture boxes over 30 % of the floor, fov 45-75, pitch -20..5, yaw -25..25):
//! - the vanishing-point fov at several resolutions: wall time per photo, how many views it answers (the rest
//!   it reports as too few lines or a frontal view), the worst and median error of its answers, and the worst
//!   error had every estimate been taken (what the uncertainty gate protects against);
//! - relative depth (disparity, unknown scale and shift) made metric on the room's planes: wall time and the
//!   error of the room's proportions after `init_room`.
//!
//! Writes benchmarks/results/observe.csv and observe.svg:
//! `cargo run -p psdr-benchmarks --release --bin bench_observe [-- --views N]`.

use glam::Vec3;
use psdr::base::Intrinsics;
use psdr::loss::Image;
use psdr::render::{render_cpu, SceneData};
use psdr::report::chart::{grid, Point, Series, XyChart};
use psdr::stages::{init_room, RoomInitOptions};
use psdr::vision::calibrate_relative_depth;
use psdr::vision::{estimate_fov, DepthUnits, VanishingOptions};
use psdr_tests::rooms::{furniture, room_scene, RoomSpec};
use psdr_tests::SplitMix64;
use std::path::Path;
use std::time::Instant;

fn rooms(n: usize) -> Vec<RoomSpec> {
    let mut rng = SplitMix64(5);
    (0..n)
        .map(|_| {
            let (w, d, h) = (3.0 + 4.0 * rng.next_f32(), 3.0 + 4.0 * rng.next_f32(), 2.4 + 0.8 * rng.next_f32());
            RoomSpec {
                w,
                d,
                h,
                cam: Vec3::new((rng.next_f32() - 0.5) * 0.4 * w, 1.2 + 0.6 * rng.next_f32(), d / 2.0 - 0.2),
                yaw: (rng.next_f32() - 0.5) * 50.0,
                pitch: -20.0 + 25.0 * rng.next_f32(),
                fov: 45.0 + 30.0 * rng.next_f32(),
            }
        })
        .collect()
}

fn main() -> anyhow::Result<()> {
    let views: usize =
        std::env::args().skip_while(|a| a != "--views").nth(1).map(|v| v.parse()).transpose()?.unwrap_or(30);
    let specs = rooms(views);
    let mut csv =
        String::from("estimator,width,height,views,answered,seconds_per_view,median_err,worst_err,worst_err_ungated\n");
    let mut fov_chart = XyChart::new(
        &format!("Vanishing-point fov on {views} rendered rooms"),
        "seconds per photo (estimate only)",
        "fov error (degrees)",
    );
    fov_chart.log_x = true;
    fov_chart.caption = "labels: resolution and views answered; ungated: every estimate taken".into();
    let (mut worst_pts, mut median_pts, mut ungated_pts) = (vec![], vec![], vec![]);
    let mut cal_pts = vec![];
    for (iw, ih) in [(256u32, 192u32), (384, 288), (512, 384), (768, 576)] {
        let (mut errs, mut ungated, mut secs, mut cal_secs, mut ratio_errs) = (vec![], vec![], 0.0, 0.0, vec![]);
        for (i, r) in specs.iter().enumerate() {
            let boxes = furniture(r, 0.3, &mut SplitMix64(100 + i as u64));
            let (mut s, classes) = room_scene(r, &boxes, true, iw, ih);
            s.settings.spp = 32;
            let f = render_cpu(&SceneData::build(&s)?, &s.settings, &|_, _| {});
            let img = Image::new(iw as usize, ih as usize, 3, f.radiance.clone())?;
            let t = Instant::now();
            let est = estimate_fov(&img, &VanishingOptions::default());
            secs += t.elapsed().as_secs_f64();
            let ungated_est =
                estimate_fov(&img, &VanishingOptions { max_sigma_deg: f32::INFINITY, ..Default::default() });
            if let Ok(e) = est {
                errs.push((e.fov_y_deg - r.fov).abs() as f64);
            }
            if let Ok(e) = ungated_est {
                ungated.push((e.fov_y_deg - r.fov).abs() as f64);
            }
            // Disparity with an unknown scale and shift, made metric on the room's planes.
            let mask = |c: &str| -> Vec<bool> {
                f.object_id.iter().map(|&o| o != u32::MAX && classes[o as usize] == c).collect()
            };
            let (fl, wa, ce) = (mask("floor"), mask("wall"), mask("ceiling"));
            let disparity: Vec<f32> = f.depth.iter().map(|&z| if z > 0.0 { 2.0 / z + 0.4 } else { 0.0 }).collect();
            let k = Intrinsics::new(iw as usize, ih as usize, r.fov);
            let t = Instant::now();
            let cal = calibrate_relative_depth(&disparity, DepthUnits::Disparity, [&fl, &wa, &ce], &k, 1.5, 1);
            cal_secs += t.elapsed().as_secs_f64();
            if let Ok((metres, _)) = cal {
                if let Ok(e) = init_room(&metres, &fl, &wa, &ce, &k, &RoomInitOptions::default()) {
                    if e.walls_seen.iter().filter(|&&b| b).count() == 3 && e.ceiling_seen {
                        let x_measured = e.walls_seen[0] && e.walls_seen[1];
                        let measured = if x_measured { e.width } else { e.depth };
                        ratio_errs.push(((measured / e.height) / (r.w / r.h) - 1.0).abs() as f64 * 100.0);
                    }
                }
            }
        }
        let stat = |v: &mut Vec<f64>| -> (f64, f64) {
            v.sort_by(f64::total_cmp);
            (v.get(v.len() / 2).copied().unwrap_or(f64::NAN), v.last().copied().unwrap_or(f64::NAN))
        };
        let (median, worst) = stat(&mut errs);
        let (_, worst_ungated) = stat(&mut ungated);
        let per = secs / views as f64;
        println!(
            "{iw}x{ih}: fov answered {}/{views}, median {median:.2}, worst {worst:.2} degrees (ungated worst \
             {worst_ungated:.1}), {:.1} ms per photo",
            errs.len(),
            per * 1e3
        );
        csv += &format!(
            "vanishing_points,{iw},{ih},{views},{},{per:.4},{median:.3},{worst:.3},{worst_ungated:.3}\n",
            errs.len()
        );
        let label = format!("{iw}x{ih} {}/{views}", errs.len());
        worst_pts.push(Point::labelled(per, worst, label));
        median_pts.push(Point::new(per, median));
        ungated_pts.push(Point::new(per, worst_ungated));
        let (rmed, rworst) = stat(&mut ratio_errs);
        let cper = cal_secs / views as f64;
        println!(
            "{iw}x{ih}: disparity calibration {:.1} ms per photo, W/H error median {rmed:.3} %, worst {rworst:.3} % \
             over {} full views",
            cper * 1e3,
            ratio_errs.len()
        );
        csv +=
            &format!("disparity_calibration,{iw},{ih},{views},{},{cper:.4},{rmed:.4},{rworst:.4},\n", ratio_errs.len());
        cal_pts.push(Point::labelled(cper, rworst.max(1e-3), format!("{iw}x{ih}")));
    }
    fov_chart.series.push(Series::marked("worst answered", worst_pts));
    fov_chart.series.push(Series::marked("median answered", median_pts));
    fov_chart.series.push(Series::marked("worst, ungated", ungated_pts));
    fov_chart.log_y = true;
    let mut cal_chart = XyChart::new(
        "Disparity made metric: room proportions",
        "seconds per photo (shift search + scale)",
        "worst W/H error over full views (%)",
    );
    (cal_chart.log_x, cal_chart.log_y) = (true, true);
    cal_chart.series.push(Series::marked("disparity 2/z + 0.4", cal_pts));
    let svg = grid(
        "Observation estimators: speed against accuracy (2 CPU cores)",
        "rooms rendered by psdr, 32 spp; fov answers gated at a 1-degree bootstrap standard deviation",
        &[fov_chart, cal_chart],
        2,
        &[],
    );
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/observe.csv");
    std::fs::create_dir_all(out.parent().unwrap())?;
    std::fs::write(&out, &csv)?;
    std::fs::write(out.with_extension("svg"), svg + "\n")?;
    println!("wrote {} and {}", out.display(), out.with_extension("svg").display());
    Ok(())
}
