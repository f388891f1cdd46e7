//! Small SVG line charts (inline in reports; no external resources): named series over a shared x axis,
//! linear or log10 y, NaN and non-finite points skipped.

use std::fmt::Write as _;

pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

pub struct LineChart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_y: bool,
    pub series: Vec<Series>,
    pub width: f64,
    pub height: f64,
}

const COLORS: [&str; 8] = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"];

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// Tick values for [lo, hi]: round linear steps, or powers of ten on a log axis.
fn ticks(lo: f64, hi: f64, log: bool) -> Vec<f64> {
    if log {
        let (a, b) = (lo.floor() as i32, hi.ceil() as i32);
        return (a..=b).map(|e| e as f64).collect();
    }
    let span = (hi - lo).max(1e-300);
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| span / s <= 6.0).unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() * step;
    (0..).map(|i| first + i as f64 * step).take_while(|v| *v <= hi + step * 1e-9).collect()
}

fn fmt_num(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-2 {
        format!("{v:.1e}")
    } else {
        format!("{}", (v * 1000.0).round() / 1000.0)
    }
}

impl LineChart {
    pub fn new(title: &str, x_label: &str, y_label: &str) -> LineChart {
        LineChart {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            log_y: false,
            series: vec![],
            width: 420.0,
            height: 240.0,
        }
    }

    /// The chart as an `<svg>` element.
    pub fn svg(&self) -> String {
        let ty = |y: f64| if self.log_y { y.log10() } else { y };
        let pts: Vec<(f64, f64)> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|(x, y)| x.is_finite() && y.is_finite() && (!self.log_y || *y > 0.0))
            .map(|(x, y)| (x, ty(y)))
            .collect();
        let (w, h) = (self.width, self.height);
        let (l, r, t, b) = (58.0, 12.0, 24.0, 34.0);
        let mut s = String::new();
        let _ = write!(
            s,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"10\">\
             <text x=\"{}\" y=\"14\" font-size=\"12\">{}</text>",
            l,
            esc(&self.title)
        );
        if pts.is_empty() {
            let _ = write!(s, "<text x=\"{l}\" y=\"{}\">no finite data</text></svg>", h / 2.0);
            return s;
        }
        let fold = |f: fn(f64, f64) -> f64, init: f64, k: usize| {
            pts.iter().map(|p| if k == 0 { p.0 } else { p.1 }).fold(init, f)
        };
        let (mut x0, mut x1) = (fold(f64::min, f64::INFINITY, 0), fold(f64::max, f64::NEG_INFINITY, 0));
        let (mut y0, mut y1) = (fold(f64::min, f64::INFINITY, 1), fold(f64::max, f64::NEG_INFINITY, 1));
        if x1 <= x0 {
            x1 = x0 + 1.0;
            x0 -= 0.0;
        }
        if y1 <= y0 {
            let d = if y0 == 0.0 { 1.0 } else { y0.abs() * 0.1 };
            y0 -= d;
            y1 += d;
        }
        let px = |x: f64| l + (x - x0) / (x1 - x0) * (w - l - r);
        let py = |y: f64| h - b - (y - y0) / (y1 - y0) * (h - t - b);
        let _ = write!(
            s,
            "<rect x=\"{l}\" y=\"{t}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#999\"/>",
            w - l - r,
            h - t - b
        );
        for v in ticks(y0, y1, self.log_y).into_iter().filter(|v| *v >= y0 && *v <= y1) {
            let label = if self.log_y { fmt_num(10f64.powf(v)) } else { fmt_num(v) };
            let y = py(v);
            let _ = write!(
                s,
                "<line x1=\"{l}\" x2=\"{}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#eee\"/><text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{label}</text>",
                w - r,
                l - 4.0,
                y + 3.0
            );
        }
        for v in ticks(x0, x1, false).into_iter().filter(|v| *v >= x0 && *v <= x1) {
            let _ = write!(
                s,
                "<text x=\"{:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
                px(v),
                h - b + 12.0,
                fmt_num(v)
            );
        }
        let _ = write!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text><text x=\"12\" y=\"{}\" transform=\"rotate(-90 12 {})\" text-anchor=\"middle\">{}</text>",
            (l + w - r) / 2.0,
            h - 6.0,
            esc(&self.x_label),
            (t + h - b) / 2.0,
            (t + h - b) / 2.0,
            esc(&self.y_label)
        );
        for (k, series) in self.series.iter().enumerate() {
            let color = COLORS[k % COLORS.len()];
            let path: Vec<String> = series
                .points
                .iter()
                .filter(|(x, y)| x.is_finite() && y.is_finite() && (!self.log_y || *y > 0.0))
                .map(|&(x, y)| format!("{:.1},{:.1}", px(x), py(ty(y))))
                .collect();
            if !path.is_empty() {
                let _ = write!(
                    s,
                    "<polyline fill=\"none\" stroke=\"{color}\" stroke-width=\"1.5\" points=\"{}\"/>",
                    path.join(" ")
                );
            }
            let _ = write!(
                s,
                "<text x=\"{}\" y=\"{}\" fill=\"{color}\">{}</text>",
                l + 6.0 + 110.0 * (k % 3) as f64,
                t + 12.0 + 12.0 * (k / 3) as f64,
                esc(&series.name)
            );
        }
        s.push_str("</svg>");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn charts_skip_non_finite_points_and_stay_well_formed() {
        let mut c = LineChart::new("loss <a&b>", "iteration", "loss");
        c.log_y = true;
        c.series
            .push(Series { name: "l2".into(), points: vec![(0.0, 1.0), (1.0, f64::NAN), (2.0, 0.01), (3.0, -1.0)] });
        c.series.push(Series { name: "empty".into(), points: vec![] });
        let svg = c.svg();
        assert!(!svg.contains("NaN") && !svg.contains("inf"), "{svg}");
        assert!(svg.contains("&lt;a&amp;b&gt;"));
        assert_eq!(svg.matches("<svg").count(), svg.matches("</svg>").count());
        // Log ticks cover the data's decades.
        assert!(svg.contains(">1<") || svg.contains(">1.0e0<") || svg.contains(">1</text>"), "{svg}");
        let empty = LineChart::new("e", "x", "y").svg();
        assert!(empty.contains("no finite data"));
    }
}
