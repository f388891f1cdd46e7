//! Exports to other renderers.

pub mod gltf;
pub mod mitsuba;
mod ply;
