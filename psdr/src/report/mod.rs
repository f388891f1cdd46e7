//! Reports: SVG charts (`chart`) and the self-contained run report `report.html` (`html`), whose top is the
//! run's summary (`summary`), with the fitted scene's materials and the decisions behind them
//! (`material_table`).

pub mod chart;
mod html;
mod material_table;
mod summary;

pub use html::{write_report, OptimizationReport, ReportImage, RunReport, StageReport};
pub use summary::{build_summary, write_difference, Summary, SummaryTable};
