//! `report.html`: one self-contained page per run (images embedded as base64 PNG, charts as inline SVG, no
//! scripts), readable offline: per stage its images, loss curves, parameter trajectories, timings and events.

use super::chart::{esc, Point, Series, XyChart};
use crate::error::{Error, Result};
use crate::optim::IterationRecord;
use base64::Engine as _;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RunReport {
    pub title: String,
    pub script: String,
    pub photo: String,
    pub command: String,
    pub seed: u64,
    /// Images shown outside any stage (the photo, targets): shown beside every stage's own images.
    pub images: Vec<ReportImage>,
    pub stages: Vec<StageReport>,
    pub total_seconds: f64,
    pub credits: Vec<String>,
    pub notes: Vec<String>,
    /// The page's top: photo, render and difference; evaluation; lights.
    #[serde(default)]
    pub summary: super::summary::Summary,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StageReport {
    pub index: usize,
    pub name: String,
    pub seconds: f64,
    /// "done", "loaded" (finished in an earlier run), "running" or "failed: ...".
    pub status: String,
    pub images: Vec<ReportImage>,
    pub optimizations: Vec<OptimizationReport>,
    /// Where the stage's time went: its steps (unit renders, searches, optimisations, saving) and seconds.
    #[serde(default)]
    pub phases: Vec<(String, f64)>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReportImage {
    pub label: String,
    /// A PNG on disk, embedded when the page is written.
    pub path: PathBuf,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OptimizationReport {
    pub label: String,
    pub iterations: Vec<IterationRecord>,
    pub events: Vec<String>,
    /// Parameter paths, in the order of `IterationRecord::values`.
    pub params: Vec<String>,
}

/// A stage's steps by label, in the order each first ran, with how often it ran and its total seconds (a
/// search repeats its unit renders per candidate; one row each would bury the stage's shape).
fn phase_totals(phases: &[(String, f64)]) -> Vec<(&str, usize, f64)> {
    let mut out: Vec<(&str, usize, f64)> = vec![];
    for (label, t) in phases {
        match out.iter_mut().find(|p| p.0 == label) {
            Some(p) => {
                p.1 += 1;
                p.2 += t;
            }
            None => out.push((label, 1, *t)),
        }
    }
    out
}

/// Components of a parameter shown in its trajectory chart.
const MAX_COMPONENTS: usize = 12;

/// What each component of a parameter is, and its colour where the colour says it (R, G, B in red, green,
/// blue): by the parameter's last path segment (`material/wall/albedo`, `object/sofa/translation`).
fn component_names(path: &str, n: usize) -> Vec<(String, Option<&'static str>)> {
    let last = path.rsplit('/').next().unwrap_or(path);
    let colour = ["albedo", "radiance", "tint", "colour", "color", "emission"].iter().any(|c| last.contains(c));
    let axes = ["translation", "position", "scale", "size", "rotation", "normal", "direction"]
        .iter()
        .any(|c| last.contains(c));
    (0..n)
        .map(|k| match (colour, axes, n, k) {
            (true, _, 3, _) => (["R", "G", "B"][k].to_string(), Some(["#d62728", "#2ca02c", "#1f77b4"][k])),
            (_, true, 3 | 4, _) => (["x", "y", "z", "w"][k].to_string(), None),
            (_, _, 1, _) => (last.to_string(), None),
            _ => (format!("[{k}]"), None),
        })
        .collect()
}

fn optimization_html(o: &OptimizationReport) -> String {
    let mut s = String::new();
    let _ = write!(s, "<h3>{}</h3>", esc(&o.label));
    // An optimisation that ends worse than it started is worth a line of its own.
    let (first, last) = (o.iterations.first().map(|r| r.loss), o.iterations.last().map(|r| r.loss));
    if let (Some(a), Some(b)) = (first, last) {
        if b > a {
            let _ = write!(
                s,
                "<p class=\"warn\">ended above its first loss: {a:.4} &rarr; {b:.4} (+{:.1} %)</p>",
                100.0 * (b - a) / a.abs().max(1e-30)
            );
        }
    }
    let log = o.iterations.iter().all(|r| r.loss > 0.0 || r.loss.is_nan());
    let mut loss = XyChart::new("loss", "iteration", if log { "loss (log scale)" } else { "loss" });
    (loss.log_y, loss.legend_right) = (log, true);
    loss.series
        .push(Series::line("total", o.iterations.iter().map(|r| Point::new(r.iteration as f64, r.loss)).collect()));
    let term_names: Vec<String> =
        o.iterations.first().map(|r| r.terms.iter().map(|t| t.0.clone()).collect()).unwrap_or_default();
    for (k, name) in term_names.iter().enumerate() {
        let points =
            o.iterations.iter().filter_map(|r| r.terms.get(k).map(|t| Point::new(r.iteration as f64, t.1))).collect();
        loss.series.push(Series::line(name.clone(), points));
    }
    s.push_str("<div class=\"charts\">");
    s.push_str(&loss.svg());
    for (p, name) in o.params.iter().enumerate() {
        let n = o.iterations.iter().filter_map(|r| r.values.get(p)).map(Vec::len).max().unwrap_or(0);
        if n == 0 {
            continue;
        }
        let title = if n > MAX_COMPONENTS { format!("{name} (first {MAX_COMPONENTS} of {n})") } else { name.clone() };
        let mut c = XyChart::new(&title, "iteration", "value");
        c.legend_right = true;
        for (k, (label, colour)) in component_names(name, n).into_iter().take(MAX_COMPONENTS).enumerate() {
            let points = o
                .iterations
                .iter()
                .filter_map(|r| {
                    r.values.get(p).and_then(|v| v.get(k)).map(|v| Point::new(r.iteration as f64, *v as f64))
                })
                .collect();
            let series = Series::line(label, points);
            c.series.push(match colour {
                Some(col) => series.color(col),
                None => series,
            });
        }
        s.push_str(&c.svg());
    }
    s.push_str("</div>");
    let sum = |f: fn(&IterationRecord) -> f64| o.iterations.iter().map(f).sum::<f64>();
    let parts = [
        ("render", sum(|r| r.seconds_render)),
        ("loss", sum(|r| r.seconds_loss)),
        ("backward", sum(|r| r.seconds_backward)),
        ("step", sum(|r| r.seconds_step)),
    ];
    let n = o.iterations.len().max(1) as f64;
    let total: f64 = parts.iter().map(|p| p.1).sum();
    s.push_str("<table><tr><th>phase</th><th>total s</th><th>ms / iteration</th></tr>");
    for (name, t) in parts {
        let _ = write!(s, "<tr><td>{name}</td><td>{t:.2}</td><td>{:.1}</td></tr>", t / n * 1e3);
    }
    let rate = if total > 0.0 { o.iterations.len() as f64 / total } else { 0.0 };
    let _ = write!(
        s,
        "<tr><td>all</td><td>{total:.2}</td><td>{:.1}</td></tr></table><p>{} iterations, {rate:.2} iterations/s</p>",
        total / n * 1e3,
        o.iterations.len()
    );
    if !o.events.is_empty() {
        s.push_str("<ul class=\"events\">");
        for e in &o.events {
            let _ = write!(s, "<li>{}</li>", esc(e));
        }
        s.push_str("</ul>");
    }
    s
}

fn image_html(img: &ReportImage) -> String {
    match std::fs::read(&img.path) {
        Ok(bytes) => format!(
            "<figure><img src=\"data:image/png;base64,{}\" alt=\"{l}\"><figcaption>{l}</figcaption></figure>",
            base64::engine::general_purpose::STANDARD.encode(bytes),
            l = esc(&img.label)
        ),
        Err(_) => format!(
            "<figure><figcaption>{}: missing {}</figcaption></figure>",
            esc(&img.label),
            esc(&img.path.display().to_string())
        ),
    }
}

/// The page's HTML.
pub fn report_html(r: &RunReport) -> String {
    let mut s = String::from("<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>");
    s.push_str(&esc(&r.title));
    s.push_str(
        "</title><style>body{font-family:sans-serif;margin:1.5em;max-width:1400px}figure{display:inline-block;\
         margin:4px}img{image-rendering:pixelated;min-width:256px}.charts svg{margin:4px;border:1px solid #ddd}\
         table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px;text-align:right}\
         .events li,.warn{color:#a40}</style></head><body>",
    );
    let _ = write!(
        s,
        "<h1>{}</h1><p>command: <code>{}</code><br>script: {} &middot; photo: {} &middot; seed {} &middot; {:.1} s</p>",
        esc(&r.title),
        esc(&r.command),
        esc(&r.script),
        esc(&r.photo),
        r.seed,
        r.total_seconds
    );
    if !r.summary.images.is_empty() || !r.summary.tables.is_empty() {
        s.push_str("<h2>Summary</h2>");
        for img in &r.summary.images {
            s.push_str(&image_html(img));
        }
        s.push_str("<div>");
        for t in &r.summary.tables {
            let _ = write!(
                s,
                "<table style=\"display:inline-table;vertical-align:top;margin:4px\"><caption>{}</caption><tr>",
                esc(&t.title)
            );
            for h in &t.header {
                let _ = write!(s, "<th>{}</th>", esc(h));
            }
            s.push_str("</tr>");
            for row in &t.rows {
                s.push_str("<tr>");
                for (k, cell) in row.iter().enumerate() {
                    let align = if k == 0 { " style=\"text-align:left\"" } else { "" };
                    let _ = write!(s, "<td{align}>{}</td>", esc(cell));
                }
                s.push_str("</tr>");
            }
            s.push_str("</table>");
        }
        s.push_str("</div><h2>Stages</h2>");
    }
    if !r.stages.is_empty() {
        s.push_str("<table><tr><th>stage</th><th>status</th><th>seconds</th><th>share</th></tr>");
        for st in &r.stages {
            let share = 100.0 * st.seconds / r.total_seconds.max(1e-9);
            let _ = write!(
                s,
                "<tr><td>{:02} {}</td><td>{}</td><td>{:.1}</td><td>{share:.0} %</td></tr>",
                st.index,
                esc(&st.name),
                esc(&st.status),
                st.seconds
            );
        }
        let _ = write!(s, "<tr><td>run</td><td></td><td>{:.1}</td><td></td></tr></table>", r.total_seconds);
    }
    for st in &r.stages {
        let _ = write!(
            s,
            "<h2>{:02} {} <small>({}, {:.1} s)</small></h2>",
            st.index,
            esc(&st.name),
            esc(&st.status),
            st.seconds
        );
        for img in r.images.iter().chain(&st.images) {
            s.push_str(&image_html(img));
        }
        if !st.phases.is_empty() {
            // Every second of the stage: its steps, and what no step covered (setup, small steps).
            let covered: f64 = st.phases.iter().map(|p| p.1).sum();
            s.push_str("<table><tr><th>step</th><th>seconds</th></tr>");
            for (label, count, t) in phase_totals(&st.phases) {
                let label = if count > 1 { format!("{label} (x{count})") } else { label.to_string() };
                let _ = write!(s, "<tr><td style=\"text-align:left\">{}</td><td>{t:.1}</td></tr>", esc(&label));
            }
            let _ = write!(
                s,
                "<tr><td style=\"text-align:left\">other</td><td>{:.1}</td></tr></table>",
                (st.seconds - covered).max(0.0)
            );
        }
        for o in &st.optimizations {
            s.push_str(&optimization_html(o));
        }
    }
    if !r.notes.is_empty() {
        s.push_str("<h2>Notes</h2><ul>");
        for n in &r.notes {
            let _ = write!(s, "<li>{}</li>", esc(n));
        }
        s.push_str("</ul>");
    }
    if !r.credits.is_empty() {
        s.push_str("<h2>Credits</h2><ul>");
        for c in &r.credits {
            let _ = write!(s, "<li>{}</li>", esc(c));
        }
        s.push_str("</ul>");
    }
    s.push_str("</body></html>\n");
    s
}

/// Writes the page atomically.
pub fn write_report(report: &RunReport, path: &Path) -> Result<()> {
    let html = report_html(report);
    crate::output::write_atomically(path, |tmp| std::fs::write(tmp, &html).map_err(|e| Error::io(tmp, e)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_embeds_images_escapes_text_and_writes_atomically() {
        let dir = std::env::temp_dir().join(format!("psdr-report-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png = dir.join("a.png");
        crate::output::write_png_srgb(&png, 2, 1, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]).unwrap();
        let rec = |i: usize, loss: f64| IterationRecord {
            iteration: i,
            loss,
            terms: vec![("mask".into(), loss / 2.0)],
            seconds_render: 0.01,
            values: vec![vec![i as f32, 1.0]],
            ..Default::default()
        };
        let report = RunReport {
            title: "t".into(),
            stages: vec![
                StageReport {
                    index: 1,
                    name: "<script>alert(1)</script>".into(),
                    status: "done".into(),
                    images: vec![ReportImage { label: "final".into(), path: png.clone() }],
                    optimizations: vec![OptimizationReport {
                        label: "fit".into(),
                        iterations: vec![rec(0, 1.0), rec(1, f64::NAN), rec(2, 0.1)],
                        events: vec!["loss rose & fell".into()],
                        params: vec!["object/a/translation".into()],
                    }],
                    ..Default::default()
                },
                StageReport {
                    index: 2,
                    name: "b".into(),
                    images: vec![ReportImage { label: "x".into(), path: dir.join("missing.png") }],
                    ..Default::default()
                },
            ],
            ..Default::default()
        };
        let out = dir.join("report.html");
        write_report(&report, &out).unwrap();
        let html = std::fs::read_to_string(&out).unwrap();
        assert!(!html.contains("<script>") && html.contains("&lt;script&gt;"));
        assert!(html.contains("missing") && html.contains("loss rose &amp; fell"));
        assert!(!html.contains("NaN"));
        let b64 = html.split("base64,").nth(1).unwrap().split('"').next().unwrap();
        let bytes = base64::engine::general_purpose::STANDARD.decode(b64).unwrap();
        assert_eq!(bytes, std::fs::read(&png).unwrap());
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().contains(".partial"))
            .collect();
        assert!(leftovers.is_empty());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn components_are_named_and_a_rising_loss_is_said() {
        assert_eq!(component_names("material/wall/albedo", 3)[0], ("R".to_string(), Some("#d62728")));
        assert_eq!(component_names("object/sofa/translation", 3)[2].0, "z");
        assert_eq!(component_names("object/sofa/rotation", 4)[3].0, "w");
        assert_eq!(component_names("object/sofa/vertices", 5)[4].0, "[4]");
        assert_eq!(component_names("object/chair/yaw", 1)[0].0, "yaw");
        let phases = [("a".to_string(), 1.0), ("b".to_string(), 2.0), ("a".to_string(), 0.5)];
        assert_eq!(phase_totals(&phases), vec![("a", 2, 1.5), ("b", 1, 2.0)]);
        let rec = |i: usize, loss: f64| IterationRecord {
            iteration: i,
            loss,
            values: vec![vec![0.1, 0.2, 0.3]],
            ..Default::default()
        };
        let rising = OptimizationReport {
            label: "objects".into(),
            iterations: vec![rec(0, 0.038), rec(1, 0.041)],
            params: vec!["material/wall/albedo".into()],
            ..Default::default()
        };
        let html = optimization_html(&rising);
        assert!(html.contains("ended above its first loss: 0.0380 &rarr; 0.0410 (+7.9 %)"), "{html}");
        assert!(html.contains(">R<") && html.contains("#d62728"), "components named R, G, B in their colours");
        let falling = OptimizationReport { iterations: vec![rec(0, 0.041), rec(1, 0.038)], ..rising };
        assert!(!optimization_html(&falling).contains("ended above"));
        // The summary's tables and images are at the top of the page.
        let report = RunReport {
            summary: super::super::summary::Summary {
                images: vec![],
                tables: vec![super::super::summary::SummaryTable {
                    title: "Emitters (lights and windows): 1".into(),
                    header: vec!["light".into(), "radiance R".into()],
                    rows: vec![vec!["light_0".into(), "2.500".into()]],
                }],
            },
            stages: vec![StageReport { name: "room".into(), ..Default::default() }],
            ..Default::default()
        };
        let page = report_html(&report);
        let (summary, stages) = (page.find("Emitters (lights").unwrap(), page.find("<h2>Stages</h2>").unwrap());
        assert!(summary < stages && page.contains("<td style=\"text-align:left\">light_0</td><td>2.500</td>"));
    }
}
