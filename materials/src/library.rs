//! The built-in library: hand-editable graphs from `materials/library/*.json`,
//! embedded at build time and listed in file-name order.

use crate::error::GraphError;
use crate::graph::Graph;

include!(concat!(env!("OUT_DIR"), "/library_files.rs"));

/// Names of the library materials (file stems), in library order.
pub fn names() -> Vec<&'static str> {
    LIBRARY_FILES.iter().map(|(n, _)| *n).collect()
}

/// The JSON text of a library material.
pub fn source(name: &str) -> Option<&'static str> {
    LIBRARY_FILES.iter().find(|(n, _)| *n == name).map(|(_, s)| *s)
}

/// Compiles a library material; `None` if there is no such name.
pub fn load(name: &str) -> Option<Result<Graph, GraphError>> {
    source(name).map(|text| Graph::from_json(text, &format!("materials/library/{name}.json")))
}
