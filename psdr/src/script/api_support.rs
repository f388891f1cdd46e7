//! What the script API files share: the run a registered function records into (`RunRef`), its result type
//! (`Rr`), psdr errors as script errors, and the checks of options and photos every API makes. The API files
//! (`*_api.rs`) use these; `engine` registers the API files; nothing here imports either.

use super::run_context::RunContext;
use crate::error::Error;
use rhai::{Dynamic, EvalAltResult, Position};
use std::cell::RefCell;
use std::rc::Rc;

pub type RunRef = Rc<RefCell<RunContext>>;
pub type Rr<T> = std::result::Result<T, Box<EvalAltResult>>;

/// A psdr error as a script runtime error (Rhai adds the position of the call).
pub fn rhai_err(e: Error) -> Box<EvalAltResult> {
    EvalAltResult::ErrorRuntime(Dynamic::from(e.to_string()), Position::NONE).into()
}

/// An option's value as a number (an integer or a float), or an error naming the function and the key.
pub fn option_number(what: &str, key: &str, v: &Dynamic) -> crate::Result<f64> {
    v.as_float()
        .or_else(|_| v.as_int().map(|i| i as f64))
        .map_err(|_| Error::Invalid(format!("{what}: '{key}' must be a number")))
}

/// Checks that `photo` is RGB at the size `scene`'s camera renders.
pub fn check_photo(what: &str, scene: &crate::scene::Scene, photo: &crate::loss::Image) -> crate::Result<()> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    if (photo.width, photo.height, photo.channels) != (w, h, 3) {
        return Err(Error::Invalid(format!(
            "{what}: the photo is {}x{}x{} but the scene's camera renders {w}x{h} RGB",
            photo.width, photo.height, photo.channels
        )));
    }
    Ok(())
}

/// Runs `f` on the run's backend, taken out of the context meanwhile (so `f` may borrow the context, and a
/// loss closure, which runs while an optimisation holds the backend, gets an error instead of a second one).
pub fn on_backend<T>(
    run: &RunRef,
    who: &str,
    f: impl FnOnce(&mut dyn crate::backend::Backend) -> crate::Result<T>,
) -> crate::Result<T> {
    let mut backend = run
        .borrow_mut()
        .backend
        .take()
        .ok_or_else(|| Error::Invalid(format!("{who}() cannot run inside a loss closure")))?;
    let out = f(backend.as_mut());
    run.borrow_mut().backend = Some(backend);
    out
}
