//! The image type of losses: H x W x C floats, row-major from the top, channels interleaved per pixel (the
//! layout of `Frame::radiance`: 3 per pixel for radiance, 1 for depth and masks). A scalar is 1x1x1.

use crate::error::{Error, Result};

#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub data: Vec<f32>,
}

impl Image {
    /// Checks that `data` has width·height·channels values, all finite.
    pub fn new(width: usize, height: usize, channels: usize, data: Vec<f32>) -> Result<Image> {
        if width == 0 || height == 0 || channels == 0 {
            return Err(Error::Invalid(format!("image of size {width}x{height}x{channels} is empty")));
        }
        if data.len() != width * height * channels {
            return Err(Error::Invalid(format!(
                "image of size {width}x{height}x{channels} needs {} values, got {}",
                width * height * channels,
                data.len()
            )));
        }
        if let Some(i) = data.iter().position(|v| !v.is_finite()) {
            return Err(Error::Invalid(format!("image value {i} is {} (not finite)", data[i])));
        }
        Ok(Image { width, height, channels, data })
    }

    pub fn zeros(width: usize, height: usize, channels: usize) -> Image {
        Image { width, height, channels, data: vec![0.0; width * height * channels] }
    }

    pub fn scalar(v: f32) -> Image {
        Image { width: 1, height: 1, channels: 1, data: vec![v] }
    }

    pub fn is_scalar(&self) -> bool {
        self.data.len() == 1
    }

    pub fn get(&self, x: usize, y: usize, c: usize) -> f32 {
        self.data[(y * self.width + x) * self.channels + c]
    }

    pub fn pixels(&self) -> usize {
        self.width * self.height
    }

    /// "WxHxC", for messages.
    pub fn shape(&self) -> String {
        format!("{}x{}x{}", self.width, self.height, self.channels)
    }

    pub(crate) fn same_shape(&self, o: &Image) -> bool {
        (self.width, self.height, self.channels) == (o.width, o.height, o.channels)
    }

    pub(crate) fn like(&self, data: Vec<f32>) -> Image {
        Image { width: self.width, height: self.height, channels: self.channels, data }
    }
}
