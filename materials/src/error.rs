//! Errors for graph files and parameter overrides. Each names the file, the
//! node or parameter, and what is wrong.

/// A graph file that cannot be loaded.
#[derive(Debug, thiserror::Error)]
pub enum GraphError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{file}: invalid graph JSON: {msg}")]
    Json { file: String, msg: String },
    #[error("{file}: duplicate node id '{node}'")]
    DuplicateNode { file: String, node: String },
    #[error("{file}: node '{node}': unknown node type '{kind}' (known types: {known})")]
    UnknownNodeType { file: String, node: String, kind: String, known: String },
    #[error("{file}: node '{node}': input '{input}' refers to unknown node '{target}'")]
    UnknownInputNode { file: String, node: String, input: String, target: String },
    #[error("{file}: node '{node}': its type has no input '{input}' (inputs: {known})")]
    UnknownInput { file: String, node: String, input: String, known: String },
    #[error("{file}: node '{node}': missing required input '{input}'")]
    MissingInput { file: String, node: String, input: String },
    #[error("{file}: node '{node}': input '{input}' must be {expected} but its source gives {got}")]
    Channels { file: String, node: String, input: String, expected: &'static str, got: &'static str },
    #[error("{file}: cycle in the graph: {path}")]
    Cycle { file: String, path: String },
    #[error("{file}: node '{node}': its type has no parameter '{param}' (parameters: {known})")]
    UnknownSlot { file: String, node: String, param: String, known: String },
    #[error("{file}: node '{node}': parameter '{param}': {msg}")]
    BadSlot { file: String, node: String, param: String, msg: String },
    #[error("{file}: exposed parameter '{param}': {msg}")]
    BadParam { file: String, param: String, msg: String },
    #[error("{file}: outputs: {msg}")]
    BadOutput { file: String, msg: String },
}

/// A `key=value` parameter override that cannot be applied.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ParamError {
    #[error("'{0}' is not of the form key=value")]
    Syntax(String),
    #[error("material '{material}' has no parameter '{key}' (parameters: {known})")]
    Unknown { material: String, key: String, known: String },
    #[error("parameter '{key}': cannot parse '{value}' as {expected}")]
    Parse { key: String, value: String, expected: &'static str },
    #[error("parameter '{key}': {value} is outside its range [{min}, {max}]")]
    OutOfRange { key: String, value: f64, min: f64, max: f64 },
}
