//! The CPU reference backend (rayon).

use super::{check_settings, Backend, Progress};
use crate::error::Result;
use crate::render::unit_paths::{render_units_cpu, UnitLights};
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
    fn unit_radiances(
        &mut self,
        data: &mut SceneData,
        settings: &RenderSettings,
        emitters: &[usize],
    ) -> Result<Vec<Vec<f32>>> {
        check_settings(settings)?;
        let units = UnitLights::new(data, emitters)?;
        Ok(render_units_cpu(data, settings, &units))
    }
}
