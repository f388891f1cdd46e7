//! SVG charts shared by the benchmarks and the run report: x-y charts (lines, markers, point labels, error
//! bars, reference lines; linear or log10 axes), horizontal bar charts (grouped or stacked), and a grid that
//! lays several charts out as panels of one SVG. Self-contained SVG strings (no external resources); points
//! that are not finite (or not positive on a log axis) are skipped, never drawn as NaN.

use std::fmt::Write as _;

/// The default series colours, in order.
pub const COLORS: [&str; 8] = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"];

/// Text escaped for SVG and HTML.
pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;").replace('\'', "&#39;")
}

/// A point, optionally labelled and with a symmetric error bar (± err in y).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub label: Option<String>,
    pub err: Option<f64>,
}

impl Point {
    pub fn new(x: f64, y: f64) -> Point {
        Point { x, y, ..Default::default() }
    }
    pub fn labelled(x: f64, y: f64, label: impl Into<String>) -> Point {
        Point { x, y, label: Some(label.into()), err: None }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Line {
    None,
    Solid,
    Dashed,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    pub name: String,
    /// None: the next default colour.
    pub color: Option<String>,
    pub points: Vec<Point>,
    pub line: Line,
    pub markers: bool,
    /// Listed in the legend.
    pub legend: bool,
}

impl Series {
    /// A solid line without markers.
    pub fn line(name: impl Into<String>, points: Vec<Point>) -> Series {
        Series { name: name.into(), color: None, points, line: Line::Solid, markers: false, legend: true }
    }
    /// A line with a marker at each point.
    pub fn marked(name: impl Into<String>, points: Vec<Point>) -> Series {
        Series { markers: true, ..Series::line(name, points) }
    }
    pub fn color(mut self, c: &str) -> Series {
        self.color = Some(c.to_string());
        self
    }
}

/// An x-y chart.
#[derive(Clone, Debug, PartialEq)]
pub struct XyChart {
    pub title: String,
    /// A smaller line under the title.
    pub caption: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    pub series: Vec<Series>,
    /// Horizontal dashed reference lines at these y values.
    pub hlines: Vec<f64>,
    pub width: f64,
    pub height: f64,
    /// Legend beside the plot (right) instead of inside it (top left).
    pub legend_right: bool,
}

/// Tick values for [lo, hi] in axis units (decades on a log axis).
fn ticks(lo: f64, hi: f64, log: bool) -> Vec<f64> {
    if log {
        // Decades, and 2 and 5 times them when the axis spans two decades or less.
        let steps: &[f64] = if hi - lo <= 2.0 { &[1.0, 2.0, 5.0] } else { &[1.0] };
        return (lo.floor() as i32..=hi.ceil() as i32)
            .flat_map(|e| steps.iter().map(move |m| f64::from(e) + m.log10()))
            .filter(|v| *v >= lo - 1e-9 && *v <= hi + 1e-9)
            .collect();
    }
    let span = (hi - lo).max(1e-300);
    let mag = 10f64.powf((span / 5.0).log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| span / s <= 6.0).unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() * step;
    (0..).map(|i| first + i as f64 * step).take_while(|v| *v <= hi + step * 1e-9).collect()
}

/// A number for a tick label.
pub fn fmt_num(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-2 {
        let e = v.abs().log10().floor() as i32;
        let m = v / 10f64.powi(e);
        if (m.abs() - 1.0).abs() < 1e-9 {
            format!("{}1e{e}", if v < 0.0 { "-" } else { "" })
        } else {
            format!("{v:.1e}")
        }
    } else {
        format!("{}", (v * 1000.0).round() / 1000.0)
    }
}

impl XyChart {
    pub fn new(title: &str, x_label: &str, y_label: &str) -> XyChart {
        XyChart {
            title: title.into(),
            caption: String::new(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            log_x: false,
            log_y: false,
            series: vec![],
            hlines: vec![],
            width: 420.0,
            height: 240.0,
            legend_right: false,
        }
    }

    fn ok(&self, x: f64, y: f64) -> bool {
        x.is_finite() && y.is_finite() && (!self.log_x || x > 0.0) && (!self.log_y || y > 0.0)
    }

    /// The chart as an `<svg>` element.
    pub fn svg(&self) -> String {
        let tx = |x: f64| if self.log_x { x.log10() } else { x };
        let ty = |y: f64| if self.log_y { y.log10() } else { y };
        let mut xs = vec![];
        let mut ys: Vec<f64> = self.hlines.iter().filter(|v| self.ok(1.0, **v)).map(|&v| ty(v)).collect();
        for p in self.series.iter().flat_map(|s| &s.points).filter(|p| self.ok(p.x, p.y)) {
            xs.push(tx(p.x));
            ys.push(ty(p.y));
        }
        let (w, h) = (self.width, self.height);
        let legend_w = if self.legend_right { 190.0 } else { 0.0 };
        let top = if self.caption.is_empty() { 24.0 } else { 38.0 };
        let (l, r, t, b) = (58.0, 12.0 + legend_w, top, 38.0);
        let mut s = String::new();
        let _ = write!(
            s,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"10\">\
             <rect width=\"100%\" height=\"100%\" fill=\"white\"/><text x=\"{l}\" y=\"14\" font-size=\"12\">{}</text>",
            esc(&self.title)
        );
        if !self.caption.is_empty() {
            let _ = write!(s, "<text x=\"{l}\" y=\"28\" fill=\"#555\">{}</text>", esc(&self.caption));
        }
        if xs.is_empty() {
            let _ = write!(s, "<text x=\"{l}\" y=\"{}\">no finite data</text></svg>", h / 2.0);
            return s;
        }
        let range = |v: &[f64], log: bool| {
            let (mut lo, mut hi) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
            if log {
                lo = lo.floor();
                hi = hi.ceil().max(lo + 1.0);
            } else if hi <= lo {
                let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
                lo -= d;
                hi += d;
            } else {
                let pad = (hi - lo) * 0.04;
                lo -= pad;
                hi += pad;
            }
            (lo, hi)
        };
        let ((x0, x1), (y0, y1)) = (range(&xs, self.log_x), range(&ys, self.log_y));
        let px = |x: f64| l + (tx(x) - x0) / (x1 - x0) * (w - l - r);
        let py = |y: f64| h - b - (ty(y) - y0) / (y1 - y0) * (h - t - b);
        let _ = write!(
            s,
            "<rect x=\"{l}\" y=\"{t}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#999\"/>",
            w - l - r,
            h - t - b
        );
        let tick_label = |v: f64, log: bool| if log { fmt_num(10f64.powf(v)) } else { fmt_num(v) };
        for v in ticks(y0, y1, self.log_y) {
            let y = h - b - (v - y0) / (y1 - y0) * (h - t - b);
            let _ = write!(
                s,
                "<line x1=\"{l}\" x2=\"{}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#eee\"/><text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
                w - r,
                l - 4.0,
                y + 3.0,
                tick_label(v, self.log_y)
            );
        }
        for v in ticks(x0, x1, self.log_x) {
            let x = l + (v - x0) / (x1 - x0) * (w - l - r);
            let _ = write!(
                s,
                "<line x1=\"{x:.1}\" x2=\"{x:.1}\" y1=\"{t}\" y2=\"{}\" stroke=\"#f2f2f2\"/><text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
                h - b,
                h - b + 12.0,
                tick_label(v, self.log_x)
            );
        }
        let _ = write!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text><text x=\"12\" y=\"{m}\" transform=\"rotate(-90 12 {m})\" text-anchor=\"middle\">{}</text>",
            (l + w - r) / 2.0,
            h - 8.0,
            esc(&self.x_label),
            esc(&self.y_label),
            m = (t + h - b) / 2.0
        );
        for &v in self.hlines.iter().filter(|v| self.ok(1.0, **v)) {
            let y = py(v);
            let _ = write!(
                s,
                "<line x1=\"{l}\" x2=\"{}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#000\" stroke-dasharray=\"4 3\"/>",
                w - r
            );
        }
        for (k, series) in self.series.iter().enumerate() {
            let color = series.color.clone().unwrap_or_else(|| COLORS[k % COLORS.len()].to_string());
            let pts: Vec<&Point> = series.points.iter().filter(|p| self.ok(p.x, p.y)).collect();
            let dash = if series.line == Line::Dashed { " stroke-dasharray=\"5 3\"" } else { "" };
            if series.line != Line::None && pts.len() > 1 {
                let path: Vec<String> = pts.iter().map(|p| format!("{:.1},{:.1}", px(p.x), py(p.y))).collect();
                let _ = write!(
                    s,
                    "<polyline fill=\"none\" stroke=\"{color}\" stroke-width=\"1.5\"{dash} points=\"{}\"/>",
                    path.join(" ")
                );
            }
            for p in &pts {
                let (x, y) = (px(p.x), py(p.y));
                if let Some(e) = p.err.filter(|e| e.is_finite() && *e > 0.0) {
                    let lo = if self.log_y { (p.y - e).max(p.y * 0.05) } else { p.y - e };
                    let _ = write!(
                        s,
                        "<line x1=\"{x:.1}\" x2=\"{x:.1}\" y1=\"{:.1}\" y2=\"{:.1}\" stroke=\"{color}\" opacity=\"0.5\"/>",
                        py(p.y + e),
                        py(lo)
                    );
                }
                if series.markers {
                    let _ = write!(s, "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"3\" fill=\"{color}\"/>");
                }
                if let Some(label) = &p.label {
                    let _ = write!(
                        s,
                        "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"9\" fill=\"{color}\">{}</text>",
                        x + 4.0,
                        y - 4.0,
                        esc(label)
                    );
                }
            }
        }
        // Legend: beside the plot, or inside it in rows of items as wide as their names.
        let (mut lx, mut ly) = if self.legend_right { (w - legend_w + 4.0, t + 10.0) } else { (l + 6.0, t + 12.0) };
        for (k, series) in self.series.iter().enumerate().filter(|(_, s)| s.legend) {
            let color = series.color.clone().unwrap_or_else(|| COLORS[k % COLORS.len()].to_string());
            let dash = if series.line == Line::Dashed { " stroke-dasharray=\"5 3\"" } else { "" };
            let item_w = 30.0 + 5.6 * series.name.chars().count() as f64;
            if !self.legend_right && lx > l + 6.0 && lx + item_w > w - r {
                (lx, ly) = (l + 6.0, ly + 12.0);
            }
            let _ = write!(
                s,
                "<line x1=\"{lx:.1}\" x2=\"{:.1}\" y1=\"{:.1}\" y2=\"{:.1}\" stroke=\"{color}\" stroke-width=\"2\"{dash}/><text x=\"{:.1}\" y=\"{ly:.1}\" fill=\"{color}\">{}</text>",
                lx + 14.0,
                ly - 3.0,
                ly - 3.0,
                lx + 18.0,
                esc(&series.name)
            );
            if self.legend_right {
                ly += 14.0;
            } else {
                lx += item_w;
            }
        }
        s.push_str("</svg>");
        s
    }
}

/// Several charts as panels of one SVG, `cols` per row, under a title and an optional caption, with an
/// optional shared legend of (name, colour) below the panels.
pub fn grid(title: &str, caption: &str, panels: &[XyChart], cols: usize, legend: &[(&str, &str)]) -> String {
    let cols = cols.max(1);
    let (pw, ph) = panels.iter().fold((0.0f64, 0.0f64), |(a, b), p| (a.max(p.width), b.max(p.height)));
    let rows = panels.len().div_ceil(cols).max(1);
    let top = if caption.is_empty() { 28.0 } else { 44.0 };
    let legend_h = 18.0 * legend.len().div_ceil(2) as f64;
    let (w, h) = (pw * cols as f64 + 20.0, ph * rows as f64 + top + 10.0 + legend_h);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/><text x=\"10\" y=\"20\" font-size=\"14\">{}</text>",
        esc(title)
    );
    if !caption.is_empty() {
        let _ = write!(s, "<text x=\"10\" y=\"36\" fill=\"#555\">{}</text>", esc(caption));
    }
    for (i, p) in panels.iter().enumerate() {
        let (x, y) = (10.0 + pw * (i % cols) as f64, top + ph * (i / cols) as f64);
        let inner = p.svg().replacen("<svg ", &format!("<svg x=\"{x}\" y=\"{y}\" "), 1);
        s.push_str(&inner);
    }
    for (i, (name, color)) in legend.iter().enumerate() {
        let (x, y) = (20.0 + (i % 2) as f64 * pw, top + ph * rows as f64 + 14.0 + 18.0 * (i / 2) as f64);
        let _ = write!(
            s,
            "<circle cx=\"{x}\" cy=\"{}\" r=\"4\" fill=\"{color}\"/><text x=\"{}\" y=\"{y}\">{}</text>",
            y - 4.0,
            x + 8.0,
            esc(name)
        );
    }
    s.push_str("</svg>\n");
    s
}

/// Horizontal bars: one row per label, one bar per series in the row (grouped) or one bar of stacked
/// segments (`stacked`), with the value (or the stack's total) printed at the end.
pub struct BarChart {
    pub title: String,
    pub unit: String,
    pub series: Vec<String>,
    /// (row label, one value per series).
    pub rows: Vec<(String, Vec<f64>)>,
    pub stacked: bool,
}

impl BarChart {
    pub fn svg(&self) -> String {
        let (label_w, plot_w, top) = (210.0, 460.0, 44.0 + 14.0 * self.series.len().div_ceil(3) as f64);
        let bars_per_row = if self.stacked { 1 } else { self.series.len().max(1) };
        let (bar_h, gap) = (10.0, 6.0);
        let row_h = bars_per_row as f64 * bar_h + gap;
        let total = |v: &[f64]| v.iter().filter(|x| x.is_finite() && **x > 0.0).sum::<f64>();
        let max =
            self.rows
                .iter()
                .map(|(_, v)| {
                    if self.stacked {
                        total(v)
                    } else {
                        v.iter().cloned().filter(|x| x.is_finite()).fold(0.0, f64::max)
                    }
                })
                .fold(1e-12, f64::max);
        let h = top + row_h * self.rows.len() as f64 + 24.0;
        let mut s = String::new();
        let _ = write!(
            s,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"10\">\
             <rect width=\"100%\" height=\"100%\" fill=\"white\"/><text x=\"10\" y=\"16\" font-size=\"13\">{}</text>",
            label_w + plot_w + 80.0,
            esc(&self.title)
        );
        for (k, name) in self.series.iter().enumerate() {
            let (x, y) = (10.0 + 200.0 * (k % 3) as f64, 34.0 + 14.0 * (k / 3) as f64);
            let _ = write!(
                s,
                "<rect x=\"{x}\" y=\"{}\" width=\"10\" height=\"8\" fill=\"{}\"/><text x=\"{}\" y=\"{y}\">{}</text>",
                y - 8.0,
                COLORS[k % COLORS.len()],
                x + 14.0,
                esc(name)
            );
        }
        for (i, (label, values)) in self.rows.iter().enumerate() {
            let y0 = top + row_h * i as f64;
            let _ = write!(
                s,
                "<text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
                label_w - 4.0,
                y0 + bar_h,
                esc(label)
            );
            let mut x = label_w;
            for (k, &v) in values.iter().enumerate() {
                if !(v.is_finite() && v > 0.0) {
                    continue;
                }
                let w = plot_w * v / max;
                let y = if self.stacked { y0 } else { y0 + bar_h * k as f64 };
                let bx = if self.stacked { x } else { label_w };
                let _ = write!(
                    s,
                    "<rect x=\"{bx:.1}\" y=\"{y:.1}\" width=\"{w:.1}\" height=\"{}\" fill=\"{}\"><title>{}: {}</title></rect>",
                    bar_h - 1.0,
                    COLORS[k % COLORS.len()],
                    esc(self.series.get(k).map_or("", |n| n.as_str())),
                    fmt_num(v)
                );
                if self.stacked {
                    x += w;
                } else {
                    let _ = write!(
                        s,
                        "<text x=\"{:.1}\" y=\"{:.1}\">{} {}</text>",
                        label_w + w + 4.0,
                        y + bar_h - 1.0,
                        fmt_num(v),
                        esc(&self.unit)
                    );
                }
            }
            if self.stacked {
                let _ = write!(
                    s,
                    "<text x=\"{:.1}\" y=\"{:.1}\">{} {}</text>",
                    x + 4.0,
                    y0 + bar_h - 1.0,
                    fmt_num(total(values)),
                    esc(&self.unit)
                );
            }
        }
        s.push_str("</svg>\n");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn balanced(svg: &str) {
        assert_eq!(svg.matches("<svg").count(), svg.matches("</svg>").count(), "{svg}");
        assert!(!svg.contains("NaN") && !svg.contains("inf"), "{svg}");
    }

    #[test]
    fn xy_charts_skip_non_finite_points_and_stay_well_formed() {
        let mut c = XyChart::new("loss <a&b>", "iteration", "loss");
        c.log_y = true;
        c.series.push(Series::marked(
            "l2",
            vec![Point::new(0.0, 1.0), Point::new(1.0, f64::NAN), Point::new(2.0, 0.01), Point::new(3.0, -1.0)],
        ));
        c.series.push(Series::line("empty", vec![]));
        c.hlines.push(f64::NAN);
        let svg = c.svg();
        balanced(&svg);
        assert!(svg.contains("&lt;a&amp;b&gt;"));
        // Log ticks cover the data's decades 1e-2 .. 1e0.
        for t in [">0.01<", ">0.1<", ">1<"] {
            assert!(svg.contains(t), "missing tick {t}: {svg}");
        }
        assert!(XyChart::new("e", "x", "y").svg().contains("no finite data"));
    }

    #[test]
    fn grids_and_bars_are_well_formed() {
        let mut a = XyChart::new("a", "s", "err");
        a.log_x = true;
        a.log_y = true;
        a.series.push(Series::marked("m", vec![Point { x: 0.5, y: 0.02, label: Some("16".into()), err: Some(0.01) }]));
        let g = grid("two", "caption", &[a.clone(), a], 2, &[("m", "#000")]);
        balanced(&g);
        assert_eq!(g.matches("<svg").count(), 3);
        let b = BarChart {
            title: "t".into(),
            unit: "ms".into(),
            series: vec!["x".into(), "y".into()],
            rows: vec![("r1".into(), vec![1.0, f64::NAN]), ("r2".into(), vec![2.0, 3.0])],
            stacked: false,
        };
        balanced(&b.svg());
        balanced(&BarChart { stacked: true, ..b }.svg());
    }
}
