//! Photo observations: the photo (`photo`), depth (`depth`), instance segmentation with classes (`masks`,
//! `classes`), the field of view, and their resolution from flags and files beside the photo
//! (`observations`). Estimators (ONNX models, vanishing points) will add sources here.

mod classes;
mod depth;
mod masks;
mod observations;
mod photo;

pub use classes::{canonical_class, class_names, ClassKind, UNKNOWN_CLASS};
pub use depth::{load_depth, Depth, DepthUnits};
pub use masks::{load_instances, Instance, Instances};
pub use observations::{ObservationInputs, Observations};
pub use photo::load_photo;
