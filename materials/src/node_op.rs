//! The node interface the evaluator drives, and the schema every node type declares.

use crate::image::Image;

/// Most float slots any node type has (sizes the stack arrays of the dual kernels).
pub const MAX_FLOAT_SLOTS: usize = 40;
/// Most inputs any node type has.
pub const MAX_INPUTS: usize = 3;

/// Kind and range of one node parameter slot.
#[derive(Clone, Copy, Debug)]
pub enum SlotKind {
    /// A continuous scalar.
    Float { min: f64, max: f64, default: f64 },
    /// An RGB triple in [0, 1] (three float slots).
    Color { default: [f64; 3] },
    /// An integer choice; `names` optionally gives symbolic values 0, 1, 2, ...
    Int { min: i64, max: i64, default: i64, names: &'static [&'static str] },
}

/// One named parameter slot of a node type.
#[derive(Clone, Copy, Debug)]
pub struct SlotSpec {
    pub name: &'static str,
    pub kind: SlotKind,
    pub doc: &'static str,
}

/// Channel requirement of an input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channels {
    Gray,
    Color,
    Any,
}

/// One named input of a node type.
#[derive(Clone, Copy, Debug)]
pub struct InputSpec {
    pub name: &'static str,
    pub channels: Channels,
    pub optional: bool,
}

/// How a node's output channel count is decided.
#[derive(Clone, Copy, Debug)]
pub enum OutRule {
    Gray,
    Color,
    /// Colour if any connected input is colour, otherwise grey.
    WidestInput,
}

/// Static description of a node type.
pub struct NodeSpec {
    pub name: &'static str,
    pub doc: &'static str,
    pub inputs: &'static [InputSpec],
    pub slots: &'static [SlotSpec],
    pub out: OutRule,
    pub op: &'static dyn NodeOp,
}

/// Resolved arguments of one node evaluation.
pub struct NodeArgs<'a> {
    pub size: usize,
    /// Float slot values (colours flattened), in schema order.
    pub f: &'a [f64],
    /// Int slot values, in schema order.
    pub i: &'a [i64],
    pub out_channels: usize,
}

/// What the backward pass of one node may write.
pub struct BackwardCtx<'a> {
    /// Per float slot: is its gradient wanted?
    pub active: &'a [bool],
    /// Per input: is its gradient wanted (input connected and depends on a parameter)?
    pub need_in: &'a [bool],
    /// Per float slot, accumulated (+=).
    pub d_params: &'a mut [f64],
    /// Per input, same shape as that input, zeroed by the caller, accumulated (+=).
    pub d_ins: &'a mut [Image],
    /// Per-row partial sums for deterministic parameter reductions (N * MAX_FLOAT_SLOTS).
    pub row_acc: &'a mut Vec<f64>,
    /// Free scratch, reused across calls.
    pub scratch: &'a mut Vec<f64>,
}

/// Forward and exact reverse-mode backward of a node type.
pub trait NodeOp: Send + Sync {
    fn forward(&self, a: &NodeArgs, ins: &[Option<&Image>], out: &mut Image, scratch: &mut Vec<f64>);
    fn backward(&self, a: &NodeArgs, ins: &[Option<&Image>], out: &Image, d_out: &Image, cx: BackwardCtx);
}

/// Sums per-row partials `row_acc[row * stride + k]` into `d[k]` in row order
/// (a fixed order, so results do not depend on the thread count).
pub fn reduce_rows(row_acc: &[f64], rows: usize, stride: usize, d: &mut [f64], lanes: &[usize]) {
    for r in 0..rows {
        let acc = &row_acc[r * stride..r * stride + lanes.len()];
        for (k, &slot) in lanes.iter().enumerate() {
            d[slot] += acc[k];
        }
    }
}

/// Shared mutable buffer written by parallel row tasks, each touching only its own row.
pub struct RowWriter<'a> {
    ptr: *mut f64,
    len: usize,
    _m: std::marker::PhantomData<&'a mut [f64]>,
}
// SAFETY: tasks write disjoint index ranges (one image row each); see `row`.
unsafe impl Send for RowWriter<'_> {}
unsafe impl Sync for RowWriter<'_> {}

impl<'a> RowWriter<'a> {
    pub fn new(buf: &'a mut [f64]) -> Self {
        RowWriter { ptr: buf.as_mut_ptr(), len: buf.len(), _m: std::marker::PhantomData }
    }
    /// Mutable view of `[start, start + n)`.
    ///
    /// # Safety
    /// Concurrent callers must request disjoint ranges.
    #[allow(clippy::mut_from_ref)]
    pub unsafe fn range(&self, start: usize, n: usize) -> &mut [f64] {
        assert!(start + n <= self.len);
        std::slice::from_raw_parts_mut(self.ptr.add(start), n)
    }
}
