//! The CPU reference backend (rayon).

use super::{check_settings, Backend, Progress};
use crate::error::Result;
use crate::render::{render_cpu, Frame, SceneData};
use crate::scene::RenderSettings;

pub struct CpuBackend;

impl Backend for CpuBackend {
    fn name(&self) -> String {
        format!("cpu ({} threads)", rayon::current_num_threads())
    }
    fn render(&mut self, data: &SceneData, settings: &RenderSettings, progress: Progress) -> Result<Frame> {
        check_settings(settings)?;
        Ok(render_cpu(data, settings, progress))
    }
}
