//! The Rhai engine of `psdr run`: registers the API (scenes, renders, loss ops, optimisation, stages),
//! applies `--set` overrides, limits runaway scripts, and reports script errors with file, line and column.

use super::api_support::{rhai_err, Rr, RunRef};
use super::scene_api::SceneHandle;
use crate::error::{Error, Result};
use crate::loss::Tensor;
use rhai::{Dynamic, Engine, EvalAltResult, FnPtr, NativeCallContext, Position, AST};
use std::collections::HashMap;
use std::path::Path;

/// Images `show` writes for the report are box-downsampled to at most this many pixels on their long side.
const REPORT_LONG_SIDE: usize = 1024;

/// Rhai operations a script may run before it is stopped: far above any real schedule (whose work happens
/// in Rust calls, each one operation), far below a runaway loop's minutes.
pub const MAX_OPERATIONS: u64 = 50_000_000;

/// A script error as one line: `SCRIPT:LINE:COLUMN: message`, at the innermost position (an error inside a
/// loss closure points into the closure, not at the `optimize` call that ran it).
pub fn script_error(script: &Path, e: &EvalAltResult) -> Error {
    let mut inner = e;
    let mut called_from = None;
    while let EvalAltResult::ErrorInFunctionCall(_, _, next, at) = inner {
        called_from = called_from.or(at.line());
        inner = next;
    }
    let pos = inner.position();
    let mut msg = inner.to_string();
    // Rhai appends " (line L, position C)" itself; we lead with it instead.
    if let Some(i) = msg.rfind(" (line ") {
        msg.truncate(i);
    }
    if let EvalAltResult::ErrorTooManyOperations(..) = inner {
        msg = format!("{msg}: the script ran more than {MAX_OPERATIONS} operations (an endless loop?) and was stopped");
    }
    if let Some(line) = called_from.filter(|l| Some(*l) != pos.line()) {
        msg = format!("{msg} (in a function called from line {line})");
    }
    match (pos.line(), pos.position()) {
        (Some(l), Some(c)) => Error::Invalid(format!("{}:{l}:{c}: {msg}", script.display())),
        (Some(l), None) => Error::Invalid(format!("{}:{l}: {msg}", script.display())),
        _ => Error::Invalid(format!("{}: {msg}", script.display())),
    }
}

/// Parses `--set key=value` overrides against the script's top-level `let`/`const` variables with literal
/// values: an unknown name or a value of another type is an error (a typo must not be silently ignored).
pub fn overrides(ast: &AST, sets: &[String]) -> Result<HashMap<String, Dynamic>> {
    let literals: HashMap<String, Dynamic> =
        ast.iter_literal_variables(true, true).map(|(n, _, v)| (n.to_string(), v)).collect();
    let mut out = HashMap::new();
    for s in sets {
        let (k, v) = s.split_once('=').ok_or_else(|| Error::Invalid(format!("--set {s}: expected key=value")))?;
        let Some(old) = literals.get(k) else {
            let mut names: Vec<&String> = literals.keys().collect();
            names.sort();
            return Err(Error::Invalid(format!(
                "--set {k}: the script has no top-level variable '{k}' with a literal value; it has {names:?}"
            )));
        };
        let value = if old.is_int() {
            v.parse::<i64>().map(Dynamic::from_int).map_err(|_| "an integer")
        } else if old.is_float() {
            v.parse::<f64>().map(Dynamic::from_float).map_err(|_| "a number")
        } else if old.is_bool() {
            v.parse::<bool>().map(Dynamic::from_bool).map_err(|_| "true or false")
        } else if old.is_string() {
            Ok(Dynamic::from(v.to_string()))
        } else {
            Err("a number, boolean or string variable")
        };
        let value = value.map_err(|want| Error::Invalid(format!("--set {k}={v}: '{k}' takes {want}")))?;
        out.insert(k.to_string(), value);
    }
    Ok(out)
}

/// `stage(name, input, |s| { ...; s })`: runs (or, when finished earlier and resuming, loads) one stage. The
/// input is usually the previous stage's scene (a first stage may take `()` and build one); the closure
/// returns the stage's scene.
fn stage(ctx: &NativeCallContext, run: &RunRef, name: &str, scene: Dynamic, f: FnPtr) -> Rr<SceneHandle> {
    if let Some(loaded) = run.borrow_mut().begin_stage(name).map_err(rhai_err)? {
        return Ok(SceneHandle(loaded));
    }
    let out = match f.call_within_context::<Dynamic>(ctx, (scene,)) {
        Ok(v) => v.try_cast::<SceneHandle>().ok_or_else(|| {
            rhai_err(Error::Invalid(format!("stage '{name}': the closure must return the scene (end it with `s`)")))
        }),
        Err(e) => Err(e),
    };
    let mut c = run.borrow_mut();
    match out {
        Ok(s) => {
            let index = c.current.as_ref().map_or(0, |s| s.index);
            let reloaded = c.end_stage(&s.0).map_err(rhai_err)?;
            c.write_summary(Some(&reloaded)).map_err(rhai_err)?;
            let until = c.options.until_stage.as_deref();
            if until.is_some_and(|u| u == name || u.parse::<usize>().ok() == Some(index)) {
                // `--until`: the run ends here with this stage's scene (run_script writes the outputs).
                c.stopped_after = Some(reloaded);
                return Err(
                    EvalAltResult::ErrorTerminated(Dynamic::from(format!("--until {name}")), Position::NONE).into()
                );
            }
            Ok(SceneHandle(reloaded))
        }
        Err(e) => {
            c.fail_stage(&e.to_string());
            Err(e)
        }
    }
}

/// The engine with the whole psdr API registered.
pub fn build_engine(run: &RunRef) -> Engine {
    let mut engine = Engine::new();
    engine.set_max_operations(MAX_OPERATIONS);
    engine.set_max_expr_depths(128, 64);
    super::tensor_api::register(&mut engine);
    super::scene_api::register(&mut engine, run);
    super::optimize_api::register(&mut engine, run);
    super::vision_api::register(&mut engine, run);
    super::object_api::register(&mut engine, run);
    super::light_api::register(&mut engine, run);
    super::material_api::register(&mut engine, run);
    super::evaluation_api::register(&mut engine, run);

    let r = run.clone();
    engine.register_fn("stage", move |ctx: NativeCallContext, name: &str, scene: Dynamic, f: FnPtr| {
        stage(&ctx, &r, name, scene, f)
    });
    let r = run.clone();
    engine.register_fn("show", move |label: &str, t: Tensor| -> Rr<()> {
        let mut c = r.borrow_mut();
        let file =
            label.chars().map(|ch| if ch.is_ascii_alphanumeric() || ch == '_' { ch } else { '_' }).collect::<String>();
        let path = c.current_dir().join(format!("{file}.png"));
        // The report embeds these: a phone photo is shown at most REPORT_LONG_SIDE pixels wide.
        let img = t.value();
        let k = img.width.max(img.height).div_ceil(REPORT_LONG_SIDE).max(1);
        let shown = if k > 1 { crate::loss::downsample(&t, k).map_err(rhai_err)?.value().clone() } else { img.clone() };
        super::scene_api::write_image(&shown, &path).map_err(rhai_err)?;
        let image = crate::report::ReportImage { label: label.to_string(), path };
        match c.current.as_mut() {
            Some(stage) => stage.report.images.push(image),
            None => c.report.images.push(image),
        }
        Ok(())
    });
    let r = run.clone();
    engine.register_fn("record", move |key: &str, value: Dynamic| -> Rr<()> {
        let v = rhai::serde::from_dynamic::<serde_json::Value>(&value)?;
        r.borrow_mut().recorded.insert(key.to_string(), v);
        Ok(())
    });
    let r = run.clone();
    engine.register_fn("set_preview_spp", move |spp: i64| -> Rr<()> {
        let spp = u32::try_from(spp).ok().filter(|&s| s > 0);
        r.borrow_mut().options.preview_spp =
            spp.ok_or_else(|| rhai_err(Error::Invalid("set_preview_spp: spp must be positive".into())))?;
        Ok(())
    });
    let r = run.clone();
    engine.on_print(move |s| {
        if !r.try_borrow().map(|c| c.options.quiet).unwrap_or(false) {
            eprintln!("{s}");
        }
    });
    engine
}
