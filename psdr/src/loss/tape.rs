//! The tape: ops whose inputs include rendered outputs are recorded here with their backward passes; one
//! reverse sweep from a scalar loss gives d loss / d(every rendered output the loss read).

use crate::base::Image;
use crate::error::{Error, Result};
use std::cell::RefCell;
use std::rc::Rc;

/// What an op is, for the structural queries (`pixelwise_l2`); the arithmetic lives in the backward closures.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Kind {
    Input,
    Add,
    Sub,
    Mul,
    Div,
    Neg,
    Scale(f32),
    L2,
    Other,
}

/// Gradients of an op's operands from the gradient of its output: (output gradient, operand values, which
/// operands need one) -> one optional gradient per operand, each of its operand's shape.
pub(crate) type Backward = Box<dyn Fn(&Image, &[Rc<Image>], &[bool]) -> Vec<Option<Image>>>;

struct Node {
    kind: Kind,
    /// Per operand: the node it comes from, or None for a constant.
    parents: Vec<Option<usize>>,
    operands: Vec<Rc<Image>>,
    backward: Option<Backward>,
    shape: (usize, usize, usize),
}

/// Records ops; cheap to clone (shared), single-threaded.
#[derive(Clone, Default)]
pub struct Tape(Rc<RefCell<Vec<Node>>>);

/// A value in a loss expression: a constant (targets, anything not rendered) or a node on a tape.
#[derive(Clone)]
pub struct Tensor {
    value: Rc<Image>,
    node: Option<(Tape, usize)>,
}

impl std::fmt::Debug for Tensor {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "Tensor({}, on tape: {})", self.value.shape(), self.node.is_some())
    }
}

impl Tensor {
    pub fn constant(image: Image) -> Tensor {
        Tensor { value: Rc::new(image), node: None }
    }
    pub fn scalar(v: f32) -> Tensor {
        Tensor::constant(Image::scalar(v))
    }
    pub fn value(&self) -> &Image {
        &self.value
    }
    pub(crate) fn shared(&self) -> Rc<Image> {
        self.value.clone()
    }
    /// Some(value) for a 1x1x1 tensor.
    pub fn item(&self) -> Option<f32> {
        self.value.is_scalar().then(|| self.value.data[0])
    }
    /// True when the tensor is on a tape (depends on a rendered output).
    pub fn requires_grad(&self) -> bool {
        self.node.is_some()
    }
}

/// d loss / d(each input leaf) of one backward sweep.
pub struct Gradients {
    tape: Tape,
    grads: Vec<Option<Image>>,
}

impl Gradients {
    /// The gradient of the loss with respect to `input` (a leaf of this tape); None when the loss did not read
    /// it.
    pub fn of(&self, input: &Tensor) -> Option<&Image> {
        match &input.node {
            Some((t, i)) if Rc::ptr_eq(&t.0, &self.tape.0) => self.grads.get(*i).and_then(|g| g.as_ref()),
            _ => None,
        }
    }
}

impl Tape {
    pub fn new() -> Tape {
        Tape::default()
    }

    /// A leaf whose gradient is wanted (a rendered output).
    pub fn input(&self, image: Image) -> Tensor {
        let shape = (image.width, image.height, image.channels);
        let mut nodes = self.0.borrow_mut();
        nodes.push(Node { kind: Kind::Input, parents: vec![], operands: vec![], backward: None, shape });
        Tensor { value: Rc::new(image), node: Some((self.clone(), nodes.len() - 1)) }
    }

    /// The reverse sweep from a scalar loss.
    pub fn backward(&self, loss: &Tensor) -> Result<Gradients> {
        if !loss.value.is_scalar() {
            return Err(Error::Invalid(format!("backward: the loss is a {} image, not a scalar", loss.value.shape())));
        }
        let Some((tape, root)) = &loss.node else {
            // A constant loss reads no rendered output.
            return Ok(Gradients { tape: self.clone(), grads: vec![] });
        };
        if !Rc::ptr_eq(&tape.0, &self.0) {
            return Err(Error::Invalid("backward: the loss is on another tape".into()));
        }
        let nodes = self.0.borrow();
        let mut grads: Vec<Option<Image>> = vec![None; nodes.len()];
        grads[*root] = Some(Image::scalar(1.0));
        for i in (0..=*root).rev() {
            let Some(g) = grads[i].take() else { continue };
            let node = &nodes[i];
            let Some(backward) = &node.backward else {
                grads[i] = Some(g); // an input: keep its gradient
                continue;
            };
            let need: Vec<bool> = node.parents.iter().map(Option::is_some).collect();
            for (k, gk) in backward(&g, &node.operands, &need).into_iter().enumerate() {
                if let (Some(p), Some(gk)) = (node.parents[k], gk) {
                    match &mut grads[p] {
                        Some(acc) => acc.data.iter_mut().zip(&gk.data).for_each(|(a, b)| *a += b),
                        slot => *slot = Some(gk),
                    }
                }
            }
        }
        // Only leaves keep gradients.
        for (i, n) in nodes.iter().enumerate() {
            if n.kind != Kind::Input {
                grads[i] = None;
            }
        }
        Ok(Gradients { tape: self.clone(), grads })
    }

    /// Some((T, scale)) when d loss / d input = scale · (input − T) for every value of the input: the loss
    /// reads the input only through L2 terms against one constant T, each reaching the loss through scalar
    /// sums, differences, negations and products or quotients by constants. psdr's fused gradient estimator
    /// needs exactly this form.
    pub fn pixelwise_l2(&self, loss: &Tensor, input: &Tensor) -> Option<(Vec<f32>, f32)> {
        let (lt, root) = loss.node.as_ref()?;
        let (it, leaf) = input.node.as_ref()?;
        if !Rc::ptr_eq(&lt.0, &self.0) || !Rc::ptr_eq(&it.0, &self.0) {
            return None;
        }
        let nodes = self.0.borrow();
        let (root, leaf) = (*root, *leaf);
        // Nodes from which the loss is reached.
        let mut reaches = vec![false; nodes.len()];
        reaches[root] = true;
        for i in (0..=root).rev() {
            if reaches[i] {
                for p in nodes[i].parents.iter().flatten() {
                    reaches[*p] = true;
                }
            }
        }
        if !reaches[leaf] {
            return None;
        }
        // d loss / d node for scalar nodes on affine chains (None: not such a chain), from the root down.
        let mut coef: Vec<Option<f64>> = vec![None; nodes.len()];
        coef[root] = Some(1.0);
        let scalar_const = |k: usize, i: usize| -> Option<f32> {
            let n: &Node = &nodes[i];
            (n.parents[k].is_none() && n.operands[k].is_scalar()).then(|| n.operands[k].data[0])
        };
        let mut target: Option<Vec<f32>> = None;
        let mut scale = 0.0f64;
        for i in (leaf + 1..=root).rev() {
            if !reaches[i] {
                continue;
            }
            let n = &nodes[i];
            let reads_leaf = n.parents.contains(&Some(leaf));
            if reads_leaf {
                // The only ops allowed to read the input: L2 against a constant.
                let k = n.parents.iter().position(|p| *p == Some(leaf))?;
                if n.kind != Kind::L2 || n.parents[1 - k].is_some() {
                    return None;
                }
                let t = &n.operands[1 - k];
                if !t.same_shape(&n.operands[k]) {
                    return None;
                }
                if target.as_ref().is_some_and(|x| x != &t.data) {
                    return None;
                }
                target = Some(t.data.clone());
                scale += coef[i]? * 2.0 / t.data.len() as f64;
                continue;
            }
            let c = match coef[i] {
                Some(c) => c,
                None => {
                    // A node on the way to the loss whose coefficient is unknown: it must not depend on the leaf.
                    if depends_on(&nodes, i, leaf) {
                        return None;
                    }
                    continue;
                }
            };
            if n.shape != (1, 1, 1) && depends_on(&nodes, i, leaf) {
                return None;
            }
            let local: Vec<Option<f64>> = match n.kind {
                Kind::Add => vec![Some(1.0), Some(1.0)],
                Kind::Sub => vec![Some(1.0), Some(-1.0)],
                Kind::Neg => vec![Some(-1.0)],
                Kind::Scale(k) => vec![Some(k as f64)],
                Kind::Mul => vec![scalar_const(1, i).map(|v| v as f64), scalar_const(0, i).map(|v| v as f64)],
                Kind::Div => vec![scalar_const(1, i).map(|v| 1.0 / v as f64), None],
                _ => vec![None; n.parents.len()],
            };
            for (k, p) in n.parents.iter().enumerate() {
                let Some(p) = *p else { continue };
                if !depends_on(&nodes, p, leaf) {
                    continue;
                }
                let l = local.get(k).copied().flatten()?;
                if nodes[p].shape != (1, 1, 1) {
                    return None;
                }
                coef[p] = Some(coef[p].unwrap_or(0.0) + c * l);
            }
        }
        Some((target?, scale as f32))
    }

    /// Pushes an op node; returns its index.
    pub(crate) fn push(
        &self,
        kind: Kind,
        parents: Vec<Option<usize>>,
        operands: Vec<Rc<Image>>,
        shape: (usize, usize, usize),
        backward: Backward,
    ) -> usize {
        let mut nodes = self.0.borrow_mut();
        nodes.push(Node { kind, parents, operands, backward: Some(backward), shape });
        nodes.len() - 1
    }
}

/// True when node i depends on node `leaf` (reads it, directly or not).
fn depends_on(nodes: &[Node], i: usize, leaf: usize) -> bool {
    if i == leaf {
        return true;
    }
    if i < leaf {
        return false;
    }
    nodes[i].parents.iter().flatten().any(|&p| depends_on(nodes, p, leaf))
}

/// Records an op over `inputs` with output `value`: a constant when no input is on a tape, else a node on the
/// inputs' tape (inputs from two tapes are an error).
pub(crate) fn record(op: &str, inputs: &[&Tensor], value: Image, kind: Kind, backward: Backward) -> Result<Tensor> {
    let mut tape: Option<Tape> = None;
    for t in inputs {
        if let Some((tt, _)) = &t.node {
            match &tape {
                Some(x) if !Rc::ptr_eq(&x.0, &tt.0) => {
                    return Err(Error::Invalid(format!("{op}: inputs come from two different tapes")))
                }
                _ => tape = Some(tt.clone()),
            }
        }
    }
    if let Some(i) = value.data.iter().position(|v| !v.is_finite()) {
        return Err(Error::Invalid(format!("{op}: output value {i} is {} (not finite)", value.data[i])));
    }
    let Some(tape) = tape else {
        return Ok(Tensor::constant(value));
    };
    let parents = inputs.iter().map(|t| t.node.as_ref().map(|(_, i)| *i)).collect();
    let operands = inputs.iter().map(|t| t.shared()).collect();
    let shape = (value.width, value.height, value.channels);
    let i = tape.push(kind, parents, operands, shape, backward);
    Ok(Tensor { value: Rc::new(value), node: Some((tape, i)) })
}
