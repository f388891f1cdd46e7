//! Forward evaluation and reverse-mode backward of a compiled graph at one
//! resolution. All buffers live in the evaluator and are reused across calls.

use crate::graph::{FloatBinding, Graph, IntBinding, Params};
use crate::image::Image;
use crate::node_op::{BackwardCtx, NodeArgs, MAX_INPUTS};
use crate::render_maps::{RenderGrads, RenderMaps};
use rayon::prelude::*;

/// Which material output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapKind {
    BaseColor,
    Roughness,
    Normal,
    Height,
}

/// Row accumulator lanes per image row (the dual kernels use 16).
const ROW_ACC_LANES: usize = 16;

/// Evaluates one graph at one size; call [`Evaluator::forward`] then [`Evaluator::backward`].
pub struct Evaluator {
    graph: Graph,
    size: usize,
    images: Vec<Image>,
    grads: Vec<Image>,
    /// Per node, per input: that input's gradient from this node alone.
    local_d_ins: Vec<Vec<Image>>,
    scratch: Vec<Vec<f64>>,
    row_acc: Vec<f64>,
    /// Per node: resolved float / int slot values of the last forward.
    fvals: Vec<Vec<f64>>,
    ivals: Vec<Vec<i64>>,
    d_slots: Vec<Vec<f64>>,
    active: Vec<Vec<bool>>,
    need_in: Vec<Vec<bool>>,
    need_grad: Vec<bool>,
    maps: RenderMaps,
    evaluated: bool,
}

impl Evaluator {
    /// Allocates every buffer for `graph` at `size` x `size`.
    pub fn new(graph: Graph, size: usize) -> Self {
        let size = size.max(1);
        let nodes = &graph.nodes;
        let mut need_grad = vec![false; nodes.len()];
        let mut active = Vec::with_capacity(nodes.len());
        let mut need_in = Vec::with_capacity(nodes.len());
        for (k, n) in nodes.iter().enumerate() {
            let a: Vec<bool> = n.floats.iter().map(|b| matches!(b, FloatBinding::Param(_))).collect();
            let ni: Vec<bool> = n.inputs.iter().map(|i| i.is_some_and(|s| need_grad[s])).collect();
            need_grad[k] = a.iter().any(|&x| x) || ni.iter().any(|&x| x);
            active.push(a);
            need_in.push(ni);
        }
        let images: Vec<Image> = nodes.iter().map(|n| Image::new(size, n.channels)).collect();
        let grads = nodes
            .iter()
            .enumerate()
            .map(|(k, n)| if need_grad[k] { Image::new(size, n.channels) } else { Image::default() })
            .collect();
        let local_d_ins = nodes
            .iter()
            .enumerate()
            .map(|(k, n)| {
                n.inputs
                    .iter()
                    .enumerate()
                    .map(|(j, i)| match i {
                        Some(s) if need_in[k][j] => Image::new(size, nodes[*s].channels),
                        _ => Image::default(),
                    })
                    .collect()
            })
            .collect();
        let maps = RenderMaps {
            size,
            albedo_linear: vec![0.0; size * size * 3],
            roughness: vec![0.0; size * size],
            normal: vec![0.0; size * size * 3],
            height: graph.outputs.height.map(|_| vec![0.0; size * size]),
        };
        Evaluator {
            fvals: nodes.iter().map(|n| vec![0.0; n.floats.len()]).collect(),
            ivals: nodes.iter().map(|n| vec![0; n.ints.len()]).collect(),
            d_slots: nodes.iter().map(|n| vec![0.0; n.floats.len()]).collect(),
            scratch: vec![Vec::new(); nodes.len()],
            row_acc: vec![0.0; size * ROW_ACC_LANES],
            images,
            grads,
            local_d_ins,
            need_grad,
            active,
            need_in,
            maps,
            size,
            graph,
            evaluated: false,
        }
    }

    pub fn graph(&self) -> &Graph {
        &self.graph
    }

    pub fn size(&self) -> usize {
        self.size
    }

    /// Evaluates every node of the graph (no output conversion).
    pub fn evaluate(&mut self, params: &Params) {
        assert_eq!(params.floats.len(), self.graph.n_floats, "float parameter count");
        assert_eq!(params.ints.len(), self.graph.n_ints, "int parameter count");
        for (k, n) in self.graph.nodes.iter().enumerate() {
            for (v, b) in self.fvals[k].iter_mut().zip(&n.floats) {
                *v = match *b {
                    FloatBinding::Literal(x) => x,
                    FloatBinding::Param(p) => params.floats[p],
                };
            }
            for (v, b) in self.ivals[k].iter_mut().zip(&n.ints) {
                *v = match *b {
                    IntBinding::Literal(x) => x,
                    IntBinding::Param(p) => params.ints[p],
                };
            }
            let (done, rest) = self.images.split_at_mut(k);
            let mut ins: [Option<&Image>; MAX_INPUTS] = [None; MAX_INPUTS];
            for (j, i) in n.inputs.iter().enumerate() {
                ins[j] = i.map(|s| &done[s]);
            }
            let args = NodeArgs { size: self.size, f: &self.fvals[k], i: &self.ivals[k], out_channels: n.channels };
            n.spec.op.forward(&args, &ins[..n.inputs.len()], &mut rest[0], &mut self.scratch[k]);
        }
        self.evaluated = true;
    }

    /// The output image of node `id` after the last evaluation.
    pub fn node_image(&self, id: &str) -> Option<&Image> {
        let k = self.graph.nodes.iter().position(|n| n.id == id)?;
        Some(&self.images[k])
    }

    /// Forward: evaluates the graph and converts its outputs to renderer maps.
    pub fn forward(&mut self, params: &Params) -> &RenderMaps {
        self.evaluate(params);
        let o = self.graph.outputs;
        crate::render_maps::fill_maps(
            &mut self.maps,
            &self.images[o.base_color],
            &self.images[o.roughness],
            o.normal.map(|k| &self.images[k]),
            o.height.map(|k| &self.images[k]),
        );
        &self.maps
    }

    /// The graph's own (f64) image behind one output map, after the last evaluation
    /// (`base_color` is sRGB and may be grey; `None` for absent normal / height).
    pub fn output_image(&self, map: MapKind) -> Option<&Image> {
        let o = self.graph.outputs;
        let k = match map {
            MapKind::BaseColor => Some(o.base_color),
            MapKind::Roughness => Some(o.roughness),
            MapKind::Normal => o.normal,
            MapKind::Height => o.height,
        }?;
        Some(&self.images[k])
    }

    /// The maps of the last [`Evaluator::forward`].
    pub fn maps(&self) -> &RenderMaps {
        &self.maps
    }

    /// Backward from renderer gradients (each optional, shaped like [`RenderMaps`])
    /// to dL/d(continuous parameters), added into `grad` (len [`Graph::num_floats`]).
    /// Uses the state of the last forward call.
    pub fn backward(&mut self, g: &RenderGrads, grad: &mut [f64]) {
        assert!(self.evaluated, "backward before forward");
        self.clear_grads();
        let o = self.graph.outputs;
        let wanted = [
            (Some(o.base_color), g.albedo_linear.is_some()),
            (Some(o.roughness), g.roughness.is_some()),
            (o.normal, g.normal.is_some()),
            (o.height, g.height.is_some()),
        ];
        // One seeding per node: a node may feed several maps (seed adds them all).
        let mut seeded: [Option<usize>; 4] = [None; 4];
        for (slot, (k, want)) in wanted.into_iter().enumerate() {
            if let (Some(k), true) = (k, want) {
                if self.need_grad[k] && !seeded.contains(&Some(k)) {
                    crate::render_maps::seed(k, o, g, &self.images[k], &mut self.grads[k]);
                    seeded[slot] = Some(k);
                }
            }
        }
        self.run_backward(grad);
    }

    /// Backward from dL/d(output texels of node `id`) (shaped like its image).
    /// Panics if there is no such node (a test and tooling entry point).
    pub fn backward_node(&mut self, id: &str, d_out: &[f64], grad: &mut [f64]) {
        assert!(self.evaluated, "backward before forward");
        let k = self.graph.nodes.iter().position(|n| n.id == id).expect("unknown node id");
        self.clear_grads();
        if self.need_grad[k] {
            self.grads[k].data.copy_from_slice(d_out);
        }
        self.run_backward(grad);
    }

    fn clear_grads(&mut self) {
        for (k, g) in self.grads.iter_mut().enumerate() {
            if self.need_grad[k] {
                g.data.par_iter_mut().for_each(|x| *x = 0.0);
            }
        }
    }

    fn run_backward(&mut self, grad: &mut [f64]) {
        assert_eq!(grad.len(), self.graph.n_floats, "gradient length");
        for k in (0..self.graph.nodes.len()).rev() {
            if !self.need_grad[k] || self.grads[k].data.iter().all(|&x| x == 0.0) {
                continue;
            }
            let n = &self.graph.nodes[k];
            for (j, d) in self.local_d_ins[k].iter_mut().enumerate() {
                if self.need_in[k][j] {
                    d.data.par_iter_mut().for_each(|x| *x = 0.0);
                }
            }
            self.d_slots[k].iter_mut().for_each(|x| *x = 0.0);
            let mut ins: [Option<&Image>; MAX_INPUTS] = [None; MAX_INPUTS];
            for (j, i) in n.inputs.iter().enumerate() {
                ins[j] = i.map(|s| &self.images[s]);
            }
            let args = NodeArgs { size: self.size, f: &self.fvals[k], i: &self.ivals[k], out_channels: n.channels };
            n.spec.op.backward(
                &args,
                &ins[..n.inputs.len()],
                &self.images[k],
                &self.grads[k],
                BackwardCtx {
                    active: &self.active[k],
                    need_in: &self.need_in[k],
                    d_params: &mut self.d_slots[k],
                    d_ins: &mut self.local_d_ins[k],
                    row_acc: &mut self.row_acc,
                    scratch: &mut self.scratch[k],
                },
            );
            for (s, b) in n.floats.iter().enumerate() {
                if let FloatBinding::Param(p) = *b {
                    grad[p] += self.d_slots[k][s];
                }
            }
            for (j, i) in n.inputs.iter().enumerate() {
                if let (Some(src), true) = (*i, self.need_in[k][j]) {
                    let local = &self.local_d_ins[k][j].data;
                    self.grads[src].data.par_iter_mut().zip(local.par_iter()).for_each(|(a, b)| *a += *b);
                }
            }
        }
    }
}
