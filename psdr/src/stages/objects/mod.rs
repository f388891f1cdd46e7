//! The object stage: instances a segmenter split merged (`instance_merge`), models retrieved and placed
//! (`object_init`) with their own colouring kept aside (`model_materials`), their poses searched against the masks and depth (`pose_search`) and set on what carries them
//! (`object_support`).

mod instance_merge;
mod model_materials;
mod object_init;
mod object_support;
mod pose_search;

pub use instance_merge::{merge_split_instances, MergedInstance};
pub use model_materials::model_looks;
pub(crate) use model_materials::picture_mean;
pub use object_init::{
    init_objects, init_objects_with, missing_classes, AppearanceCue, Candidate, ObjectInitOptions, ObjectPlacement,
    SkippedInstance,
};
