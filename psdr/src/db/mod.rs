//! The furniture model database: an index of OBJ models with categories, real sizes and licences, from which
//! the object stage retrieves candidates. So far: a folder of OBJ files with an optional `catalog.json`
//! (`model_set`).

mod model_set;

pub use model_set::{ModelEntry, ModelSet};
