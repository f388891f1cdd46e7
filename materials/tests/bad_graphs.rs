//! Bad graph files and bad overrides give errors that name the file, the node or
//! parameter, and what is wrong (and never panic).

use psdr_materials::{Graph, GraphError, ParamError};

const GOOD_TAIL: &str = r#"{"id": "r", "type": "uniform"}], "outputs": {"base_color": "r", "roughness": "r"}}"#;

fn graph(params: &str, nodes: &str) -> String {
    format!(r#"{{"name": "t", "params": [{params}], "nodes": [{nodes}{GOOD_TAIL}"#)
}

fn err(text: &str) -> (GraphError, String) {
    let e = Graph::from_json(text, "rooms/bad.json").err().expect("must be rejected");
    let msg = e.to_string();
    assert!(msg.starts_with("rooms/bad.json"), "message must name the file: {msg}");
    (e, msg)
}

#[test]
fn a_good_graph_loads() {
    let g = Graph::from_json(&graph("", ""), "ok.json").unwrap();
    assert_eq!(g.num_floats(), 0);
}

#[test]
fn unknown_node_type() {
    let (e, msg) = err(&graph("", r#"{"id": "n1", "type": "sparkles"},"#));
    assert!(matches!(e, GraphError::UnknownNodeType { .. }), "{e:?}");
    assert!(msg.contains("'n1'") && msg.contains("sparkles") && msg.contains("fbm"), "{msg}");
}

#[test]
fn cycle() {
    let (e, msg) = err(&graph(
        "",
        r#"{"id": "a", "type": "invert", "inputs": {"input": "b"}},
           {"id": "b", "type": "blur", "inputs": {"input": "c"}},
           {"id": "c", "type": "levels", "inputs": {"input": "a"}},"#,
    ));
    assert!(matches!(e, GraphError::Cycle { .. }), "{e:?}");
    assert!(msg.contains("a -> b -> c -> a"), "{msg}");
}

#[test]
fn missing_input() {
    let (e, msg) = err(&graph("", r#"{"id": "w", "type": "warp", "inputs": {"input": "r"}},"#));
    assert!(matches!(e, GraphError::MissingInput { .. }), "{e:?}");
    assert!(msg.contains("'w'") && msg.contains("'displacement'"), "{msg}");
}

#[test]
fn input_from_unknown_node() {
    let (e, msg) = err(&graph("", r#"{"id": "i", "type": "invert", "inputs": {"input": "ghost"}},"#));
    assert!(matches!(e, GraphError::UnknownInputNode { .. }), "{e:?}");
    assert!(msg.contains("'i'") && msg.contains("'ghost'"), "{msg}");
}

#[test]
fn out_of_range_default() {
    let (e, msg) = err(&graph(r#"{"name": "gap", "default": 0.5, "min": 0.0, "max": 0.2}"#, ""));
    assert!(matches!(e, GraphError::BadParam { .. }), "{e:?}");
    assert!(msg.contains("'gap'") && msg.contains("outside the range"), "{msg}");
}

#[test]
fn out_of_range_literal_slot() {
    let (e, msg) = err(&graph("", r#"{"id": "b", "type": "bricks", "params": {"mortar": 7.0}},"#));
    assert!(matches!(e, GraphError::BadSlot { .. }), "{e:?}");
    assert!(msg.contains("'b'") && msg.contains("'mortar'") && msg.contains("outside"), "{msg}");
}

#[test]
fn unknown_slot_choice_and_reference() {
    let (_, msg) = err(&graph("", r#"{"id": "b", "type": "bricks", "params": {"grout": 1}},"#));
    assert!(msg.contains("no parameter 'grout'") && msg.contains("mortar"), "{msg}");
    let (_, msg) = err(&graph(
        "",
        r#"{"id": "m", "type": "blend", "inputs": {"a": "r", "b": "r"}, "params": {"mode": "dodge"}},"#,
    ));
    assert!(msg.contains("unknown choice 'dodge'") && msg.contains("multiply"), "{msg}");
    let (_, msg) = err(&graph("", r#"{"id": "u", "type": "uniform", "params": {"value": "$nope"}},"#));
    assert!(msg.contains("'u'") && msg.contains("undefined parameter '$nope'"), "{msg}");
    let (_, msg) = err(&graph(
        r#"{"name": "k", "type": "int", "default": 2, "min": 1, "max": 4}"#,
        r#"{"id": "u", "type": "uniform", "params": {"value": "$k"}},"#,
    ));
    assert!(msg.contains("not a float parameter"), "{msg}");
}

#[test]
fn wrong_channels_and_outputs() {
    let (e, msg) = err(&graph(
        "",
        r#"{"id": "c", "type": "color"}, {"id": "g", "type": "gradient_map", "inputs": {"input": "c"}},"#,
    ));
    assert!(matches!(e, GraphError::Channels { .. }), "{e:?}");
    assert!(msg.contains("'g'") && msg.contains("must be grey"), "{msg}");
    let text =
        r#"{"name": "t", "nodes": [{"id": "c", "type": "color"}], "outputs": {"base_color": "c", "roughness": "c"}}"#;
    let (_, msg) = err(text);
    assert!(msg.contains("roughness must be grey"), "{msg}");
}

#[test]
fn malformed_json_and_unknown_fields() {
    let (e, msg) = err(r#"{"name": "t", "nodes": [ "#);
    assert!(matches!(e, GraphError::Json { .. }), "{e:?}");
    assert!(msg.contains("line"), "{msg}");
    let (_, msg) = err(r#"{"name": "t", "nodez": [], "nodes": [], "outputs": {"base_color": "a", "roughness": "a"}}"#);
    assert!(msg.contains("nodez"), "{msg}");
}

#[test]
fn duplicate_node() {
    let (e, _) = err(&graph("", r#"{"id": "r", "type": "uniform"},"#));
    assert!(matches!(e, GraphError::DuplicateNode { .. }), "{e:?}");
}

#[test]
fn missing_file_names_the_path() {
    let e = Graph::load(std::path::Path::new("/nonexistent/x.json")).err().unwrap();
    assert!(e.to_string().contains("/nonexistent/x.json"));
}

#[test]
fn overrides_are_parsed_with_clear_errors() {
    let text = graph(
        r#"{"name": "gap", "default": 0.1, "min": 0.0, "max": 0.2},
           {"name": "tint", "type": "color", "default": [0.5, 0.5, 0.5]},
           {"name": "rows", "type": "int", "default": 4, "min": 1, "max": 8}"#,
        "",
    );
    let g = Graph::from_json(&text, "t.json").unwrap();
    let mut p = g.default_params();
    g.apply_override(&mut p, "gap=0.15").unwrap();
    g.apply_override(&mut p, "tint=0.1, 0.2,0.3").unwrap();
    g.apply_override(&mut p, "rows=6").unwrap();
    assert_eq!(p.floats, vec![0.15, 0.1, 0.2, 0.3]);
    assert_eq!(p.ints, vec![6]);
    assert!(matches!(g.apply_override(&mut p, "gap"), Err(ParamError::Syntax(_))));
    assert!(matches!(g.apply_override(&mut p, "gapp=1"), Err(ParamError::Unknown { .. })));
    assert!(matches!(g.apply_override(&mut p, "gap=wide"), Err(ParamError::Parse { .. })));
    assert!(matches!(g.apply_override(&mut p, "rows=2.5"), Err(ParamError::Parse { .. })));
    assert!(matches!(g.apply_override(&mut p, "tint=0.1,0.2"), Err(ParamError::Parse { .. })));
    let e = g.apply_override(&mut p, "gap=0.9").unwrap_err();
    assert!(e.to_string().contains("outside its range [0, 0.2]"), "{e}");
    // Failed overrides leave the values untouched.
    assert_eq!(p.floats, vec![0.15, 0.1, 0.2, 0.3]);
}
