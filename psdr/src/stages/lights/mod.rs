//! The light stage: candidate lights (`light_init`) and the windows the photo shows (`window_lights`), their
//! radiances fitted to the photo with backward elimination (`light_fit`), and their positions and sizes
//! (`light_placement`), and how each may move when the joint fit moves it by gradient (`light_motion`).

mod light_fit;
mod light_init;
mod light_motion;
mod light_placement;
mod window_lights;

pub use light_fit::{fit_lights, nnls, LightFit, LightFitOptions};
pub use light_init::{init_lights, LightInitOptions};
pub use light_motion::{light_motion, LightMotion};
pub use light_placement::{refine_light_placement, LightPlacement, LightPlacementOptions};
pub use window_lights::{add_visible_windows, is_visible_window};
