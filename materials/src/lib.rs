#![doc = include_str!("../README.md")]

pub mod cli;
pub mod error;
pub mod evaluator;
pub mod export;
mod font;
pub mod graph;
pub mod graph_file;
pub mod image;
pub mod kernel;
pub mod library;
pub mod node_op;
pub mod nodes;
pub mod noise;
pub mod real;
pub mod render_maps;
pub mod texture_transform;

pub use error::{GraphError, ParamError};
pub use evaluator::{Evaluator, MapKind};
pub use graph::{Graph, ParamInfo, ParamKind, Params};
pub use image::Image;
pub use render_maps::{RenderGrads, RenderMaps};
pub use texture_transform::{PreparedTransform, TextureTransform, TextureView, TransformGrad};
