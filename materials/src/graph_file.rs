//! The on-disk graph format (JSON), exactly as written by hand. See the crate
//! docs for a description; [`crate::graph::Graph`] validates and compiles it.

use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GraphFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub category: String,
    #[serde(default)]
    pub params: Vec<ParamDecl>,
    pub nodes: Vec<NodeDecl>,
    pub outputs: OutputsDecl,
}

/// An exposed parameter: `type` is "float" (default), "int" or "color".
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ParamDecl {
    pub name: String,
    #[serde(rename = "type", default)]
    pub kind: Option<String>,
    pub default: Value,
    #[serde(default)]
    pub min: Option<Value>,
    #[serde(default)]
    pub max: Option<Value>,
    #[serde(default)]
    pub description: String,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct NodeDecl {
    pub id: String,
    #[serde(rename = "type")]
    pub kind: String,
    #[serde(default)]
    pub inputs: BTreeMap<String, String>,
    #[serde(default)]
    pub params: BTreeMap<String, Value>,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OutputsDecl {
    pub base_color: String,
    pub roughness: String,
    #[serde(default)]
    pub normal: Option<String>,
    #[serde(default)]
    pub height: Option<String>,
}
