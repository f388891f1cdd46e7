//! Running an image model through ONNX Runtime (`ort`, loaded at run time, so psdr builds and runs without it).
//!
//! The input contract every psdr image model follows: one float32 input `[1, 3, H, W]` (NCHW), the photo's
//! sRGB-encoded values in 0..1 normalised per channel as `(v - mean) / std` with ImageNet's mean
//! (0.485, 0.456, 0.406) and std (0.229, 0.224, 0.225), as DPT, Depth-Anything and most segmentation networks
//! are trained. A model with a static H and W gets the photo resized to them (bilinear, pixel centres); one
//! with dynamic dimensions gets the photo at its own size rounded down to a multiple of 14 (ViT patches),
//! the long side at most 518. Outputs are read by each estimator (`onnx_depth`, `onnx_segmentation`,
//! `onnx_fov`).
//!
//! The runtime library: `PSDR_ORT_LIB` or `ORT_DYLIB_PATH` (a `libonnxruntime.so` file), else a
//! `libonnxruntime.so*` in the models folder, else the one inside a pip-installed `onnxruntime` package
//! (python3's, or the virtual environment ~/.cache/psdr-venv that `.ci/install-deps` makes).

use crate::base::Image;
use crate::error::{Error, Result};
use ort::session::Session;
use ort::value::{Tensor, TensorElementType, ValueType};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

const MEAN: [f32; 3] = [0.485, 0.456, 0.406];
const STD: [f32; 3] = [0.229, 0.224, 0.225];
/// Dynamic inputs: sides a multiple of this, the long side at most `MAX_SIDE`.
const PATCH: usize = 14;
const MAX_SIDE: usize = 518;

static RUNTIME: OnceLock<std::result::Result<ort::environment::Environment, String>> = OnceLock::new();

/// Where the ONNX Runtime library is, by the rules in the module's documentation.
fn find_library(models: Option<&Path>) -> std::result::Result<PathBuf, String> {
    for var in ["PSDR_ORT_LIB", "ORT_DYLIB_PATH"] {
        if let Some(p) = std::env::var_os(var).map(PathBuf::from) {
            return if p.is_file() { Ok(p) } else { Err(format!("{var}={} is not a file", p.display())) };
        }
    }
    let in_dir = |dir: &Path| -> Option<PathBuf> {
        let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
            .ok()?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("libonnxruntime.so")))
            .collect();
        found.sort();
        found.pop()
    };
    if let Some(p) = models.and_then(in_dir) {
        return Ok(p);
    }
    // A pip-installed onnxruntime keeps the library in onnxruntime/capi: ask python3, then the virtual
    // environment `.ci/install-deps` makes.
    let venv = std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache/psdr-venv/bin/python3"));
    for python in std::iter::once(PathBuf::from("python3")).chain(venv) {
        let out = std::process::Command::new(&python)
            .args(["-c", "import onnxruntime, os; print(os.path.join(os.path.dirname(onnxruntime.__file__), 'capi'))"])
            .output();
        if let Some(out) = out.ok().filter(|o| o.status.success()) {
            if let Some(p) = in_dir(Path::new(String::from_utf8_lossy(&out.stdout).trim())) {
                return Ok(p);
            }
        }
    }
    Err("ONNX Runtime not found: `pip install onnxruntime==1.31.1`, or set ORT_DYLIB_PATH to a libonnxruntime.so, \
         or put one in the models folder"
        .into())
}

/// The process's ONNX Runtime environment, loaded on first use.
fn runtime(models: Option<&Path>) -> Result<&'static ort::environment::Environment> {
    RUNTIME
        .get_or_init(|| {
            let lib = find_library(models)?;
            ort::init_from(&lib)
                .map_err(|e| format!("loading ONNX Runtime from {}: {e}", lib.display()))?
                .with_name("psdr")
                .build()
                .map_err(|e| format!("starting ONNX Runtime ({}): {e}", lib.display()))
        })
        .as_ref()
        .map_err(|e| Error::Invalid(e.clone()))
}

/// How a model wants its pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputContract {
    /// NCHW `[1, 3, H, W]`, ImageNet-normalised sRGB: the depth, segmentation and fov models.
    NchwImageNet,
    /// `[1, 3, H, W]` or `[1, H, W, 3]` (told apart by where the 3 is), sRGB in 0..1 with any normalisation baked
    /// into the model: image-embedding models.
    UnitAnyLayout,
    /// NCHW `[1, 3, H, W]`, sRGB normalised with OpenAI CLIP's mean and std: CLIP's image tower as exported.
    NchwClip,
}

/// OpenAI CLIP's preprocessing (its repository's `Normalize`), its published digits.
#[allow(clippy::excessive_precision)]
const CLIP_MEAN: [f32; 3] = [0.481_454_66, 0.457_827_5, 0.408_210_73];
#[allow(clippy::excessive_precision)]
const CLIP_STD: [f32; 3] = [0.268_629_54, 0.261_302_58, 0.275_777_11];

/// A loaded image model and its input size (None: dynamic).
pub struct OnnxModel {
    pub path: PathBuf,
    session: Session,
    input: String,
    fixed_size: Option<(usize, usize)>,
    contract: InputContract,
    nhwc: bool,
}

/// One output tensor, as f32 whatever its element type.
pub struct ModelOutput {
    pub shape: Vec<usize>,
    pub data: Vec<f32>,
    /// True when the model gave integers (class ids).
    pub integer: bool,
}

impl OnnxModel {
    /// Loads a model of the depth/segmentation/fov contract (NCHW, ImageNet normalisation).
    pub fn load(path: &Path) -> Result<OnnxModel> {
        Self::load_with(path, InputContract::NchwImageNet)
    }

    pub fn load_with(path: &Path, contract: InputContract) -> Result<OnnxModel> {
        if !path.is_file() {
            return Err(Error::io(path, "model file not found"));
        }
        let env = runtime(path.parent())?;
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        let session = Session::builder(env)
            .and_then(|b| b.with_intra_threads(threads).map_err(Into::into))
            .and_then(|mut b| b.commit_from_file(path))
            .map_err(|e| Error::io(path, format!("not a loadable ONNX model: {e}")))?;
        let [input] = session.inputs() else {
            return Err(Error::io(path, format!("expected one image input, found {}", session.inputs().len())));
        };
        let shape = match input.dtype() {
            ValueType::Tensor { ty: TensorElementType::Float32, shape, .. } if shape.len() == 4 => shape.to_vec(),
            other => {
                return Err(Error::io(path, format!("the input must be a float32 [1, 3, H, W] tensor, not {other:?}")))
            }
        };
        let nhwc = contract == InputContract::UnitAnyLayout && shape[3] == 3 && shape[1] != 3;
        if (!nhwc && shape[1] != 3) || shape[0] > 1 {
            let want =
                if contract == InputContract::UnitAnyLayout { "[1, 3, H, W] or [1, H, W, 3]" } else { "[1, 3, H, W]" };
            return Err(Error::io(path, format!("the input must be {want}, not {shape:?}")));
        }
        let (hd, wd) = if nhwc { (shape[1], shape[2]) } else { (shape[2], shape[3]) };
        let fixed_size = (hd > 0 && wd > 0).then_some((wd as usize, hd as usize));
        let input = input.name().to_string();
        Ok(OnnxModel { path: path.to_path_buf(), session, input, fixed_size, contract, nhwc })
    }

    /// The size (w, h) the photo is fed at.
    pub fn input_size(&self, photo: &Image) -> (usize, usize) {
        self.fixed_size.unwrap_or_else(|| {
            let s = (MAX_SIDE as f32 / photo.width.max(photo.height) as f32).min(1.0);
            let fit = |v: usize| (((v as f32 * s) as usize) / PATCH * PATCH).max(PATCH);
            (fit(photo.width), fit(photo.height))
        })
    }

    /// Runs the model on the photo (linear RGB) by the input contract; returns the first output.
    pub fn run(&mut self, photo: &Image) -> Result<ModelOutput> {
        let (w, h) = self.input_size(photo);
        let srgb: Vec<f32> = photo.data.iter().map(|v| crate::base::linear_to_srgb(v.clamp(0.0, 1.0))).collect();
        let resized = resize_bilinear(&srgb, photo.width, photo.height, photo.channels, w, h);
        let mut pixels = vec![0.0f32; 3 * w * h];
        for c in 0..3 {
            let src = c.min(photo.channels - 1);
            for p in 0..w * h {
                let v = resized[p * photo.channels + src];
                let v = match self.contract {
                    InputContract::NchwImageNet => (v - MEAN[c]) / STD[c],
                    InputContract::NchwClip => (v - CLIP_MEAN[c]) / CLIP_STD[c],
                    InputContract::UnitAnyLayout => v,
                };
                pixels[if self.nhwc { p * 3 + c } else { c * w * h + p }] = v;
            }
        }
        let path = self.path.clone();
        let err = |e: ort::Error| Error::io(&path, format!("running the model: {e}"));
        let shape = if self.nhwc { [1usize, h, w, 3] } else { [1usize, 3, h, w] };
        let tensor = Tensor::from_array((shape, pixels)).map_err(err)?;
        let outputs = self.session.run(ort::inputs![self.input.as_str() => tensor]).map_err(err)?;
        let value = &outputs[0];
        if let Ok((shape, data)) = value.try_extract_tensor::<f32>() {
            return Ok(ModelOutput {
                shape: shape.iter().map(|&d| d as usize).collect(),
                data: data.to_vec(),
                integer: false,
            });
        }
        if let Ok((shape, data)) = value.try_extract_tensor::<i64>() {
            return Ok(ModelOutput {
                shape: shape.iter().map(|&d| d as usize).collect(),
                data: data.iter().map(|&v| v as f32).collect(),
                integer: true,
            });
        }
        Err(Error::io(&self.path, "the first output must be a float32 or int64 tensor"))
    }
}

/// Bilinear resize of an interleaved image (pixel centres aligned, clamped at the borders).
pub fn resize_bilinear(src: &[f32], sw: usize, sh: usize, channels: usize, dw: usize, dh: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; dw * dh * channels];
    for y in 0..dh {
        let fy = ((y as f32 + 0.5) * sh as f32 / dh as f32 - 0.5).clamp(0.0, (sh - 1) as f32);
        let (y0, ty) = (fy.floor() as usize, fy.fract());
        let y1 = (y0 + 1).min(sh - 1);
        for x in 0..dw {
            let fx = ((x as f32 + 0.5) * sw as f32 / dw as f32 - 0.5).clamp(0.0, (sw - 1) as f32);
            let (x0, tx) = (fx.floor() as usize, fx.fract());
            let x1 = (x0 + 1).min(sw - 1);
            for c in 0..channels {
                let at = |xx: usize, yy: usize| src[(yy * sw + xx) * channels + c];
                let top = at(x0, y0) * (1.0 - tx) + at(x1, y0) * tx;
                let bottom = at(x0, y1) * (1.0 - tx) + at(x1, y1) * tx;
                out[(y * dw + x) * channels + c] = top * (1.0 - ty) + bottom * ty;
            }
        }
    }
    out
}
