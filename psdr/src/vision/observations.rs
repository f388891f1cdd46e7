//! Resolving a photo's observations: for each quantity (depth, instance masks with labels, field of view)
//! the first source that exists: a command-line flag, else a file beside the photo by its stem
//! (`STEM.depth.exr` or `.depth.png`, `STEM.masks.png` + `STEM.labels.json`, `STEM.camera.json`), else an ONNX
//! model in the models folder (`--models`, `PSDR_MODELS`), else for the fov the vanishing points, else a
//! stated default. A quantity a
//! stage needs but nothing supplies is an error that lists the ways to supply it. `write` is `psdr observe`.

use super::depth::{load_depth, Depth, DepthUnits};
use super::depth_direction::{floor_depth_trend, INVERTED_BELOW};
use super::masks::{load_instances, Instances};
use super::onnx_depth::estimate_depth;
use super::onnx_fov::estimate_fov_onnx;
use super::onnx_model::OnnxModel;
use super::onnx_segmentation::estimate_instances;
use super::photo::load_photo;
use super::room_init::RoomEstimate;
use super::vanishing_points::{estimate_fov, FovEstimate, VanishingOptions};
use crate::base::Image;
use crate::base::Intrinsics;
use crate::error::{Error, Result};
use crate::vision::{calibrate_relative_depth, check_against_layout, DepthCalibration};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Where observations may come from besides the files beside the photo.
#[derive(Clone, Debug, PartialEq)]
pub struct ObservationInputs {
    pub photo: PathBuf,
    pub depth: Option<PathBuf>,
    pub depth_units: DepthUnits,
    pub masks: Option<PathBuf>,
    pub labels: Option<PathBuf>,
    pub fov_y_deg: Option<f32>,
    /// The camera's height above the floor (metres) that sets the scale of relative depth: a prior.
    pub camera_height: f32,
    /// A folder of ONNX models (`depth.onnx`, `segmentation.onnx`, `fov.onnx`) for what no file gives.
    pub models: Option<PathBuf>,
    /// The vanishing-point fov is used only when its bootstrap standard deviation is below this (degrees).
    pub fov_max_sigma_deg: f32,
}

/// The camera height assumed when depth is relative: eye level of a standing photographer, a little low.
pub const DEFAULT_CAMERA_HEIGHT: f32 = 1.5;
/// The vertical fov used when nothing gives one and the vanishing points do not fix it (a phone's main camera
/// in landscape is 45-50 degrees vertically, a wide real-estate lens 60-75).
pub const DEFAULT_FOV_Y_DEG: f32 = 55.0;

impl ObservationInputs {
    pub fn new(photo: &Path) -> ObservationInputs {
        ObservationInputs {
            photo: photo.to_path_buf(),
            depth: None,
            depth_units: DepthUnits::Metres,
            masks: None,
            labels: None,
            fov_y_deg: None,
            camera_height: DEFAULT_CAMERA_HEIGHT,
            models: crate::models::models_folder(None),
            fov_max_sigma_deg: VanishingOptions::default().max_sigma_deg,
        }
    }

    /// `STEM.suffix` beside the photo.
    fn beside(&self, suffix: &str) -> PathBuf {
        let stem = self.photo.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        self.photo.with_file_name(format!("{stem}.{suffix}"))
    }
}

/// The resolved observations of one photo.
#[derive(Clone, Debug)]
pub struct Observations {
    pub photo_path: PathBuf,
    /// Linear RGB.
    pub photo: Image,
    pub depth: Option<Depth>,
    pub instances: Option<Instances>,
    pub fov_y_deg: Option<f32>,
    /// The vanishing-point estimate, when the fov came from it (or it was tried and failed: `warnings`).
    pub fov_estimate: Option<FovEstimate>,
    /// How relative depth was turned into metres.
    pub depth_calibration: Option<DepthCalibration>,
    /// The room box from the photo's lines and masks, where relative depth was mapped onto it
    /// (`layout_calibration`); the room stage starts from it.
    pub room_layout: Option<RoomEstimate>,
    /// Quantity -> where it came from ("flag --depth x.exr", "file room.depth.exr").
    pub sources: BTreeMap<String, String>,
    /// What was assumed rather than observed (a default fov, a failed estimator), for the run's report.
    pub warnings: Vec<String>,
}

fn check_size(what: &str, path: &Path, (w, h): (usize, usize), photo: &Image) -> Result<()> {
    if (w, h) != (photo.width, photo.height) {
        return Err(Error::io(
            path,
            format!(
                "the {what} is {w}x{h} but the photo is {}x{}; they must be the same size",
                photo.width, photo.height
            ),
        ));
    }
    Ok(())
}

/// Reads `{"fov_y_deg": ...}`.
fn load_camera(path: &Path) -> Result<f32> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| Error::io(path, e))?;
    let fov = v
        .get("fov_y_deg")
        .and_then(|f| f.as_f64())
        .ok_or_else(|| Error::io(path, "expected {\"fov_y_deg\": <vertical field of view in degrees>}"))?
        as f32;
    check_fov(fov).map_err(|m| Error::io(path, m))
}

fn check_fov(fov: f32) -> std::result::Result<f32, String> {
    if fov.is_finite() && fov > 1.0 && fov < 179.0 {
        Ok(fov)
    } else {
        Err(format!("vertical field of view {fov} degrees is not in (1, 179)"))
    }
}

impl Observations {
    /// Loads the photo and every quantity that has a source; checks that all images have the photo's size.
    pub fn resolve(inputs: &ObservationInputs) -> Result<Observations> {
        let photo = load_photo(&inputs.photo)?;
        let mut sources = BTreeMap::new();
        sources.insert("photo".to_string(), format!("file {}", inputs.photo.display()));
        if let Some(dir) = inputs.models.as_ref().filter(|d| !d.is_dir()) {
            return Err(Error::io(dir, "the models folder does not exist (--models or PSDR_MODELS; `psdr models fetch` fills ~/.cache/psdr/models)"));
        }
        // NAME.onnx in the models folder, when there is one.
        let model = |name: &str| -> Result<Option<OnnxModel>> {
            match inputs.models.as_ref().map(|d| d.join(format!("{name}.onnx"))).filter(|p| p.is_file()) {
                Some(p) => OnnxModel::load(&p).map(Some),
                None => Ok(None),
            }
        };
        let pick = |flag: &Option<PathBuf>, beside: &[PathBuf]| -> Option<(PathBuf, String)> {
            match flag {
                Some(p) => Some((p.clone(), format!("flag {}", p.display()))),
                None => beside.iter().find(|p| p.is_file()).map(|p| (p.clone(), format!("file {}", p.display()))),
            }
        };
        let depth = match pick(&inputs.depth, &[inputs.beside("depth.exr"), inputs.beside("depth.png")]) {
            Some((p, src)) => {
                let d = load_depth(&p, inputs.depth_units)?;
                check_size("depth map", &p, (d.image.width, d.image.height), &photo)?;
                let units = format!("{:?}", inputs.depth_units).to_lowercase();
                sources.insert("depth".into(), format!("{src} ({units})"));
                Some(d)
            }
            None => match model("depth")? {
                Some(mut m) => {
                    let d = estimate_depth(&mut m, &photo)?;
                    sources.insert("depth".into(), format!("model {} (disparity)", m.path.display()));
                    Some(d)
                }
                None => None,
            },
        };
        let mut label_warnings = vec![];
        let instances = match pick(&inputs.masks, &[inputs.beside("masks.png")]) {
            Some((p, src)) => {
                let labels =
                    inputs.labels.clone().or_else(|| Some(inputs.beside("labels.json")).filter(|l| l.is_file()));
                let (m, notes) = load_instances(&p, labels.as_deref(), Some((photo.width, photo.height)))?;
                label_warnings = notes;
                check_size("instance mask", &p, (m.width, m.height), &photo)?;
                sources.insert(
                    "instances".into(),
                    format!(
                        "{src}, labels {}",
                        labels.map_or("none (every instance is an object)".into(), |l| l.display().to_string())
                    ),
                );
                Some(m)
            }
            None => match model("segmentation")? {
                Some(mut m) => {
                    let inst = estimate_instances(&mut m, &photo)?;
                    sources.insert("instances".into(), format!("model {} (ADE20K classes)", m.path.display()));
                    Some(inst)
                }
                None => None,
            },
        };
        let mut warnings = label_warnings;
        let mut fov_estimate = None;
        let fov_y_deg = match (inputs.fov_y_deg, inputs.beside("camera.json")) {
            (Some(f), _) => {
                let f = check_fov(f).map_err(|m| Error::Invalid(format!("--fov: {m}")))?;
                sources.insert("fov".into(), format!("flag --fov {f}"));
                f
            }
            (None, p) if p.is_file() => {
                let f = load_camera(&p)?;
                sources.insert("fov".into(), format!("file {}", p.display()));
                f
            }
            _ if inputs.models.as_ref().is_some_and(|d| d.join("fov.onnx").is_file()) => {
                let mut m = model("fov")?.ok_or_else(|| Error::Invalid("fov model vanished".into()))?;
                let f = estimate_fov_onnx(&mut m, &photo)?;
                sources.insert("fov".into(), format!("model {}", m.path.display()));
                f
            }
            _ => match estimate_fov(
                &photo,
                &VanishingOptions { max_sigma_deg: inputs.fov_max_sigma_deg, ..Default::default() },
            ) {
                Ok(e) => {
                    sources.insert(
                        "fov".into(),
                        format!(
                            "vanishing points: {:.1} ± {:.1} degrees from {} line segments in {} directions",
                            e.fov_y_deg,
                            e.sigma_deg,
                            e.segments,
                            e.vanishing_points.len()
                        ),
                    );
                    let f = e.fov_y_deg;
                    fov_estimate = Some(e);
                    f
                }
                Err(failure) => {
                    let w = format!(
                        "field of view: the default {DEFAULT_FOV_Y_DEG} degrees, a guess: the vanishing points did not \
                         fix it ({failure}); give it with --fov or {}.camera.json",
                        stem_of(&inputs.photo)
                    );
                    sources.insert(
                        "fov".into(),
                        format!("default {DEFAULT_FOV_Y_DEG} degrees (vanishing points: {failure})"),
                    );
                    warnings.push(w);
                    DEFAULT_FOV_Y_DEG
                }
            },
        };
        let mut obs = Observations {
            photo_path: inputs.photo.clone(),
            photo,
            depth,
            instances,
            fov_y_deg: Some(fov_y_deg),
            fov_estimate,
            depth_calibration: None,
            room_layout: None,
            sources,
            warnings,
        };
        obs.check_depth_direction()?;
        // A photo whose room the calibration cannot read keeps its relative depth; the reason is kept for
        // whoever asks for metric depth.
        if let Err(e) = obs.calibrate_depth(inputs.camera_height) {
            obs.warnings.push(format!("depth: could not be made metric: {e}"));
        }
        Ok(obs)
    }

    /// Stops on a depth map that runs against its units on the floor (`depth_direction`), naming the units
    /// that fit it; the trend is kept in `sources` either way.
    fn check_depth_direction(&mut self) -> Result<()> {
        let (Some(depth), Some(inst)) = (&self.depth, &self.instances) else { return Ok(()) };
        let floor: Vec<bool> = inst.class_mask("floor").into_iter().map(|v| v > 0.5).collect();
        let Some(trend) = floor_depth_trend(&depth.image.data, depth.units, &floor, depth.image.width) else {
            return Ok(());
        };
        let units = format!("{:?}", depth.units).to_lowercase();
        if trend < INVERTED_BELOW {
            let (flip, what) = match depth.units {
                DepthUnits::Disparity => ("metres (or relative)", "larger values farther away"),
                _ => ("disparity", "larger values nearer"),
            };
            return Err(Error::Invalid(format!(
                "the depth of {} ({}) runs backwards for {units}: on the floor it falls towards the horizon (rank                  correlation {trend:.2}), so the map has {what}; give --depth-units {flip}",
                self.photo_path.display(),
                self.sources.get("depth").map_or("depth", String::as_str),
            )));
        }
        let note =
            format!("; on the floor it rises towards the horizon as {units} should (rank correlation {trend:.2})");
        self.sources.entry("depth".into()).or_default().push_str(&note);
        Ok(())
    }

    /// Relative depth to metres, when there is a floor (and walls) to find its shift on; otherwise it stays
    /// relative and `require_depth` says what is missing.
    fn calibrate_depth(&mut self, camera_height: f32) -> Result<()> {
        let (Some(depth), Some(inst), Some(fov)) = (&self.depth, &self.instances, self.fov_y_deg) else {
            return Ok(());
        };
        if depth.units == DepthUnits::Metres || !inst.instances.iter().any(|i| i.class == "floor") {
            return Ok(());
        }
        let mask = |c: &str| inst.class_mask(c).into_iter().map(|v| v > 0.5).collect::<Vec<bool>>();
        let (floor, walls, ceiling) = (mask("floor"), mask("wall"), mask("ceiling"));
        let k = Intrinsics::new(self.photo.width, self.photo.height, fov);
        let depth = depth.clone();
        let (mut metres, mut cal) =
            calibrate_relative_depth(&depth.image.data, depth.units, [&floor, &walls, &ceiling], &k, camera_height, 1)?;
        let units = format!("{:?}", depth.units).to_lowercase();
        let mut note = format!(
            "; {units} depth made metric: shift {:.4} from the room's planes, scale from a camera height prior of \
             {camera_height} m",
            cal.shift
        );
        match check_against_layout(
            &self.photo,
            fov,
            &depth.image.data,
            depth.units,
            &metres,
            [&floor, &walls, &ceiling],
            &k,
            camera_height,
        ) {
            Ok(l) => {
                let c = &l.check;
                if let (Some(room), Some(mapped)) = (l.room, l.metres) {
                    note = format!(
                        "; {units} depth made metric by its order on the room layout (frame from {}, mask IoU {:.3} \
                         against {:.3} for the affine calibration's box; rank correlation {:.3}), scale from a \
                         camera height prior of {camera_height} m",
                        c.frame,
                        c.box_iou_layout,
                        c.box_iou_affine,
                        c.rank_correlation.unwrap_or(f32::NAN)
                    );
                    self.warnings.push(format!(
                        "depth: the {units} depth is not affine in distance (its room fits the segmentation with IoU \
                         {:.3}, the layout from lines and masks {:.3}): the room comes from the layout, and the depth \
                         keeps only its order",
                        c.box_iou_affine, c.box_iou_layout
                    ));
                    metres = mapped;
                    self.room_layout = Some(room);
                }
                cal.layout = Some(l.check);
            }
            Err(e) => self.warnings.push(format!("depth: the room layout from lines and masks was not found: {e}")),
        }
        self.sources.entry("depth".into()).or_default().push_str(&note);
        self.warnings.push(format!(
            "scale: the depth is {units}, so the room's size in metres rests on the assumed camera height \
             {camera_height} m (set it with camera_height); its proportions are measured"
        ));
        let missing = metres.iter().filter(|v| **v <= 0.0).count();
        self.depth = Some(Depth {
            image: Image::new(depth.image.width, depth.image.height, 1, metres)?,
            units: DepthUnits::Metres,
            missing,
        });
        self.depth_calibration = Some(cal);
        Ok(())
    }

    fn stem(&self) -> String {
        stem_of(&self.photo_path)
    }

    /// The depth in metres (measured, or relative made metric), or an error listing how to supply it.
    pub fn require_depth(&self) -> Result<&Depth> {
        if let Some(d) = self.depth.as_ref().filter(|d| d.units != DepthUnits::Metres) {
            let why = self.warnings.iter().find(|w| w.starts_with("depth: could not")).cloned().unwrap_or_default();
            return Err(Error::Invalid(format!(
                "the depth of {} is {:?} (unknown scale and shift); its shift is found on the floor and walls, so it \
                 needs a segmentation with a floor ({}.masks.png + {}.labels.json, or --masks/--labels). {why}",
                self.photo_path.display(),
                d.units,
                self.stem(),
                self.stem()
            )));
        }
        self.depth.as_ref().ok_or_else(|| {
            Error::Invalid(format!(
                "no depth for {}: put {s}.depth.exr (or a 16-bit {s}.depth.png) beside the photo, or pass --depth FILE \
                 (--depth-units metres|relative|disparity), or --models DIR holding a depth.onnx, {}",
                self.photo_path.display(),
                crate::models::fetch_hint("depth.onnx"),
                s = self.stem()
            ))
        })
    }

    /// The depth and the instances, or one error naming all that is missing: a photo with nothing beside it
    /// lacks both, and its user should learn that from one message, not one file per run.
    pub fn require_depth_and_instances(&self) -> Result<(&Depth, &Instances)> {
        if self.depth.is_none() && self.instances.is_none() {
            return Err(Error::Invalid(format!(
                "no depth and no segmentation for {}: put {s}.depth.exr (or a 16-bit {s}.depth.png), {s}.masks.png \
                 (16-bit instance ids, 0 = none) and {s}.labels.json ({{\"<id>\": \"<class>\"}}) beside the photo, or \
                 pass --depth FILE --masks FILE --labels FILE, or --models DIR holding depth.onnx and \
                 segmentation.onnx, {}",
                self.photo_path.display(),
                crate::models::fetch_hint_files(&["depth.onnx", "segmentation.onnx"]),
                s = self.stem()
            )));
        }
        Ok((self.require_depth()?, self.require_instances()?))
    }

    /// The instances, or an error listing how to supply them.
    pub fn require_instances(&self) -> Result<&Instances> {
        self.instances.as_ref().ok_or_else(|| {
            Error::Invalid(format!(
                "no segmentation for {}: put {s}.masks.png (16-bit instance ids, 0 = none) and {s}.labels.json \
                 ({{\"<id>\": \"<class>\"}}) beside the photo, or pass --masks FILE --labels FILE, or --models DIR holding a \
                 segmentation.onnx, {}",
                self.photo_path.display(),
                crate::models::fetch_hint("segmentation.onnx"),
                s = self.stem()
            ))
        })
    }

    /// The vertical field of view, or an error listing how to supply it.
    pub fn require_fov(&self) -> Result<f32> {
        self.fov_y_deg.ok_or_else(|| {
            Error::Invalid(format!(
                "no field of view for {}: put {}.camera.json ({{\"fov_y_deg\": 60}}) beside the photo, or pass --fov DEGREES",
                self.photo_path.display(),
                self.stem()
            ))
        })
    }

    /// Writes the resolved observations into `dir` under the photo's stem, in the formats they are read from
    /// (so the folder can be edited and fed back), plus a colour-coded overlay of the instances and
    /// `observations.json` (sources, instances with classes and pixel counts).
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let s = self.stem();
        let (w, h) = (self.photo.width as u32, self.photo.height as u32);
        let mut written = vec![];
        let photo = dir.join(format!("{s}.png"));
        crate::output::write_png_srgb(&photo, w, h, &self.photo.data)?;
        written.push(photo);
        if let Some(d) = &self.depth {
            let p = dir.join(format!("{s}.depth.exr"));
            crate::output::write_atomically(&p, |tmp| {
                crate::output::write_exr_channels(tmp, w, h, &[("Z".to_string(), d.image.data.clone())])
            })?;
            written.push(p);
        }
        if let Some(m) = &self.instances {
            let p = dir.join(format!("{s}.masks.png"));
            let img = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, m.ids.clone())
                .ok_or_else(|| Error::io(&p, "mask size mismatch"))?;
            crate::output::write_atomically(&p, |tmp| {
                img.save_with_format(tmp, image::ImageFormat::Png).map_err(|e| Error::io(tmp, e))
            })?;
            written.push(p);
            let labels: BTreeMap<String, String> =
                m.instances.iter().map(|i| (i.id.to_string(), i.class.clone())).collect();
            let p = dir.join(format!("{s}.labels.json"));
            write_json(&p, &json!(labels))?;
            written.push(p);
            let p = dir.join(format!("{s}.overlay.png"));
            crate::output::write_png_srgb(&p, w, h, &overlay(&self.photo, m))?;
            written.push(p);
        }
        if let Some(f) = self.fov_y_deg {
            let p = dir.join(format!("{s}.camera.json"));
            write_json(&p, &json!({ "fov_y_deg": f }))?;
            written.push(p);
        }
        let p = dir.join("observations.json");
        let summary = json!({
            "photo": self.photo_path, "width": w, "height": h, "sources": self.sources,
            "fov_y_deg": self.fov_y_deg,
            "fov_estimate": self.fov_estimate,
            "depth": self.depth.as_ref().map(|d| json!({"units": d.units, "missing_pixels": d.missing})),
            "depth_calibration": self.depth_calibration,
            "warnings": self.warnings,
            "instances": self.instances.as_ref().map(|m| &m.instances),
        });
        write_json(&p, &summary)?;
        written.push(p);
        Ok(written)
    }
}

fn stem_of(photo: &Path) -> String {
    photo.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "photo".into())
}

fn write_json(path: &Path, v: &serde_json::Value) -> Result<()> {
    let text = serde_json::to_string_pretty(v).map_err(|e| Error::io(path, e))?;
    crate::output::write_atomically(path, |tmp| std::fs::write(tmp, &text).map_err(|e| Error::io(tmp, e)))
}

/// The photo with each instance tinted by a colour of its own (structure classes in greys and blues), linear.
fn overlay(photo: &Image, m: &Instances) -> Vec<f32> {
    let colour = |id: u16| -> [f32; 3] {
        let class = m.instances.iter().find(|i| i.id == id).map_or("", |i| i.class.as_str());
        match class {
            "floor" => [0.35, 0.2, 0.05],
            "wall" => [0.3, 0.3, 0.3],
            "ceiling" => [0.6, 0.6, 0.7],
            _ => {
                // A hashed hue per instance.
                let hsh = (id as u32).wrapping_mul(2654435761) >> 16;
                let f = |k: u32| ((hsh >> (k * 5)) & 31) as f32 / 31.0 * 0.8 + 0.1;
                [f(0), f(1), f(2)]
            }
        }
    };
    let mut out = photo.data.clone();
    for (p, &id) in m.ids.iter().enumerate() {
        if id != 0 {
            let c = colour(id);
            for k in 0..3 {
                out[p * 3 + k] = 0.5 * out[p * 3 + k] + 0.5 * c[k];
            }
        }
    }
    out
}
