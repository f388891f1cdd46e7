//! Reports: SVG charts (`chart`) and the self-contained run report `report.html` (`html`), whose top is the
//! run's summary (`summary`).

pub mod chart;
mod html;
mod summary;

pub use html::{write_report, OptimizationReport, ReportImage, RunReport, StageReport};
pub use summary::{build_summary, write_difference, Summary, SummaryTable};
