//! The optimisation loop: render, evaluate the loss on a tape, backpropagate through the tape and the
//! renderer's adjoint, take an Adam step in each parameter's own parametrisation, project onto the bounds.
//! A divergence guard restores the best state and halves the rates on a non-finite gradient or a loss that
//! rises past a factor of its best; repeated divergence ends the optimisation with a message, best state kept.

use super::adam::{AdamConfig, AdamState};
use super::checkpoint::{BestState, Checkpoint, CHECKPOINT_FORMAT};
use super::parametrization::ParamSpec;
use super::rendered::Rendered;
use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::grad::{
    moves_geometry, outputs_vjp, BoundarySamples, GradLayout, GradientEvaluator, ParamPath, PixelwiseAdjoint,
    ADJOINT_SEED_OFFSET,
};
use crate::loss::{self, Tensor};
use crate::optim::IterationRecord;
use crate::scene::{RenderSettings, Scene};
use std::path::PathBuf;
use std::rc::Rc;
use std::time::Instant;

/// A loss: named scalar terms (their sum is minimised) of one iteration's render.
pub type LossFn<'a> = dyn FnMut(Rc<Rendered>) -> Result<Vec<(String, Tensor)>> + 'a;

#[derive(Clone, Debug)]
pub struct OptimizeOptions {
    pub iters: usize,
    pub spp: u32,
    /// Iteration t renders with seed + t (primal) and seed + t + ADJOINT_SEED_OFFSET (adjoint).
    pub seed: u32,
    /// None: the scene's.
    pub max_depth: Option<u32>,
    /// Primary boundary samples per iteration (sppe) and secondary samples per path vertex (sppse).
    pub edge_samples: u32,
    pub secondary_edge_samples: u32,
    pub adam: AdamConfig,
    /// A loss above factor × best loss counts as divergence.
    pub divergence_factor: f64,
    /// Divergences tolerated; one more ends the optimisation.
    pub max_divergences: usize,
    /// Use the fused primal-adjoint estimator when the loss allows it (an L2 radiance term of material and
    /// light parameters; see grad/interior/fused_l2.rs).
    pub fused: bool,
    /// Write the state to `checkpoint` every this many iterations (0: only at the end).
    pub checkpoint_every: usize,
    pub checkpoint: Option<PathBuf>,
    /// Continue from `checkpoint` if it exists.
    pub resume: bool,
    /// After every step, each object whose translation is optimised is moved along the floor by the least that
    /// keeps all of it between the room's walls (`scene::keep_inside_walls`; no effect without the room
    /// surfaces): furniture cut by a wall has image edges no mesh edge carries, and their gradient is missing.
    pub keep_inside_room: bool,
}

impl Default for OptimizeOptions {
    fn default() -> Self {
        OptimizeOptions {
            iters: 100,
            spp: 4,
            seed: 0,
            max_depth: None,
            edge_samples: 1 << 14,
            secondary_edge_samples: 1,
            adam: AdamConfig::default(),
            divergence_factor: 10.0,
            max_divergences: 3,
            fused: true,
            checkpoint_every: 10,
            checkpoint: None,
            resume: false,
            keep_inside_room: false,
        }
    }
}

/// What an optimisation did.
#[derive(Clone, Debug)]
pub struct OptimizeOutcome {
    pub records: Vec<IterationRecord>,
    /// Divergences and other notable events, as sentences.
    pub events: Vec<String>,
    /// Why it ended early (repeated divergence), if it did; the scene then holds the best state.
    pub stopped: Option<String>,
    pub best_loss: Option<f64>,
    /// Iterations run by this call (fewer than `iters` when resumed from a checkpoint).
    pub iterations_run: usize,
    /// Iterations whose gradient came from the fused estimator.
    pub fused_iterations: usize,
}

/// Values of parameters longer than this are not recorded per iteration (vertices: the record would dwarf
/// the run).
const RECORD_MAX_VALUES: usize = 64;

/// Runs the optimisation of `specs` on `scene` (which ends in the final state) for `opts.iters` iterations.
/// `observe` sees each iteration's record (progress bars, logs).
pub fn optimize(
    scene: &mut Scene,
    specs: &[ParamSpec],
    loss_fn: &mut LossFn,
    opts: &OptimizeOptions,
    backend: &mut dyn Backend,
    observe: &mut dyn FnMut(&IterationRecord),
) -> Result<OptimizeOutcome> {
    if specs.is_empty() {
        return Err(Error::Invalid("optimize: no parameters selected".into()));
    }
    for s in specs {
        s.check()?;
    }
    if opts.spp == 0 {
        return Err(Error::Invalid("optimize: spp must be at least 1".into()));
    }
    if opts.divergence_factor.is_nan() || opts.divergence_factor <= 1.0 {
        return Err(Error::Invalid(format!("optimize: divergence factor {} must exceed 1", opts.divergence_factor)));
    }
    let paths: Vec<ParamPath> = specs.iter().map(|s| s.path.clone()).collect();
    let mut st = State::start(scene, specs, opts)?;
    let mut evaluator = GradientEvaluator::default();
    let (mut ran, mut fused_count) = (0, 0);
    while st.next < opts.iters && st.stopped.is_none() {
        let t = st.next;
        apply(scene, specs, &st.u)?;
        let thetas: Vec<Vec<f32>> = specs.iter().zip(&st.u).map(|(s, u)| s.to_theta(u)).collect();
        let e = evaluate(scene, &mut evaluator, &paths, loss_fn, opts, t, backend)?;
        fused_count += e.fused as usize;
        let Evaluation { total, terms, grad: g, seconds: [t_render, t_loss, t_backward], .. } = e;
        let loss = total.item().map(|v| v as f64).unwrap_or(f64::NAN);
        let t3 = Instant::now();
        let record_terms: Vec<(String, f64)> = if terms.len() > 1 {
            terms.iter().map(|(n, v)| (n.clone(), v.item().map(|x| x as f64).unwrap_or(f64::NAN))).collect()
        } else {
            vec![]
        };
        st.iterate(specs, opts, t, loss, &g, &thetas)?;
        if opts.keep_inside_room {
            keep_inside_room(scene, specs, &mut st.u)?;
        }
        let record = IterationRecord {
            iteration: t,
            loss,
            terms: record_terms,
            seconds_render: t_render,
            seconds_loss: t_loss,
            seconds_backward: t_backward,
            seconds_step: t3.elapsed().as_secs_f64(),
            values: thetas.iter().map(|v| if v.len() <= RECORD_MAX_VALUES { v.clone() } else { vec![] }).collect(),
        };
        observe(&record);
        st.records.push(record);
        ran += 1;
        if let Some(path) = &opts.checkpoint {
            let due = opts.checkpoint_every > 0 && st.next % opts.checkpoint_every == 0;
            if due || st.next >= opts.iters || st.stopped.is_some() {
                st.checkpoint(specs).write(path)?;
            }
        }
    }
    apply(scene, specs, &st.u)?;
    if let Some(path) = &opts.checkpoint {
        st.checkpoint(specs).write(path)?;
    }
    Ok(OptimizeOutcome {
        records: st.records,
        events: st.events,
        stopped: st.stopped,
        best_loss: st.best.map(|b| b.loss),
        iterations_run: ran,
        fused_iterations: fused_count,
    })
}

/// One evaluation of the loss and its gradient.
pub struct Evaluation {
    pub total: Tensor,
    pub terms: Vec<(String, Tensor)>,
    /// dLoss/dθ of every parameter, in order, each parameter's floats in a row.
    pub grad: Vec<f64>,
    /// Seconds spent rendering, evaluating the loss, and backpropagating (tape + renderer adjoint).
    pub seconds: [f64; 3],
    /// Whether the fused primal-adjoint estimator produced it.
    pub fused: bool,
}

/// The loss and its gradient with respect to `paths` at the scene's current state, as iteration `t` of an
/// optimisation computes them (seeds `opts.seed + t`): what scripts call `gradient`, and what tests compare.
pub fn gradient(
    scene: &Scene,
    paths: &[ParamPath],
    loss_fn: &mut LossFn,
    opts: &OptimizeOptions,
    backend: &mut dyn Backend,
) -> Result<Evaluation> {
    evaluate(scene, &mut GradientEvaluator::default(), paths, loss_fn, opts, 0, backend)
}

fn evaluate(
    scene: &Scene,
    evaluator: &mut GradientEvaluator,
    paths: &[ParamPath],
    loss_fn: &mut LossFn,
    opts: &OptimizeOptions,
    t: usize,
    backend: &mut dyn Backend,
) -> Result<Evaluation> {
    let geometry = paths.iter().any(moves_geometry);
    let names: Vec<String> = scene.objects.iter().map(|o| o.name.clone()).collect();
    let mut settings =
        RenderSettings { spp: opts.spp, seed: opts.seed.wrapping_add(t as u32), ..scene.settings.clone() };
    if let Some(d) = opts.max_depth {
        settings.max_depth = d;
    }
    let t0 = Instant::now();
    let data = evaluator.prepare(scene)?;
    let boundary = BoundarySamples { primary: opts.edge_samples, secondary: opts.secondary_edge_samples };

    // The fused estimator when the loss is an L2 of radiance against a constant (probed on a black image:
    // the closure's structure, not its values, decides) and no parameter moves geometry.
    if opts.fused && !geometry && settings.spp >= 2 {
        if let Some((target, scale)) = probe_pixelwise(scene, &names, loss_fn) {
            let layout = GradLayout::new(scene, paths)?;
            let px = PixelwiseAdjoint { target: &target, scale };
            let seed_b = settings.seed.wrapping_add(ADJOINT_SEED_OFFSET);
            let (g, image) = crate::grad::radiance_vjp_cross_on(backend, data, &settings, &layout, &px, seed_b)?;
            let t_render = t0.elapsed().as_secs_f64();
            let t1 = Instant::now();
            let r = Rc::new(Rendered::radiance_only(scene.camera.width, scene.camera.height, image, names.clone()));
            if let Ok(terms) = loss_fn(r.clone()) {
                let total = sum_terms(&terms)?;
                let same = r.radiance_read().and_then(|rad| r.tape().pixelwise_l2(&total, &rad));
                if !r.missed_output() && same.as_ref() == Some(&(target.clone(), scale)) {
                    let grad = crate::grad::in_param_order(scene, paths, g, vec![])?;
                    let seconds = [t_render, t1.elapsed().as_secs_f64(), 0.0];
                    return Ok(Evaluation { total, terms, grad, seconds, fused: true });
                }
            }
        }
    }
    let t0 = Instant::now();
    let frame = backend.render(data, &settings, &|_, _| {})?;
    let t_render = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let r = Rc::new(Rendered::new(frame, names));
    let terms = loss_fn(r.clone())?;
    let total = sum_terms(&terms)?;
    let t_loss = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let grads = r.tape().backward(&total)?;
    let adjoints = r.adjoints(&grads);
    let mut adj_settings = settings.clone();
    adj_settings.seed = settings.seed.wrapping_add(ADJOINT_SEED_OFFSET);
    let grad = if adjoints.is_empty() {
        let mut n = 0;
        for p in paths {
            n += p.get(scene)?.len();
        }
        vec![0.0; n]
    } else {
        outputs_vjp(scene, data, &adj_settings, paths, &adjoints, boundary, backend)?
    };
    Ok(Evaluation { total, terms, grad, seconds: [t_render, t_loss, t2.elapsed().as_secs_f64()], fused: false })
}

/// The sum of the loss terms; each must be a scalar.
fn sum_terms(terms: &[(String, Tensor)]) -> Result<Tensor> {
    let mut total: Option<Tensor> = None;
    for (name, t) in terms {
        if t.item().is_none() {
            let v = t.value();
            return Err(Error::Invalid(format!(
                "loss term '{name}' is a {}x{}x{} image, not a scalar: reduce it (l1, l2, mean, ...)",
                v.width, v.height, v.channels
            )));
        }
        total = Some(match total {
            None => t.clone(),
            Some(s) => loss::add(&s, t)?,
        });
    }
    total.ok_or_else(|| Error::Invalid("the loss has no terms".into()))
}

/// Runs the loss on a black radiance image to learn whether it is c·L2(radiance, T) for a constant T, and
/// which T and c; None when it reads anything else or has another form.
fn probe_pixelwise(scene: &Scene, names: &[String], loss_fn: &mut LossFn) -> Option<(Vec<f32>, f32)> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let r = Rc::new(Rendered::radiance_only(w, h, vec![0.0; (w * h * 3) as usize], names.to_vec()));
    let terms = loss_fn(r.clone()).ok()?;
    let total = sum_terms(&terms).ok()?;
    if r.missed_output() || r.read_aovs() {
        return None;
    }
    r.tape().pixelwise_l2(&total, &r.radiance_read()?)
}

/// Sets every parameter's θ(u) in the scene.
fn apply(scene: &mut Scene, specs: &[ParamSpec], u: &[Vec<f64>]) -> Result<()> {
    for (s, u) in specs.iter().zip(u) {
        s.path.set(scene, &s.to_theta(u))?;
    }
    Ok(())
}

/// `OptimizeOptions::keep_inside_room`: the state `u` applied, every object whose translation is a parameter
/// moved back between the walls, and its translation's `u` read back.
fn keep_inside_room(scene: &mut Scene, specs: &[ParamSpec], u: &mut [Vec<f64>]) -> Result<()> {
    apply(scene, specs, u)?;
    let Some(room) = crate::scene::room_box(scene) else { return Ok(()) };
    for (k, s) in specs.iter().enumerate() {
        let ParamPath::Translation(name) = &s.path else { continue };
        let Some(i) = scene.objects.iter().position(|o| &o.name == name) else { continue };
        if crate::scene::keep_inside_walls(scene, i, room) != glam::Vec3::ZERO {
            u[k] = s.to_u(&s.path.get(scene)?);
            s.project(&mut u[k]);
        }
    }
    Ok(())
}

/// The optimiser's mutable state (what a checkpoint holds).
struct State {
    next: usize,
    u: Vec<Vec<f64>>,
    adam: Vec<AdamState>,
    lr_scale: f64,
    divergences: usize,
    best: Option<BestState>,
    records: Vec<IterationRecord>,
    events: Vec<String>,
    stopped: Option<String>,
}

impl State {
    fn start(scene: &Scene, specs: &[ParamSpec], opts: &OptimizeOptions) -> Result<State> {
        if let (true, Some(path)) = (opts.resume, &opts.checkpoint) {
            if let Some(c) = Checkpoint::read(path)? {
                if c.specs.iter().map(|s| &s.path).ne(specs.iter().map(|s| &s.path)) {
                    return Err(Error::io(
                        path,
                        "checkpoint is of other parameters than this optimisation; delete it or run without --resume",
                    ));
                }
                return Ok(State {
                    next: c.next_iteration,
                    u: c.u,
                    adam: c.adam,
                    lr_scale: c.lr_scale,
                    divergences: c.divergences,
                    best: c.best,
                    records: c.records,
                    events: c.events,
                    stopped: c.stopped,
                });
            }
        }
        let mut u = vec![];
        for s in specs {
            let mut v = s.to_u(&s.path.get(scene)?);
            s.project(&mut v);
            u.push(v);
        }
        Ok(State {
            next: 0,
            adam: specs.iter().map(|s| AdamState::new(s.dims())).collect(),
            u,
            lr_scale: 1.0,
            divergences: 0,
            best: None,
            records: vec![],
            events: vec![],
            stopped: None,
        })
    }

    /// Handles iteration t's loss and gradient (at the state that was rendered): divergence check, then a step.
    fn iterate(
        &mut self,
        specs: &[ParamSpec],
        opts: &OptimizeOptions,
        t: usize,
        loss: f64,
        g: &[f64],
        thetas: &[Vec<f32>],
    ) -> Result<()> {
        self.next = t + 1;
        let why = if !loss.is_finite() {
            Some(format!("the loss is {loss}"))
        } else if let Some(i) = g.iter().position(|v| !v.is_finite()) {
            Some(format!("gradient entry {i} is {}", g[i]))
        } else {
            match &self.best {
                Some(b) if loss > opts.divergence_factor * b.loss && b.loss > 0.0 => Some(format!(
                    "the loss {loss:.4e} rose past {}x its best ({:.4e} at iteration {})",
                    opts.divergence_factor, b.loss, b.iteration
                )),
                _ => None,
            }
        };
        if let Some(why) = why {
            return self.diverged(opts, t, &why);
        }
        if self.best.as_ref().is_none_or(|b| loss < b.loss) {
            self.best = Some(BestState { loss, iteration: t, u: self.u.clone(), adam: self.adam.clone() });
        }
        let mut at = 0;
        let mut next_u = self.u.clone();
        for (k, s) in specs.iter().enumerate() {
            let n = thetas[k].len();
            let gu = s.grad_u(&thetas[k], &g[at..at + n]);
            at += n;
            let lr = s.lr * s.schedule.factor(t, opts.iters) * self.lr_scale;
            self.adam[k].step(&opts.adam, lr, &mut next_u[k], &gu);
            s.project(&mut next_u[k]);
        }
        // A step whose parameters are no longer finite (an absurd rate through exp) is a divergence too.
        let bad = specs.iter().zip(&next_u).find(|(s, u)| s.to_theta(u).iter().any(|v| !v.is_finite()));
        if let Some((s, _)) = bad {
            return self.diverged(opts, t, &format!("the step made {} non-finite", s.path));
        }
        self.u = next_u;
        Ok(())
    }

    fn diverged(&mut self, opts: &OptimizeOptions, t: usize, why: &str) -> Result<()> {
        self.divergences += 1;
        let Some(best) = self.best.clone() else {
            // Nothing good to return to: the start itself gives no finite loss or gradient.
            self.stopped = Some(format!("iteration {t}: {why} at the starting point; stopped"));
            self.events.push(self.stopped.clone().unwrap_or_default());
            return Ok(());
        };
        self.u = best.u;
        self.adam = best.adam;
        if self.divergences > opts.max_divergences {
            let msg = format!(
                "iteration {t}: {why}; diverged {} times, stopped with the best state (loss {:.4e} at iteration {})",
                self.divergences, best.loss, best.iteration
            );
            self.events.push(msg.clone());
            self.stopped = Some(msg);
        } else {
            self.lr_scale *= 0.5;
            self.events.push(format!(
                "iteration {t}: {why}; restored the best state (iteration {}), rates halved to {}x",
                best.iteration, self.lr_scale
            ));
        }
        Ok(())
    }

    fn checkpoint(&self, specs: &[ParamSpec]) -> Checkpoint {
        Checkpoint {
            format: CHECKPOINT_FORMAT.into(),
            next_iteration: self.next,
            specs: specs.to_vec(),
            u: self.u.clone(),
            adam: self.adam.clone(),
            lr_scale: self.lr_scale,
            divergences: self.divergences,
            best: self.best.clone(),
            records: self.records.clone(),
            events: self.events.clone(),
            stopped: self.stopped.clone(),
        }
    }
}
