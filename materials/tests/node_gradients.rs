//! Finite-difference check of every node type's backward, with random parameter
//! values and random (parameter-dependent) inputs, for every choice of its
//! mode-like integer slots.

mod common;
use common::{check_fd, random_params, Rng};
use psdr_materials::node_op::{Channels, SlotKind};
use psdr_materials::nodes::NODES;
use psdr_materials::{Evaluator, Graph};
use serde_json::{json, Value};

const N: usize = 32;

/// A graph exposing every float slot of `kind` (plus parameter-dependent grey and
/// colour sources feeding its inputs) with int slot `choice` set if given.
fn test_graph(kind: &str, choice: Option<(&str, i64)>, seed: u64) -> Value {
    let spec = psdr_materials::nodes::node_spec(kind).unwrap();
    let mut params = vec![];
    let mut nodes = vec![];
    let mut inputs = serde_json::Map::new();
    for (j, inp) in spec.inputs.iter().enumerate() {
        let g = format!("g{j}");
        params.push(json!({"name": format!("rough{j}"), "default": 0.5, "min": 0.2, "max": 0.8}));
        nodes.push(json!({"id": g, "type": "fbm", "params": {"scale_x": 3, "scale_y": 2, "octaves": 3,
            "seed": seed as i64 + j as i64, "roughness": format!("$rough{j}")}}));
        let src = if inp.channels == Channels::Gray {
            g
        } else {
            let c = format!("c{j}");
            params.push(json!({"name": format!("lo{j}"), "type": "color", "default": [0.2, 0.3, 0.4]}));
            params.push(json!({"name": format!("hi{j}"), "type": "color", "default": [0.8, 0.6, 0.5]}));
            nodes.push(json!({"id": c, "type": "gradient_map", "inputs": {"input": g},
                "params": {"count": 2, "pos0": 0.2, "pos1": 0.8,
                           "color0": format!("$lo{j}"), "color1": format!("$hi{j}")}}));
            c
        };
        inputs.insert(inp.name.to_string(), json!(src));
    }
    let mut slots = serde_json::Map::new();
    for s in spec.slots {
        match s.kind {
            SlotKind::Float { min, max, default } => {
                let name = format!("p_{}", s.name);
                params.push(json!({"name": name, "default": default, "min": min, "max": max}));
                slots.insert(s.name.into(), json!(format!("${name}")));
            }
            SlotKind::Color { default } => {
                let name = format!("p_{}", s.name);
                params.push(json!({"name": name, "type": "color", "default": default}));
                slots.insert(s.name.into(), json!(format!("${name}")));
            }
            SlotKind::Int { .. } => {}
        }
    }
    if let Some((slot, v)) = choice {
        slots.insert(slot.into(), json!(v));
    }
    if kind == "gradient_map" {
        slots.insert("count".into(), json!(4));
    }
    nodes.push(json!({"id": "test", "type": kind, "inputs": inputs, "params": slots}));
    nodes.push(json!({"id": "rough", "type": "uniform"}));
    json!({"name": format!("test_{kind}"), "params": params, "nodes": nodes,
           "outputs": {"base_color": "test", "roughness": "rough"}})
}

fn loss(ev: &mut Evaluator, p: &psdr_materials::Params, w: &[f64]) -> f64 {
    ev.evaluate(p);
    ev.node_image("test").unwrap().data.iter().zip(w).map(|(a, b)| a * b).sum()
}

/// Gradient-map stop positions must stay ascending; sort the random draws.
fn sort_stops(kind: &str, ev: &Evaluator, p: &mut psdr_materials::Params) {
    if kind == "gradient_map" {
        let g = ev.graph();
        let mut pos: Vec<f64> = (0..6).map(|k| p.floats[g.param(&format!("p_pos{k}")).unwrap().offset]).collect();
        pos.sort_by(|a, b| a.partial_cmp(b).unwrap());
        for (k, v) in pos.into_iter().enumerate() {
            p.floats[g.param(&format!("p_pos{k}")).unwrap().offset] = v;
        }
    }
}

#[test]
fn every_node_backward_matches_finite_differences() {
    let mut failures = vec![];
    let mut checked = 0;
    for (t, spec) in NODES.iter().enumerate() {
        let mut cases: Vec<Option<(&str, i64)>> = vec![None];
        for s in spec.slots {
            if let SlotKind::Int { names, .. } = s.kind {
                if !names.is_empty() {
                    cases.extend((0..names.len() as i64).map(|v| Some((s.name, v))));
                }
            }
        }
        for (c, case) in cases.into_iter().enumerate() {
            let json = test_graph(spec.name, case, 11 + t as u64);
            let graph = Graph::from_json(&json.to_string(), spec.name).unwrap();
            let mut ev = Evaluator::new(graph, N);
            let mut rng = Rng(0x1234_5678 + 977 * t as u64 + 31 * c as u64);
            let mut p = random_params(&ev, &mut rng);
            sort_stops(spec.name, &ev, &mut p);
            ev.evaluate(&p);
            let len = ev.node_image("test").unwrap().data.len();
            let w: Vec<f64> = (0..len).map(|_| rng.range(-1.0, 1.0)).collect();
            let mut grad = vec![0.0; ev.graph().num_floats()];
            ev.backward_node("test", &w, &mut grad);
            let res = check_fd(&mut ev, &p, &grad, 1e-5, 1e-6, |ev, p| loss(ev, p, &w));
            checked += 1;
            if let Err(e) = res {
                failures.push(format!("{} {:?}: {e}", spec.name, case));
            }
        }
    }
    assert!(checked >= NODES.len());
    assert!(failures.is_empty(), "FD mismatches:\n{}", failures.join("\n"));
}

/// A deliberately wrong gradient must fail the checker (guards against a vacuous test).
#[test]
fn fd_checker_detects_a_wrong_gradient() {
    let json = test_graph("levels", None, 3);
    let graph = Graph::from_json(&json.to_string(), "levels").unwrap();
    let mut ev = Evaluator::new(graph, N);
    let mut rng = Rng(99);
    let p = random_params(&ev, &mut rng);
    ev.evaluate(&p);
    let w: Vec<f64> = (0..N * N * 3).map(|_| rng.range(-1.0, 1.0)).collect();
    let mut grad = vec![0.0; ev.graph().num_floats()];
    ev.backward_node("test", &w, &mut grad);
    grad[0] *= 1.01;
    assert!(check_fd(&mut ev, &p, &grad, 1e-5, 1e-6, |ev, p| loss(ev, p, &w)).is_err());
}
