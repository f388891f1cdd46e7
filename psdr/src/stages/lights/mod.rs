//! The light stage: the height of a ceiling the photo does not show, from the light it throws
//! (`ceiling_search`); candidate lights (`light_init`), the windows and ceiling lights the photo shows
//! (`window_lights`, `ceiling_panels`), their
//! radiances fitted to the photo with backward elimination (`light_fit`), and their positions and sizes
//! (`light_placement`), a window the photo does not show where the light falls as from one (`unseen_window`),
//! the windows' daylight shaped by direction (`window_sky`), and how each may move when
//! the joint fit moves it by gradient (`light_motion`).

mod albedo_free_split;
mod ceiling_panels;
mod ceiling_search;
mod emitter_outline;
mod light_fit;
mod light_init;
mod light_motion;
mod light_placement;
mod light_view;
mod unseen_window;
mod window_lights;
mod window_sky;

pub use ceiling_panels::{add_visible_ceiling_lights, is_edge_ceiling_light, is_visible_ceiling_light};
pub use ceiling_search::{search_ceiling_height, CeilingSearch, CeilingSearchOptions};
pub use emitter_outline::{fit_light_outlines, LightOutline};
pub use light_fit::{fit_lights, nnls, Agreement, LightFit, LightFitOptions};
pub use light_init::{init_lights, LightInitOptions};
pub use light_motion::{light_motion, LightMotion};
pub use light_placement::{refine_light_placement, LightPlacement, LightPlacementOptions};
pub use unseen_window::{add_unseen_window, UnseenWindow, UnseenWindowOptions};
pub use window_lights::{add_visible_windows, is_visible_window};
pub use window_sky::{fit_window_skies, WindowSky, WindowSkyOptions};

/// Whether `name` is a light the photo shows where its pixels are (a window or a ceiling light): the
/// placement leaves it there.
pub fn is_visible_light(name: &str) -> bool {
    is_visible_window(name) || is_visible_ceiling_light(name)
}
