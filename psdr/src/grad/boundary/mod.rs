//! Boundary terms: the mesh edges and their tree, and the primary, secondary and horizon boundaries.

pub(crate) mod edge_tree;
pub(crate) mod horizon;
pub(crate) mod mesh_edges;
pub(crate) mod primary;
pub(crate) mod secondary;
pub(crate) mod shadow;
