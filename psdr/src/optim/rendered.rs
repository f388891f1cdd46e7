//! What a loss closure reads: one iteration's render as tensors on the iteration's tape. Radiance, depth and
//! coverage masks are tape inputs (the loss's gradient flows back into the renderer through them); albedo and
//! normals are constants (the renderer has no adjoint for them). An output becomes a tape input the first time
//! the loss reads it, so outputs a loss ignores cost nothing in the backward pass.

use crate::error::{Error, Result};
use crate::grad::OutputAdjoints;
use crate::loss::{Gradients, Image, Tape, Tensor};
use crate::render::Frame;
use std::cell::{Cell, RefCell};

pub struct Rendered {
    tape: Tape,
    frame: Frame,
    object_names: Vec<String>,
    /// False in the fused estimator's pass, which yields radiance only.
    has_aovs: bool,
    /// False for a plain render (a script's `render()`): its outputs are constants, on no tape.
    on_tape: bool,
    /// Set when the loss asked for an output this pass does not have (the optimiser then renders them all).
    missing: Cell<bool>,
    radiance: RefCell<Option<Tensor>>,
    depth: RefCell<Option<Tensor>>,
    masks: RefCell<Vec<(usize, Tensor)>>,
}

impl Rendered {
    /// A full frame: radiance and every AOV.
    pub fn new(frame: Frame, object_names: Vec<String>) -> Rendered {
        Rendered::with(frame, object_names, true)
    }

    /// A plain render whose outputs are constants (nothing will be differentiated through them).
    pub fn constant(frame: Frame, object_names: Vec<String>) -> Rendered {
        Rendered { on_tape: false, ..Rendered::with(frame, object_names, true) }
    }

    /// Radiance only (`radiance` w·h·3 values); reading an AOV marks the pass as missing it.
    pub fn radiance_only(width: u32, height: u32, radiance: Vec<f32>, object_names: Vec<String>) -> Rendered {
        let frame = Frame { width, height, object_count: object_names.len() as u32, radiance, ..Default::default() };
        Rendered::with(frame, object_names, false)
    }

    fn with(frame: Frame, object_names: Vec<String>, has_aovs: bool) -> Rendered {
        Rendered {
            tape: Tape::new(),
            frame,
            object_names,
            has_aovs,
            on_tape: true,
            missing: Cell::new(false),
            radiance: RefCell::new(None),
            depth: RefCell::new(None),
            masks: RefCell::new(vec![]),
        }
    }

    pub fn tape(&self) -> &Tape {
        &self.tape
    }
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
    pub fn width(&self) -> usize {
        self.frame.width as usize
    }
    pub fn height(&self) -> usize {
        self.frame.height as usize
    }

    fn image(&self, channels: usize, data: Vec<f32>) -> Result<Image> {
        Image::new(self.width(), self.height(), channels, data)
    }

    /// A rendered output as a tape input (or a constant for a plain render).
    fn leaf(&self, image: Image) -> Tensor {
        if self.on_tape {
            self.tape.input(image)
        } else {
            Tensor::constant(image)
        }
    }

    fn need_aovs(&self, what: &str) -> Result<()> {
        if self.has_aovs {
            return Ok(());
        }
        self.missing.set(true);
        Err(Error::Invalid(format!("{what} is not rendered in this pass (radiance-only estimator)")))
    }

    /// True when the loss read an output this pass lacks.
    pub fn missed_output(&self) -> bool {
        self.missing.get()
    }

    /// Linear RGB radiance, 3 channels.
    pub fn radiance(&self) -> Result<Tensor> {
        if let Some(t) = &*self.radiance.borrow() {
            return Ok(t.clone());
        }
        let t = self.leaf(self.image(3, self.frame.radiance.clone())?);
        *self.radiance.borrow_mut() = Some(t.clone());
        Ok(t)
    }

    /// Camera-space depth of the primary hit (0 where the pixel sees nothing), anti-aliased, 1 channel.
    pub fn depth(&self) -> Result<Tensor> {
        self.need_aovs("depth")?;
        if let Some(t) = &*self.depth.borrow() {
            return Ok(t.clone());
        }
        let t = self.leaf(self.image(1, self.frame.depth.clone())?);
        *self.depth.borrow_mut() = Some(t.clone());
        Ok(t)
    }

    /// The anti-aliased coverage mask of the named object (fraction of each pixel it covers), 1 channel.
    pub fn mask(&self, object: &str) -> Result<Tensor> {
        self.need_aovs(&format!("the mask of '{object}'"))?;
        let o = self.object_names.iter().position(|n| n == object).ok_or_else(|| {
            Error::Invalid(format!("mask: no object named '{object}'; objects are {:?}", self.object_names))
        })?;
        if let Some((_, t)) = self.masks.borrow().iter().find(|(i, _)| *i == o) {
            return Ok(t.clone());
        }
        let t = self.leaf(self.image(1, self.frame.mask(o))?);
        self.masks.borrow_mut().push((o, t.clone()));
        Ok(t)
    }

    /// Diffuse albedo of the primary hit (a constant: no gradient flows through it).
    pub fn albedo(&self) -> Result<Tensor> {
        self.need_aovs("albedo")?;
        Ok(Tensor::constant(self.image(3, self.frame.albedo.clone())?))
    }

    /// Shading normal of the primary hit (a constant).
    pub fn normal(&self) -> Result<Tensor> {
        self.need_aovs("normal")?;
        Ok(Tensor::constant(self.image(3, self.frame.normal.clone())?))
    }

    /// The radiance tensor if the loss read it.
    pub fn radiance_read(&self) -> Option<Tensor> {
        self.radiance.borrow().clone()
    }

    /// True when the loss read some output other than radiance.
    pub fn read_aovs(&self) -> bool {
        self.depth.borrow().is_some() || !self.masks.borrow().is_empty()
    }

    /// The adjoint images of every output the loss read, from the tape's backward pass.
    pub fn adjoints(&self, grads: &Gradients) -> OutputAdjoints {
        let of = |t: &Option<Tensor>| t.as_ref().and_then(|t| grads.of(t)).map(|g| g.data.clone());
        OutputAdjoints {
            radiance: of(&self.radiance.borrow()),
            depth: of(&self.depth.borrow()),
            masks: self.masks.borrow().iter().filter_map(|(o, t)| grads.of(t).map(|g| (*o, g.data.clone()))).collect(),
        }
    }
}
