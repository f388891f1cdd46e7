//! A validated, topologically ordered material graph and its parameter vector.

use crate::error::{GraphError, ParamError};
use crate::graph_file::{GraphFile, NodeDecl, ParamDecl};
use crate::node_op::{Channels, NodeSpec, OutRule, SlotKind, MAX_FLOAT_SLOTS};
use crate::nodes::{node_spec, NODES};
use serde_json::Value;
use std::path::Path;

/// Kind of an exposed parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamKind {
    Float,
    Int,
    /// Three floats (sRGB components).
    Color,
}

/// An exposed parameter. Float and colour parameters occupy `len` consecutive
/// entries of [`Params::floats`] from `offset`; int parameters one entry of [`Params::ints`].
#[derive(Clone, Debug)]
pub struct ParamInfo {
    pub name: String,
    pub description: String,
    pub kind: ParamKind,
    pub offset: usize,
    pub len: usize,
    pub min: Vec<f64>,
    pub max: Vec<f64>,
    pub default: Vec<f64>,
}

/// Values of a graph's exposed parameters. Gradients are reported per entry of `floats`.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    pub floats: Vec<f64>,
    pub ints: Vec<i64>,
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum FloatBinding {
    Literal(f64),
    Param(usize),
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum IntBinding {
    Literal(i64),
    Param(usize),
}

#[derive(Clone)]
pub(crate) struct CompiledNode {
    pub id: String,
    pub spec: &'static NodeSpec,
    /// Index (in `Graph::nodes`) of each input, in spec order.
    pub inputs: Vec<Option<usize>>,
    pub floats: Vec<FloatBinding>,
    pub ints: Vec<IntBinding>,
    pub channels: usize,
}

/// Node indices of the material outputs.
#[derive(Clone, Copy, Debug)]
pub(crate) struct OutputNodes {
    pub base_color: usize,
    pub roughness: usize,
    pub normal: Option<usize>,
    pub height: Option<usize>,
}

/// A compiled material graph.
#[derive(Clone)]
pub struct Graph {
    pub name: String,
    pub description: String,
    pub category: String,
    pub params: Vec<ParamInfo>,
    pub(crate) n_floats: usize,
    pub(crate) n_ints: usize,
    pub(crate) nodes: Vec<CompiledNode>,
    pub(crate) outputs: OutputNodes,
}

fn channel_name(c: usize) -> &'static str {
    if c == 1 {
        "grey"
    } else {
        "colour"
    }
}

fn as_vec(v: &Value, len: usize) -> Option<Vec<f64>> {
    match v {
        Value::Number(n) if len == 1 => Some(vec![n.as_f64()?]),
        Value::Array(a) if a.len() == len => a.iter().map(|x| x.as_f64()).collect(),
        _ => None,
    }
}

impl Graph {
    /// Reads and compiles a graph file.
    pub fn load(path: &Path) -> Result<Graph, GraphError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| GraphError::Io { file: file.clone(), source })?;
        Graph::from_json(&text, &file)
    }

    /// Compiles a graph from JSON text; `file` names it in errors.
    pub fn from_json(text: &str, file: &str) -> Result<Graph, GraphError> {
        let decl: GraphFile =
            serde_json::from_str(text).map_err(|e| GraphError::Json { file: file.to_string(), msg: e.to_string() })?;
        Graph::compile(&decl, file)
    }

    /// Compiles an already parsed graph file.
    pub fn compile(decl: &GraphFile, file: &str) -> Result<Graph, GraphError> {
        let f = file.to_string();
        let (params, n_floats, n_ints) = compile_params(&decl.params, file)?;
        // Node ids -> declaration index.
        let mut index = std::collections::HashMap::new();
        for (k, n) in decl.nodes.iter().enumerate() {
            if index.insert(n.id.as_str(), k).is_some() {
                return Err(GraphError::DuplicateNode { file: f, node: n.id.clone() });
            }
        }
        let mut specs = Vec::with_capacity(decl.nodes.len());
        for n in &decl.nodes {
            let spec = node_spec(&n.kind).ok_or_else(|| GraphError::UnknownNodeType {
                file: f.clone(),
                node: n.id.clone(),
                kind: n.kind.clone(),
                known: NODES.iter().map(|s| s.name).collect::<Vec<_>>().join(", "),
            })?;
            for (input, target) in &n.inputs {
                if !spec.inputs.iter().any(|i| i.name == input) {
                    return Err(GraphError::UnknownInput {
                        file: f.clone(),
                        node: n.id.clone(),
                        input: input.clone(),
                        known: spec.inputs.iter().map(|i| i.name).collect::<Vec<_>>().join(", "),
                    });
                }
                if !index.contains_key(target.as_str()) {
                    return Err(GraphError::UnknownInputNode {
                        file: f.clone(),
                        node: n.id.clone(),
                        input: input.clone(),
                        target: target.clone(),
                    });
                }
            }
            for i in spec.inputs {
                if !i.optional && !n.inputs.contains_key(i.name) {
                    return Err(GraphError::MissingInput {
                        file: f.clone(),
                        node: n.id.clone(),
                        input: i.name.to_string(),
                    });
                }
            }
            specs.push(spec);
        }
        let order = topo_order(&decl.nodes, &index, file)?;
        let mut position = vec![0; decl.nodes.len()];
        for (p, &k) in order.iter().enumerate() {
            position[k] = p;
        }
        let mut nodes: Vec<CompiledNode> = Vec::with_capacity(order.len());
        for &k in &order {
            let n = &decl.nodes[k];
            let spec = specs[k];
            let mut inputs = Vec::new();
            let mut widest = 1;
            for i in spec.inputs {
                let src = n.inputs.get(i.name).map(|t| position[index[t.as_str()]]);
                if let Some(s) = src {
                    let c = nodes[s].channels;
                    let ok = match i.channels {
                        Channels::Gray => c == 1,
                        Channels::Color => c == 3,
                        Channels::Any => true,
                    };
                    if !ok {
                        return Err(GraphError::Channels {
                            file: f.clone(),
                            node: n.id.clone(),
                            input: i.name.to_string(),
                            expected: channel_name(if i.channels == Channels::Gray { 1 } else { 3 }),
                            got: channel_name(c),
                        });
                    }
                    // The optional grey mask does not widen the output.
                    if !i.optional {
                        widest = widest.max(c);
                    }
                }
                inputs.push(src);
            }
            let channels = match spec.out {
                OutRule::Gray => 1,
                OutRule::Color => 3,
                OutRule::WidestInput => widest,
            };
            let (floats, ints) = bind_slots(n, spec, &params, file)?;
            nodes.push(CompiledNode { id: n.id.clone(), spec, inputs, floats, ints, channels });
        }
        let find = |id: &str, what: &str, want: Option<usize>| -> Result<usize, GraphError> {
            let k = *index.get(id).ok_or_else(|| GraphError::BadOutput {
                file: f.clone(),
                msg: format!("{what} refers to unknown node '{id}'"),
            })?;
            let p = position[k];
            if let Some(c) = want {
                if nodes[p].channels != c {
                    return Err(GraphError::BadOutput {
                        file: f.clone(),
                        msg: format!(
                            "{what} must be {} but node '{id}' is {}",
                            channel_name(c),
                            channel_name(nodes[p].channels)
                        ),
                    });
                }
            }
            Ok(p)
        };
        let o = &decl.outputs;
        let outputs = OutputNodes {
            base_color: find(&o.base_color, "base_color", None)?,
            roughness: find(&o.roughness, "roughness", Some(1))?,
            normal: o.normal.as_deref().map(|id| find(id, "normal", Some(3))).transpose()?,
            height: o.height.as_deref().map(|id| find(id, "height", Some(1))).transpose()?,
        };
        Ok(Graph {
            name: decl.name.clone(),
            description: decl.description.clone(),
            category: decl.category.clone(),
            params,
            n_floats,
            n_ints,
            nodes,
            outputs,
        })
    }

    /// Default values of the exposed parameters.
    pub fn default_params(&self) -> Params {
        let mut p = Params { floats: vec![0.0; self.n_floats], ints: vec![0; self.n_ints] };
        for info in &self.params {
            for k in 0..info.len {
                match info.kind {
                    ParamKind::Int => p.ints[info.offset] = info.default[0] as i64,
                    _ => p.floats[info.offset + k] = info.default[k],
                }
            }
        }
        p
    }

    /// Number of continuous (differentiable) parameter entries.
    pub fn num_floats(&self) -> usize {
        self.n_floats
    }

    /// Name of each continuous entry, e.g. `gap` or `tint[1]` for a colour component.
    pub fn float_names(&self) -> Vec<String> {
        let mut names = vec![String::new(); self.n_floats];
        for info in self.params.iter().filter(|p| p.kind != ParamKind::Int) {
            for k in 0..info.len {
                names[info.offset + k] = if info.len == 1 { info.name.clone() } else { format!("{}[{k}]", info.name) };
            }
        }
        names
    }

    /// (min, max) of each continuous entry.
    pub fn float_ranges(&self) -> Vec<(f64, f64)> {
        let mut r = vec![(0.0, 1.0); self.n_floats];
        for info in self.params.iter().filter(|p| p.kind != ParamKind::Int) {
            for k in 0..info.len {
                r[info.offset + k] = (info.min[k], info.max[k]);
            }
        }
        r
    }

    /// Looks up an exposed parameter.
    pub fn param(&self, name: &str) -> Option<&ParamInfo> {
        self.params.iter().find(|p| p.name == name)
    }

    /// Applies one `key=value` override (`value` is a number, or `r,g,b` for a colour).
    pub fn apply_override(&self, params: &mut Params, assignment: &str) -> Result<(), ParamError> {
        let (key, value) = assignment.split_once('=').ok_or_else(|| ParamError::Syntax(assignment.to_string()))?;
        let (key, value) = (key.trim(), value.trim());
        let info = self.param(key).ok_or_else(|| ParamError::Unknown {
            material: self.name.clone(),
            key: key.to_string(),
            known: self.params.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(", "),
        })?;
        let parts: Vec<&str> = value.split(',').map(str::trim).collect();
        let expected = match info.kind {
            ParamKind::Float => "a number",
            ParamKind::Int => "an integer",
            ParamKind::Color => "three numbers r,g,b",
        };
        let bad = || ParamError::Parse { key: key.to_string(), value: value.to_string(), expected };
        if parts.len() != info.len {
            return Err(bad());
        }
        let mut vals = Vec::with_capacity(info.len);
        for p in parts {
            let v: f64 = if info.kind == ParamKind::Int {
                p.parse::<i64>().map_err(|_| bad())? as f64
            } else {
                p.parse::<f64>().map_err(|_| bad())?
            };
            if !v.is_finite() {
                return Err(bad());
            }
            vals.push(v);
        }
        for (k, &v) in vals.iter().enumerate() {
            if v < info.min[k] || v > info.max[k] {
                return Err(ParamError::OutOfRange {
                    key: key.to_string(),
                    value: v,
                    min: info.min[k],
                    max: info.max[k],
                });
            }
        }
        for (k, &v) in vals.iter().enumerate() {
            match info.kind {
                ParamKind::Int => params.ints[info.offset] = v as i64,
                _ => params.floats[info.offset + k] = v,
            }
        }
        Ok(())
    }
}

fn compile_params(decls: &[ParamDecl], file: &str) -> Result<(Vec<ParamInfo>, usize, usize), GraphError> {
    let mut out: Vec<ParamInfo> = Vec::new();
    let (mut nf, mut ni) = (0, 0);
    for d in decls {
        let err = |msg: String| GraphError::BadParam { file: file.to_string(), param: d.name.clone(), msg };
        if out.iter().any(|p| p.name == d.name) {
            return Err(err("declared twice".into()));
        }
        let kind = match d.kind.as_deref().unwrap_or("float") {
            "float" => ParamKind::Float,
            "int" => ParamKind::Int,
            "color" => ParamKind::Color,
            other => return Err(err(format!("unknown type '{other}' (use float, int or color)"))),
        };
        let len = if kind == ParamKind::Color { 3 } else { 1 };
        let read = |v: &Option<Value>, what: &str, fallback: Option<f64>| -> Result<Vec<f64>, GraphError> {
            match v {
                Some(v) => as_vec(v, len).ok_or_else(|| {
                    err(format!("'{what}' must be {}", if len == 1 { "a number" } else { "an array of 3 numbers" }))
                }),
                None => fallback.map(|x| vec![x; len]).ok_or_else(|| err(format!("missing '{what}'"))),
            }
        };
        let color_fallback = |x| (kind == ParamKind::Color).then_some(x);
        let default = read(&Some(d.default.clone()), "default", None)?;
        let min = read(&d.min, "min", color_fallback(0.0))?;
        let max = read(&d.max, "max", color_fallback(1.0))?;
        for k in 0..len {
            if min[k] > max[k] {
                return Err(err(format!("min {} is above max {}", min[k], max[k])));
            }
            if !(default[k] >= min[k] && default[k] <= max[k]) {
                return Err(err(format!("default {} is outside the range [{}, {}]", default[k], min[k], max[k])));
            }
            if kind == ParamKind::Int && default[k].fract() != 0.0 {
                return Err(err(format!("default {} of an int parameter is not an integer", default[k])));
            }
        }
        let offset = if kind == ParamKind::Int {
            ni += 1;
            ni - 1
        } else {
            nf += len;
            nf - len
        };
        out.push(ParamInfo {
            name: d.name.clone(),
            description: d.description.clone(),
            kind,
            offset,
            len,
            min,
            max,
            default,
        });
    }
    Ok((out, nf, ni))
}

/// Depth-first topological order; reports the first cycle found.
fn topo_order(
    nodes: &[NodeDecl],
    index: &std::collections::HashMap<&str, usize>,
    file: &str,
) -> Result<Vec<usize>, GraphError> {
    // 0 = unvisited, 1 = on the stack, 2 = done.
    let mut state = vec![0u8; nodes.len()];
    let mut order = Vec::with_capacity(nodes.len());
    let mut stack: Vec<usize> = Vec::new();
    fn visit(
        k: usize,
        nodes: &[NodeDecl],
        index: &std::collections::HashMap<&str, usize>,
        state: &mut [u8],
        stack: &mut Vec<usize>,
        order: &mut Vec<usize>,
    ) -> Result<(), String> {
        if state[k] == 2 {
            return Ok(());
        }
        if state[k] == 1 {
            let start = stack.iter().position(|&s| s == k).unwrap_or(0);
            let mut path: Vec<&str> = stack[start..].iter().map(|&s| nodes[s].id.as_str()).collect();
            path.push(nodes[k].id.as_str());
            return Err(path.join(" -> "));
        }
        state[k] = 1;
        stack.push(k);
        for target in nodes[k].inputs.values() {
            visit(index[target.as_str()], nodes, index, state, stack, order)?;
        }
        stack.pop();
        state[k] = 2;
        order.push(k);
        Ok(())
    }
    for k in 0..nodes.len() {
        visit(k, nodes, index, &mut state, &mut stack, &mut order)
            .map_err(|path| GraphError::Cycle { file: file.to_string(), path })?;
    }
    Ok(order)
}

/// Resolves a node's slot values (literal or `$param`) against its type's schema.
fn bind_slots(
    n: &NodeDecl,
    spec: &NodeSpec,
    params: &[ParamInfo],
    file: &str,
) -> Result<(Vec<FloatBinding>, Vec<IntBinding>), GraphError> {
    for key in n.params.keys() {
        if !spec.slots.iter().any(|s| s.name == key) {
            return Err(GraphError::UnknownSlot {
                file: file.to_string(),
                node: n.id.clone(),
                param: key.clone(),
                known: spec.slots.iter().map(|s| s.name).collect::<Vec<_>>().join(", "),
            });
        }
    }
    let mut floats = Vec::new();
    let mut ints = Vec::new();
    for slot in spec.slots {
        let err = |msg: String| GraphError::BadSlot {
            file: file.to_string(),
            node: n.id.clone(),
            param: slot.name.to_string(),
            msg,
        };
        let value = n.params.get(slot.name);
        let reference =
            |v: &Value| -> Option<String> { v.as_str().and_then(|s| s.strip_prefix('$')).map(str::to_string) };
        let lookup = |name: &str| -> Result<&ParamInfo, GraphError> {
            params
                .iter()
                .find(|p| p.name == name)
                .ok_or_else(|| err(format!("refers to undefined parameter '${name}'")))
        };
        match slot.kind {
            SlotKind::Float { min, max, default } => match value {
                None => floats.push(FloatBinding::Literal(default)),
                Some(v) => {
                    if let Some(name) = reference(v) {
                        let p = lookup(&name)?;
                        if p.kind != ParamKind::Float {
                            return Err(err(format!("'${name}' is not a float parameter")));
                        }
                        floats.push(FloatBinding::Param(p.offset));
                    } else {
                        let x = v.as_f64().ok_or_else(|| err(format!("expected a number or \"$param\", got {v}")))?;
                        if x < min || x > max {
                            return Err(err(format!("value {x} is outside the range [{min}, {max}]")));
                        }
                        floats.push(FloatBinding::Literal(x));
                    }
                }
            },
            SlotKind::Color { default } => match value {
                None => floats.extend(default.iter().map(|&x| FloatBinding::Literal(x))),
                Some(v) => {
                    if let Some(name) = reference(v) {
                        let p = lookup(&name)?;
                        if p.kind != ParamKind::Color {
                            return Err(err(format!("'${name}' is not a color parameter")));
                        }
                        floats.extend((0..3).map(|k| FloatBinding::Param(p.offset + k)));
                    } else {
                        let arr = v
                            .as_array()
                            .filter(|a| a.len() == 3)
                            .ok_or_else(|| err(format!("expected [r, g, b] or \"$param\", got {v}")))?;
                        for c in arr {
                            if let Some(name) = reference(c) {
                                let p = lookup(&name)?;
                                if p.kind != ParamKind::Float {
                                    return Err(err(format!("'${name}' is not a float parameter")));
                                }
                                floats.push(FloatBinding::Param(p.offset));
                            } else {
                                let x =
                                    c.as_f64().ok_or_else(|| err(format!("colour component {c} is not a number")))?;
                                if !(0.0..=1.0).contains(&x) {
                                    return Err(err(format!("colour component {x} is outside [0, 1]")));
                                }
                                floats.push(FloatBinding::Literal(x));
                            }
                        }
                    }
                }
            },
            SlotKind::Int { min, max, default, names } => match value {
                None => ints.push(IntBinding::Literal(default)),
                Some(v) => {
                    if let Some(name) = reference(v) {
                        let p = lookup(&name)?;
                        if p.kind != ParamKind::Int {
                            return Err(err(format!("'${name}' is not an int parameter")));
                        }
                        if p.min[0] < min as f64 || p.max[0] > max as f64 {
                            return Err(err(format!(
                                "range of '${name}' [{}, {}] exceeds [{min}, {max}]",
                                p.min[0], p.max[0]
                            )));
                        }
                        ints.push(IntBinding::Param(p.offset));
                    } else if let Some(s) = v.as_str() {
                        let k = names.iter().position(|&x| x == s).ok_or_else(|| {
                            err(format!(
                                "unknown choice '{s}' (choices: {})",
                                if names.is_empty() { "none, use an integer".to_string() } else { names.join(", ") }
                            ))
                        })?;
                        ints.push(IntBinding::Literal(k as i64));
                    } else {
                        let x = v
                            .as_i64()
                            .ok_or_else(|| err(format!("expected an integer, a choice name or \"$param\", got {v}")))?;
                        if x < min || x > max {
                            return Err(err(format!("value {x} is outside the range [{min}, {max}]")));
                        }
                        ints.push(IntBinding::Literal(x));
                    }
                }
            },
        }
    }
    debug_assert!(floats.len() <= MAX_FLOAT_SLOTS);
    Ok((floats, ints))
}
