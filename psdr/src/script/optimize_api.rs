//! `optimize(scene, #{ params, lr, iters, spp, loss, ... })` in scripts: parses the options into parameter
//! specs and optimiser settings, runs the loop with the script's loss closure, checkpoints inside stages, and
//! adds the optimisation to the stage's report.

use super::api_support::{on_backend, rhai_err, Rr, RunRef};
use super::scene_api::{RenderHandle, SceneHandle};
use crate::error::{Error, Result};
use crate::loss::Tensor;
use crate::optim::{glob_match, optimize, select, OptimizeOptions, ParamSpec, Rendered, Schedule, Space};
use crate::report::OptimizationReport;
use crate::scene::Scene;
use rhai::{Array, Dynamic, Engine, EvalAltResult, FnPtr, Map, NativeCallContext};
use std::cell::RefCell;
use std::rc::Rc;

/// Options `optimize` knows; anything else is a typo and an error.
const KNOWN: &[&str] = &[
    "params",
    "lr",
    "iters",
    "spp",
    "seed",
    "max_depth",
    "sppe",
    "sppse",
    "loss",
    "targets",
    "every",
    "label",
    "schedule",
    "divergence_factor",
    "max_divergences",
    "fused",
    "keep_inside_room",
    "beta1",
    "beta2",
];

fn int(m: &Map, key: &str, default: i64) -> Result<i64> {
    match m.get(key) {
        None => Ok(default),
        Some(v) => v
            .as_int()
            .map_err(|_| Error::Invalid(format!("optimize: '{key}' must be an integer, found {}", v.type_name()))),
    }
}

fn float(v: &Dynamic, key: &str) -> Result<f64> {
    v.as_float()
        .or_else(|_| v.as_int().map(|i| i as f64))
        .map_err(|_| Error::Invalid(format!("optimize: '{key}' must be a number, found {}", v.type_name())))
}

/// One number per component: `min: [x0, y0, z0]`.
fn floats(v: &Dynamic, key: &str) -> Result<Vec<f32>> {
    let a =
        v.clone().try_cast::<Array>().ok_or_else(|| Error::Invalid(format!("optimize: '{key}' must be an array")))?;
    a.iter().map(|x| float(x, key).map(|f| f as f32)).collect()
}

fn count(m: &Map, key: &str, default: i64) -> Result<u32> {
    let v = int(m, key, default)?;
    u32::try_from(v).map_err(|_| Error::Invalid(format!("optimize: '{key}' = {v} is out of range")))
}

/// `schedule: "constant" | #{kind: "exponential", gamma} | #{kind: "step", every, gamma} | #{kind: "cosine", min}`.
fn schedule(v: &Dynamic) -> Result<Schedule> {
    if let Ok(s) = v.clone().into_string() {
        return match s.as_str() {
            "constant" => Ok(Schedule::Constant),
            other => Err(Error::Invalid(format!("schedule '{other}': give \"constant\" or a map with a kind"))),
        };
    }
    let m = v.clone().try_cast::<Map>().ok_or_else(|| Error::Invalid("schedule must be a string or a map".into()))?;
    let kind = m.get("kind").and_then(|k| k.clone().into_string().ok()).unwrap_or_default();
    let f = |k: &str| m.get(k).map(|v| float(v, k)).transpose();
    Ok(match kind.as_str() {
        "constant" => Schedule::Constant,
        "exponential" => Schedule::Exponential { gamma: f("gamma")?.unwrap_or(0.99) },
        "step" => Schedule::Step { every: f("every")?.unwrap_or(50.0) as usize, gamma: f("gamma")?.unwrap_or(0.5) },
        "cosine" => Schedule::Cosine { min: f("min")?.unwrap_or(0.1) },
        other => return Err(Error::Invalid(format!("schedule kind '{other}' (constant, exponential, step, cosine)"))),
    })
}

/// The parameter specs of `params` (strings or maps `#{select, lr, free, space, min, max, schedule}`), with
/// rates from the entry, else the first matching pattern of an `lr` map, else a number `lr`, else the kind's
/// default.
pub fn specs(scene: &Scene, opts: &Map) -> Result<Vec<ParamSpec>> {
    let entries = opts
        .get("params")
        .and_then(|v| v.clone().try_cast::<Array>())
        .ok_or_else(|| Error::Invalid("optimize: 'params' must be an array of parameter patterns".into()))?;
    let default_schedule = opts.get("schedule").map(schedule).transpose()?;
    let mut out: Vec<ParamSpec> = vec![];
    for e in entries {
        let (pattern, extra) = match e.clone().into_string() {
            Ok(s) => (s, Map::new()),
            Err(_) => {
                let m = e.try_cast::<Map>().ok_or_else(|| {
                    Error::Invalid("optimize: each 'params' entry is a pattern string or a map with 'select'".into())
                })?;
                let s = m
                    .get("select")
                    .and_then(|v| v.clone().into_string().ok())
                    .ok_or_else(|| Error::Invalid("optimize: a 'params' map needs 'select': \"pattern\"".into()))?;
                (s, m)
            }
        };
        for path in select(scene, &pattern)? {
            if out.iter().any(|s| s.path == path) {
                return Err(Error::Invalid(format!("optimize: {path} is selected twice")));
            }
            let mut spec = ParamSpec::new(scene, path)?;
            match opts.get("lr") {
                Some(v) if v.is_map() => {
                    let m = v.clone().cast::<Map>();
                    if let Some((_, lr)) = m.iter().find(|(k, _)| glob_match(k, &spec.path.to_string())) {
                        spec.lr = float(lr, "lr")?;
                    }
                }
                Some(v) => spec.lr = float(v, "lr")?,
                None => {}
            }
            if let Some(s) = default_schedule {
                spec.schedule = s;
            }
            for (k, v) in &extra {
                match k.as_str() {
                    "select" => {}
                    "lr" => spec.lr = float(v, "lr")?,
                    "min" if v.is_array() => spec.lower_each = floats(v, "min")?,
                    "max" if v.is_array() => spec.upper_each = floats(v, "max")?,
                    "min" => spec.lower = float(v, "min")? as f32,
                    "max" => spec.upper = float(v, "max")? as f32,
                    "schedule" => spec.schedule = schedule(v)?,
                    "free" => match v.clone().into_string() {
                        Ok(axes) => spec.set_free_axes(&axes)?,
                        Err(_) => {
                            let a = v.clone().try_cast::<Array>().ok_or_else(|| {
                                Error::Invalid(format!("{}: free is \"xz\"-style axes or an array of booleans", spec.path))
                            })?;
                            spec.free = a.iter().map(|b| b.as_bool().unwrap_or(false)).collect();
                        }
                    },
                    "space" => {
                        spec.space = match v.clone().into_string().unwrap_or_default().as_str() {
                            "linear" => Space::Linear,
                            "log" => Space::Log,
                            "uniform_log" => Space::UniformLog,
                            "range" => Space::Range,
                            other => {
                                return Err(Error::Invalid(format!(
                                    "{}: space '{other}' (linear, log, uniform_log, range)",
                                    spec.path
                                )))
                            }
                        }
                    }
                    other => {
                        return Err(Error::Invalid(format!(
                            "optimize: unknown key '{other}' in a params entry (select, lr, free, space, min, max, schedule)"
                        )))
                    }
                }
            }
            spec.check()?;
            out.push(spec);
        }
    }
    // An `lr` pattern that matches nothing is a typo (patterns match whole paths: `*/yaw` does not match
    // `object/chair/yaw`), not a request for the default rate.
    if let Some(m) = opts.get("lr").filter(|v| v.is_map()).map(|v| v.clone().cast::<Map>()) {
        for k in m.keys() {
            if !out.iter().any(|s| glob_match(k, &s.path.to_string())) {
                let paths: Vec<String> = out.iter().map(|s| s.path.to_string()).collect();
                return Err(Error::Invalid(format!(
                    "optimize: lr pattern '{k}' matches none of the selected parameters ({}); '*' does not cross '/'",
                    paths.join(", ")
                )));
            }
        }
    }
    Ok(out)
}

/// The optimiser settings of an options map.
pub fn options(opts: &Map) -> Result<OptimizeOptions> {
    if let Some(k) = opts.keys().find(|k| !KNOWN.contains(&k.as_str())) {
        return Err(Error::Invalid(format!("optimize: unknown option '{k}'; options are {}", KNOWN.join(", "))));
    }
    let d = OptimizeOptions::default();
    let mut o = OptimizeOptions {
        iters: int(opts, "iters", d.iters as i64)?.max(0) as usize,
        spp: count(opts, "spp", d.spp as i64)?,
        seed: count(opts, "seed", d.seed as i64)?,
        max_depth: opts.get("max_depth").map(|_| count(opts, "max_depth", 5)).transpose()?,
        edge_samples: count(opts, "sppe", d.edge_samples as i64)?,
        secondary_edge_samples: count(opts, "sppse", d.secondary_edge_samples as i64)?,
        checkpoint_every: int(opts, "every", d.checkpoint_every as i64)?.max(0) as usize,
        max_divergences: int(opts, "max_divergences", d.max_divergences as i64)?.max(0) as usize,
        ..d
    };
    if let Some(v) = opts.get("divergence_factor") {
        o.divergence_factor = float(v, "divergence_factor")?;
    }
    if let Some(v) = opts.get("fused") {
        o.fused = v.as_bool().map_err(|_| Error::Invalid("optimize: 'fused' must be true or false".into()))?;
    }
    if let Some(v) = opts.get("keep_inside_room") {
        o.keep_inside_room =
            v.as_bool().map_err(|_| Error::Invalid("optimize: 'keep_inside_room' must be true or false".into()))?;
    }
    if let Some(v) = opts.get("beta1") {
        o.adam.beta1 = float(v, "beta1")?;
    }
    if let Some(v) = opts.get("beta2") {
        o.adam.beta2 = float(v, "beta2")?;
    }
    Ok(o)
}

/// What a loss closure returned: a scalar tensor (one term, "loss"), or a map of named scalar terms.
fn terms_of(v: Dynamic) -> Result<Vec<(String, Tensor)>> {
    if v.is::<Tensor>() {
        return Ok(vec![("loss".into(), v.cast::<Tensor>())]);
    }
    if let Some(m) = v.clone().try_cast::<Map>() {
        let mut out = vec![];
        for (k, t) in m {
            let t = t
                .clone()
                .try_cast::<Tensor>()
                .ok_or_else(|| Error::Invalid(format!("loss term '{k}' is a {}, not a tensor", t.type_name())))?;
            out.push((k.to_string(), t));
        }
        return Ok(out);
    }
    Err(Error::Invalid(format!(
        "the loss closure returned a {}; it must return a scalar tensor (e.g. l1(r.radiance, target)) or a map of them",
        v.type_name()
    )))
}

fn run_optimize(ctx: &NativeCallContext, run: &RunRef, scene: &mut Scene, opts: &Map) -> Rr<Map> {
    let specs = specs(scene, opts).map_err(rhai_err)?;
    let mut o = options(opts).map_err(rhai_err)?;
    let loss = ScriptLoss::from_options(opts, "optimize")?;
    let label = opts.get("label").and_then(|v| v.clone().into_string().ok());
    let quiet = {
        let mut c = run.borrow_mut();
        // Checkpoints live in the stage's folder; outside stages there is nothing to resume into.
        if let Some(stage) = c.current.as_mut() {
            o.checkpoint = Some(stage.dir.join(format!("optimize{}.checkpoint.json", stage.optimizations)));
            stage.optimizations += 1;
        }
        o.resume = c.options.resume;
        c.options.quiet
    };
    let label = label.unwrap_or_else(|| {
        format!("optimize {}", specs.iter().map(|s| s.path.to_string()).collect::<Vec<_>>().join(", "))
    });
    let mut call = |r: Rc<Rendered>| loss.call(ctx, r);
    let progress = crate::progress::activity(label.clone(), Some(o.iters));
    let mut observe = |r: &crate::optim::IterationRecord| {
        progress.set(r.iteration + 1, Some(format!("loss {:.4e}", r.loss)));
    };
    // The backend is out of the context while the optimisation runs: a loss closure must not render.
    let outcome = on_backend(run, "optimize", |b| optimize(scene, &specs, &mut call, &o, b, &mut observe));
    drop(progress);
    let outcome = outcome.map_err(|e| loss.error(e))?;
    if !quiet {
        for e in &outcome.events {
            eprintln!("  {e}");
        }
    }
    let mut result = Map::new();
    let last = outcome.records.last().map(|r| r.loss).unwrap_or(f64::NAN);
    result.insert("loss".into(), Dynamic::from_float(last));
    result.insert("best_loss".into(), Dynamic::from_float(outcome.best_loss.unwrap_or(f64::NAN)));
    result.insert("iterations".into(), Dynamic::from_int(outcome.records.len() as i64));
    result.insert("fused_iterations".into(), Dynamic::from_int(outcome.fused_iterations as i64));
    result.insert("stopped".into(), Dynamic::from(outcome.stopped.clone().unwrap_or_default()));
    result.insert("events".into(), outcome.events.iter().map(|e| Dynamic::from(e.clone())).collect::<Array>().into());
    result
        .insert("losses".into(), outcome.records.iter().map(|r| Dynamic::from_float(r.loss)).collect::<Array>().into());
    let report = OptimizationReport {
        label,
        iterations: outcome.records,
        events: outcome.events,
        params: specs.iter().map(|s| s.path.to_string()).collect(),
    };
    let mut c = run.borrow_mut();
    match c.current.as_mut() {
        Some(stage) => stage.report.optimizations.push(report),
        None => {
            c.report.notes.push(format!("{} (outside a stage): {} iterations", report.label, report.iterations.len()))
        }
    }
    Ok(result)
}

/// `gradient(scene, #{ params, loss, spp, seed, ... })`: the loss and dLoss/dθ at the scene's current state,
/// as the first iteration of `optimize` with the same options computes them. Returns `#{ loss, grad: #{ path:
/// [..] } }`.
fn run_gradient(ctx: &NativeCallContext, run: &RunRef, scene: &Scene, opts: &Map) -> Rr<Map> {
    let specs = specs(scene, opts).map_err(rhai_err)?;
    let o = options(opts).map_err(rhai_err)?;
    let paths: Vec<_> = specs.iter().map(|s| s.path.clone()).collect();
    let loss = ScriptLoss::from_options(opts, "gradient")?;
    let mut call = |r: Rc<Rendered>| loss.call(ctx, r);
    let e = on_backend(run, "gradient", |b| crate::optim::gradient(scene, &paths, &mut call, &o, b));
    let e = e.map_err(|e| loss.error(e))?;
    let mut grad = Map::new();
    let mut at = 0;
    for p in &paths {
        let n = p.get(scene).map_err(rhai_err)?.len();
        grad.insert(
            p.to_string().into(),
            e.grad[at..at + n].iter().map(|&v| Dynamic::from_float(v)).collect::<Array>().into(),
        );
        at += n;
    }
    let mut out = Map::new();
    out.insert("loss".into(), Dynamic::from_float(e.total.item().unwrap_or(f32::NAN) as f64));
    out.insert("grad".into(), grad.into());
    out.insert("fused".into(), Dynamic::from_bool(e.fused));
    Ok(out)
}

/// The script's loss closure with what it needs: `|r|`, or `|r, t|` when the options hold `targets`.
struct ScriptLoss {
    f: FnPtr,
    targets: Option<Dynamic>,
    /// The closure's own script error, kept with its position to report instead of a flattened message.
    error: RefCell<Option<Box<EvalAltResult>>>,
}

/// The message that marks a psdr error as the loss closure's.
const CLOSURE_FAILED: &str = "the loss closure failed";

impl ScriptLoss {
    fn from_options(opts: &Map, who: &str) -> Rr<ScriptLoss> {
        let f = opts.get("loss").and_then(|v| v.clone().try_cast::<FnPtr>()).ok_or_else(|| {
            rhai_err(Error::Invalid(format!("{who}: 'loss' must be a closure, e.g. |r| l2(r.radiance, target)")))
        })?;
        Ok(ScriptLoss { f, targets: opts.get("targets").cloned(), error: RefCell::new(None) })
    }

    fn call(&self, ctx: &NativeCallContext, r: Rc<Rendered>) -> Result<Vec<(String, Tensor)>> {
        let handle = RenderHandle(r);
        let value = match &self.targets {
            Some(t) => self.f.call_within_context::<Dynamic>(ctx, (handle, t.clone())),
            None => self.f.call_within_context::<Dynamic>(ctx, (handle,)),
        };
        match value {
            Ok(v) => terms_of(v),
            Err(e) => {
                let msg = e.to_string();
                *self.error.borrow_mut() = Some(e);
                Err(Error::Invalid(format!("{CLOSURE_FAILED}: {msg}")))
            }
        }
    }

    /// A failing loss closure reports its own script error (with its line and column).
    fn error(&self, e: Error) -> Box<EvalAltResult> {
        match self.error.take() {
            Some(script) if e.to_string().starts_with(CLOSURE_FAILED) => script,
            _ => rhai_err(e),
        }
    }
}

pub fn register(engine: &mut Engine, run: &RunRef) {
    let r = run.clone();
    engine.register_fn("gradient", move |ctx: NativeCallContext, s: &mut SceneHandle, opts: Map| -> Rr<Map> {
        run_gradient(&ctx, &r, &s.0, &opts)
    });
    let r = run.clone();
    engine.register_fn("optimize", move |ctx: NativeCallContext, s: &mut SceneHandle, opts: Map| -> Rr<Map> {
        run_optimize(&ctx, &r, &mut s.0, &opts)
    });
}
