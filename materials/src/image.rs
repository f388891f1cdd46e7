//! Square multi-channel image buffer (row-major, row 0 at the top, f64 texels).

/// An N x N image with 1 (grey) or 3 (colour) interleaved channels.
#[derive(Clone, Debug, Default)]
pub struct Image {
    pub size: usize,
    pub channels: usize,
    pub data: Vec<f64>,
}

impl Image {
    pub fn new(size: usize, channels: usize) -> Self {
        Image { size, channels, data: vec![0.0; size * size * channels] }
    }

    /// Reshape in place; reallocates only when the buffer must grow.
    pub fn reshape(&mut self, size: usize, channels: usize) {
        self.size = size;
        self.channels = channels;
        self.data.resize(size * size * channels, 0.0);
    }

    pub fn fill(&mut self, v: f64) {
        self.data.iter_mut().for_each(|x| *x = v);
    }

    /// Texel channel `c` at wrapped integer coordinates; grey images broadcast.
    #[inline(always)]
    pub fn at_wrapped(&self, x: i64, y: i64, c: usize) -> f64 {
        let n = self.size as i64;
        let xi = x.rem_euclid(n) as usize;
        let yi = y.rem_euclid(n) as usize;
        let c = if self.channels == 1 { 0 } else { c };
        self.data[(yi * self.size + xi) * self.channels + c]
    }
}
