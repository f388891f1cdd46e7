//! Reports: SVG charts (`chart`) and the self-contained run report `report.html` (`html`).

pub mod chart;
mod html;

pub use html::{write_report, IterationRecord, OptimizationReport, ReportImage, RunReport, StageReport};
