//! Linear EXR files with arbitrary named f32 channels.

use super::write_atomically;
use crate::error::{Error, Result};
use exr::prelude::*;
use std::path::Path;

/// Writes `channels` (name, row-major w*h values) as one layer.
pub fn write_exr_channels(path: &Path, width: u32, height: u32, channels: &[(String, Vec<f32>)]) -> Result<()> {
    let size = (width as usize, height as usize);
    let list: Vec<AnyChannel<FlatSamples>> =
        channels.iter().map(|(name, data)| AnyChannel::new(name.as_str(), FlatSamples::F32(data.clone()))).collect();
    let layer = Layer::new(
        size,
        LayerAttributes::named("psdr"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(list)),
    );
    let image = Image::from_layer(layer);
    write_atomically(path, |tmp| image.write().to_file(tmp).map_err(|e| Error::io(path, e)))
}

/// Reads every channel of the first layer as f32, with its name.
/// Named channels of an image, each row-major from the top.
pub type Channels = Vec<(String, Vec<f32>)>;

/// (width, height, channels).
pub fn read_exr_channels(path: &Path) -> Result<(u32, u32, Channels)> {
    let image = read_all_flat_layers_from_file(path).map_err(|e| match e {
        // The exr crate's words for a file without the EXR magic number ("file identifier missing").
        exr::error::Error::Invalid(what) if what.contains("identifier") => {
            Error::io(path, "not an OpenEXR file (a linear .exr is needed, e.g. from psdr render)")
        }
        e => Error::io(path, e),
    })?;
    let layer = image.layer_data.first().ok_or_else(|| Error::io(path, "EXR has no layers"))?;
    let (w, h) = (layer.size.width() as u32, layer.size.height() as u32);
    let channels =
        layer.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect())).collect();
    Ok((w, h, channels))
}

/// Reads an EXR as interleaved linear RGB: its R, G, B channels, or a single-channel (grey, e.g. Y) image
/// replicated to all three.
pub fn read_exr_rgb(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    let (w, h, channels) = read_exr_channels(path)?;
    let find = |name: &str| channels.iter().find(|c| c.0 == name).map(|c| &c.1);
    let planes: [&Vec<f32>; 3] = match (find("R"), find("G"), find("B"), channels.as_slice()) {
        (Some(r), Some(g), Some(b), _) => [r, g, b],
        (_, _, _, [(_, grey)]) => [grey; 3],
        _ => {
            let names: Vec<&str> = channels.iter().map(|c| c.0.as_str()).collect();
            return Err(Error::io(path, format!("EXR needs R, G, B channels or a single channel; it has {names:?}")));
        }
    };
    let rgb = (0..(w * h) as usize).flat_map(|i| planes.map(|p| p[i])).collect();
    Ok((w, h, rgb))
}
