//! The top of `report.html`: the photo, the final render and their difference side by side, the evaluation
//! against a truth when the run had one (`--set truth=...`), the fitted emitters (lights, windows) with
//! their radiances and sky gradients, the lights each fit removed or the placement merged (`lights_removed` in
//! result.json), a window added on a wall the photo does not show (`unseen_window`), whether the windows'
//! daylight was shaped by direction (`window_sky`), the materials and
//! the decisions behind them (`material_table`), and
//! the camera's side of the photo: its exposure and white balance, which psdr absorbs into the lights (the
//! light-scale search's factor per channel), and the share of clipped pixels the photometric fits left out.

use super::html::ReportImage;
use crate::base::Image;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use std::path::Path;

/// The report shows images at most this many pixels on their long side.
const LONG_SIDE: usize = 1024;

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SummaryTable {
    pub title: String,
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub images: Vec<ReportImage>,
    pub tables: Vec<SummaryTable>,
}

/// The summary of a finished run: images written into `out/report/`, tables from the scene and the recorded
/// values. Whatever cannot be made (no render, a photo of another size) is left out, never an error.
pub fn build_summary(out: &Path, photo: &Path, render: &Path, scene: &Scene, recorded: &Map<String, Value>) -> Summary {
    let mut summary = Summary::default();
    let dir = out.join("report");
    let photo = crate::vision::load_photo(photo).ok();
    let render = crate::vision::load_photo(render).ok();
    if std::fs::create_dir_all(&dir).is_ok() {
        let mut shown = |label: &str, file: &str, img: &Image| {
            let small = shrink(img);
            let path = dir.join(file);
            if crate::output::write_png_srgb(&path, small.width as u32, small.height as u32, &small.data).is_ok() {
                summary.images.push(ReportImage { label: label.into(), path });
            }
        };
        if let Some(p) = &photo {
            shown("photo", "photo.png", p);
        }
        if let Some(r) = &render {
            shown("final render", "render.png", r);
        }
        if let Some(d) = photo.as_ref().zip(render.as_ref()).and_then(|(p, r)| difference(p, r)) {
            shown("|render - photo|", "difference.png", &d);
        }
    }
    if let Some(Value::Object(e)) = recorded.get("evaluation") {
        let mut rows = vec![];
        flatten("", e, 2, &mut rows);
        summary.tables.push(SummaryTable {
            // The image error's split says what more samples would remove (noise) and what they would not.
            title: "Evaluation against the truth (image: RMSE at 1/8 size over the photo's mean; its noise_rel_1_8 \
                    is the render's Monte Carlo noise, bias_rel_1_8 the rest)"
                .into(),
            header: vec!["quantity".into(), "value".into()],
            rows,
        });
        if let Some(Value::Array(parts)) = e.get("image").and_then(|i| i.get("by_surface_1_8")) {
            let rows = parts
                .iter()
                .map(|p| {
                    let pct = |k: &str| p[k].as_f64().map_or("-".into(), |v| format!("{:.1} %", 100.0 * v));
                    vec![p["surface"].as_str().unwrap_or("").into(), pct("share"), pct("rmse_rel")]
                })
                .collect();
            summary.tables.push(SummaryTable {
                title: "The image error by the truth's surfaces (each 1/8-size block's squared error shared by its \
                        pixels; the parts add in quadrature to the whole)"
                    .into(),
                header: ["surface", "share of the squared error", "its part of the relative RMSE"]
                    .map(String::from)
                    .to_vec(),
                rows,
            });
        }
    }
    let lights: Vec<Vec<String>> = scene
        .objects
        .iter()
        .filter_map(|o| {
            let e = o.emitter.as_ref()?;
            let (r, g) = (e.radiance, e.sky_gradient);
            let shape = if g == glam::Vec3::ZERO { "-".into() } else { format!("{:.2}, {:.2}, {:.2}", g.x, g.y, g.z) };
            Some(vec![o.name.clone(), format!("{:.3}", r.x), format!("{:.3}", r.y), format!("{:.3}", r.z), shape])
        })
        .collect();
    summary.tables.push(SummaryTable {
        title: format!("Emitters (lights and windows): {}", lights.len()),
        header: ["light", "radiance R", "G", "B", "sky gradient (R, G, B)"].map(String::from).to_vec(),
        rows: lights,
    });
    if let Some(w) = recorded.get("window_sky").filter(|w| w["windows"].as_array().is_some_and(|a| !a.is_empty())) {
        let pct = |k: &str| w[k].as_f64().map_or("-".into(), |v| format!("{:.2} %", 100.0 * v));
        let kept =
            if w["kept"].as_bool() == Some(true) { "kept" } else { "not kept (the gain is under the threshold)" };
        let rows = w["windows"]
            .as_array()
            .into_iter()
            .flatten()
            .zip(w["sky_gradient"].as_array().into_iter().flatten())
            .map(|(n, g)| {
                let g: Vec<String> =
                    g.as_array().into_iter().flatten().filter_map(Value::as_f64).map(|v| format!("{v:.2}")).collect();
                vec![
                    n.as_str().unwrap_or("").into(),
                    g.join(", "),
                    pct("relative_rms_as_they_were"),
                    pct("relative_rms_shaped"),
                    kept.into(),
                ]
            })
            .collect();
        summary.tables.push(SummaryTable {
            title: "Windows' daylight shaped by direction (radiance x (1 + g d_y): the sky over the ground)".into(),
            header: ["window", "fitted g (R, G, B)", "error uniform", "error shaped", "decision"]
                .map(String::from)
                .to_vec(),
            rows,
        });
    }
    summary.tables.extend(unseen_window_table(recorded));
    if let Some(Value::Array(fits)) = recorded.get("lights_removed") {
        let rows: Vec<Vec<String>> = fits
            .iter()
            .map(|f| {
                let names: Vec<&str> =
                    f["removed"].as_array().into_iter().flatten().filter_map(Value::as_str).collect();
                let pct = |k: &str| f[k].as_f64().map_or("-".into(), |v| format!("{:.1} %", 100.0 * v));
                vec![names.join(", "), f["candidates"].to_string(), pct("relative_rms_all"), pct("relative_rms_kept")]
            })
            .collect();
        summary.tables.push(SummaryTable {
            title: "Lights the fit removed (backward elimination; merged into a neighbour)".into(),
            header: ["removed", "of candidates", "error with all", "error with the rest"].map(String::from).to_vec(),
            rows,
        });
    }
    summary.tables.push(super::material_table::material_table(scene, recorded));
    let camera = camera_rows(photo.as_ref(), recorded);
    if !camera.is_empty() {
        summary.tables.push(SummaryTable {
            title: "The camera's side of the photo".into(),
            header: vec!["quantity".into(), "value".into()],
            rows: camera,
        });
    }
    summary
}

/// Exposure and white balance are not fitted apart: they are absorbed into the lights' radiances, whose common
/// scale per channel the light-scale search chose (a white light under a warm white balance fits as a warm
/// light); and the photo's clipped pixels, left out of every photometric fit.
fn camera_rows(photo: Option<&Image>, recorded: &Map<String, Value>) -> Vec<Vec<String>> {
    let mut rows = vec![];
    let chosen: Vec<f64> = recorded
        .get("light_scale")
        .and_then(|s| s["chosen"].as_array())
        .into_iter()
        .flatten()
        .filter_map(Value::as_f64)
        .collect();
    if let [r, g, b] = chosen[..] {
        rows.push(vec![
            "exposure x white balance, absorbed into the lights (their common scale R, G, B)".into(),
            format!("{r:.3}, {g:.3}, {b:.3}"),
        ]);
    }
    if let Some(p) = photo.filter(|p| p.channels == 3 && p.width > 0) {
        let unclipped = crate::vision::unclipped(&p.data, p.width);
        let clipped = unclipped.iter().filter(|&&u| u == 0.0).count();
        rows.push(vec![
            "photo pixels clipped or next to clipped (left out of the photometric fits)".into(),
            format!("{:.2} %", 100.0 * clipped as f64 / unclipped.len().max(1) as f64),
        ]);
    }
    rows
}

/// Writes |render - photo| to `path` with the photo brought to the render's size (a working size of it);
/// false when there is no photo at that size or the file cannot be written (a report without it, not an error).
pub fn write_difference(photo: &Path, render: &Image, path: &Path) -> bool {
    let Some(photo) = crate::vision::load_photo(photo).ok() else { return false };
    let Some(photo) = crate::vision::photo_at(&photo, render.width, render.height) else { return false };
    let Some(d) = difference(&photo, render) else { return false };
    let small = shrink(&d);
    crate::output::write_png_srgb(path, small.width as u32, small.height as u32, &small.data).is_ok()
}

/// At most LONG_SIDE pixels on the long side (an integer box filter).
fn shrink(img: &Image) -> Image {
    let k = img.width.max(img.height).div_ceil(LONG_SIDE).max(1);
    if k == 1 {
        return img.clone();
    }
    let (w, h, c) = (img.width / k, img.height / k, img.channels);
    let mut data = vec![0.0f32; w * h * c];
    for y in 0..h {
        for x in 0..w {
            for ch in 0..c {
                let mut sum = 0.0;
                for j in 0..k {
                    for i in 0..k {
                        sum += img.data[((y * k + j) * img.width + x * k + i) * c + ch];
                    }
                }
                data[(y * w + x) * c + ch] = sum / (k * k) as f32;
            }
        }
    }
    Image { width: w, height: h, channels: c, data }
}

/// Per pixel |render - photo| (linear), when both are RGB of one size.
fn difference(photo: &Image, render: &Image) -> Option<Image> {
    let same = (photo.width, photo.height, photo.channels) == (render.width, render.height, render.channels);
    if !same || photo.channels != 3 {
        return None;
    }
    let data = photo.data.iter().zip(&render.data).map(|(a, b)| (a - b).abs()).collect();
    Some(Image { width: photo.width, height: photo.height, channels: 3, data })
}

/// Numbers of a JSON object as table rows, `a.b` for nested ones down to `depth` levels; lists are skipped.
fn flatten(prefix: &str, v: &Map<String, Value>, depth: usize, rows: &mut Vec<Vec<String>>) {
    for (k, x) in v {
        let name = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
        match x {
            Value::Number(n) => {
                let f = n.as_f64().unwrap_or(f64::NAN);
                let text = if n.is_i64() || n.is_u64() { n.to_string() } else { format!("{f:.4}") };
                rows.push(vec![name, text]);
            }
            Value::Object(o) if depth > 1 => flatten(&name, o, depth - 1, rows),
            _ => {}
        }
    }
}

/// The windows tried on the walls the photo does not show (`unseen_window`) and the one added, if any.
fn unseen_window_table(recorded: &Map<String, Value>) -> Option<SummaryTable> {
    let u = recorded.get("unseen_window").filter(|u| u["tried"].as_array().is_some_and(|a| !a.is_empty()))?;
    let pct = |v: &Value| v.as_f64().map_or("-".into(), |v| format!("{:.2} %", 100.0 * v));
    let added = u["added"].as_str().unwrap_or("");
    let rows = u["tried"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|t| {
            let name = t[0].as_str().unwrap_or("");
            let decision = if name == added { "added" } else { "-" };
            vec![name.into(), pct(&t[1]), decision.into()]
        })
        .collect();
    Some(SummaryTable {
        title: format!(
            "Windows on the walls the photo does not show, tried beside the chosen lights (their error {}; one is \
             added where it lowers that by the removal threshold): {}",
            pct(&u["relative_rms_before"]),
            if added.is_empty() { "none added" } else { added }
        ),
        header: ["window", "error with it", "decision"].map(String::from).to_vec(),
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shrink_averages_boxes_and_difference_needs_one_size() {
        let img = Image { width: 2048, height: 4, channels: 1, data: (0..2048 * 4).map(|i| (i % 2) as f32).collect() };
        let s = shrink(&img);
        assert_eq!((s.width, s.height), (1024, 2));
        assert!(s.data.iter().all(|&v| (v - 0.5).abs() < 1e-6), "each 2x2 box holds two 0s and two 1s");
        let a = Image { width: 2, height: 1, channels: 3, data: vec![0.5; 6] };
        let b = Image { width: 2, height: 1, channels: 3, data: vec![0.2; 6] };
        assert!(difference(&a, &b).unwrap().data.iter().all(|&v| (v - 0.3).abs() < 1e-6));
        assert!(difference(&a, &shrink(&img)).is_none());
    }

    #[test]
    fn the_camera_rows_state_the_absorbed_exposure_and_the_clipped_share() {
        let recorded: Map<String, Value> =
            serde_json::from_value(serde_json::json!({"light_scale": {"chosen": [0.5, 1.0, 2.0]}})).unwrap();
        // An 8-bit photo (values on the sRGB steps) with its top-left pixel at white.
        let mut data: Vec<f32> = (0..16 * 3).map(|i| crate::base::srgb_to_linear((i % 200) as f32 / 255.0)).collect();
        data[..3].fill(1.0);
        let photo = Image { width: 4, height: 4, channels: 3, data };
        let rows = camera_rows(Some(&photo), &recorded);
        assert_eq!(rows[0][1], "0.500, 1.000, 2.000");
        // The white pixel and its three neighbours in the 4x4 photo.
        assert_eq!(rows[1][1], "25.00 %");
        assert!(camera_rows(None, &Map::new()).is_empty());
    }

    #[test]
    fn the_unseen_windows_table_marks_the_one_added() {
        let recorded: Map<String, Value> = serde_json::from_value(serde_json::json!({"unseen_window": {
            "tried": [["light_window_wall_x0_0", 0.2], ["light_window_wall_x0_1", 0.25]],
            "relative_rms_before": 0.25, "added": "light_window_wall_x0_0", "relative_rms_after": 0.2}}))
        .unwrap();
        let t = unseen_window_table(&recorded).unwrap();
        assert!(t.title.ends_with("light_window_wall_x0_0") && t.title.contains("25.00 %"), "{}", t.title);
        assert_eq!(t.rows[0], vec!["light_window_wall_x0_0".to_string(), "20.00 %".into(), "added".into()]);
        assert_eq!(t.rows[1][2], "-");
        assert!(unseen_window_table(&Map::new()).is_none());
    }

    #[test]
    fn nested_numbers_become_rows() {
        let v: Value = serde_json::json!({"image": {"ssim": 0.5, "deep": {"x": 1}}, "objects_found": 5, "list": [1]});
        let mut rows = vec![];
        flatten("", v.as_object().unwrap(), 2, &mut rows);
        assert_eq!(
            rows,
            vec![vec!["image.ssim".to_string(), "0.5000".into()], vec!["objects_found".into(), "5".into()]]
        );
    }
}
