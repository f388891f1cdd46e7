//! Rendering: the flattened scene buffers and the primal kernels (CPU twins of shaders/*.glsl|comp).

pub mod bsdf;
pub mod bvh;
mod bvh_cache;
mod bvh_refit;
pub mod camera;
pub mod cpu;
pub mod frame;
pub mod layout;
pub mod light;
pub mod path_trace;
pub mod primary_hits;
pub mod sampler;
pub mod scene_data;
pub mod shading;
pub mod texture;
pub mod unit_paths;

pub use cpu::render_cpu;
pub use frame::Frame;
pub use scene_data::SceneData;
