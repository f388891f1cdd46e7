//! Adam (Kingma & Ba 2015), the one optimiser of the project: per-component moments with bias correction, a
//! rate per parameter group. Its whole state serialises, so a checkpoint resumes a run exactly.

use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdamConfig {
    pub beta1: f64,
    pub beta2: f64,
    pub eps: f64,
}

impl Default for AdamConfig {
    fn default() -> Self {
        AdamConfig { beta1: 0.9, beta2: 0.999, eps: 1e-8 }
    }
}

/// Moments of one parameter vector.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AdamState {
    pub m: Vec<f64>,
    pub v: Vec<f64>,
    /// Steps taken (for the bias correction).
    pub t: u64,
}

impl AdamState {
    pub fn new(dims: usize) -> AdamState {
        AdamState { m: vec![0.0; dims], v: vec![0.0; dims], t: 0 }
    }

    /// One step of `x` against gradient `g` at rate `lr`.
    pub fn step(&mut self, cfg: &AdamConfig, lr: f64, x: &mut [f64], g: &[f64]) {
        self.t += 1;
        let c1 = 1.0 - cfg.beta1.powi(self.t as i32);
        let c2 = 1.0 - cfg.beta2.powi(self.t as i32);
        for i in 0..x.len() {
            self.m[i] = cfg.beta1 * self.m[i] + (1.0 - cfg.beta1) * g[i];
            self.v[i] = cfg.beta2 * self.v[i] + (1.0 - cfg.beta2) * g[i] * g[i];
            x[i] -= lr * (self.m[i] / c1) / ((self.v[i] / c2).sqrt() + cfg.eps);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first step moves every component by lr against the gradient's sign (bias correction makes m̂/√v̂ = ±1).
    #[test]
    fn first_step_is_lr_times_sign() {
        let mut s = AdamState::new(3);
        let mut x = [1.0, 2.0, 3.0];
        s.step(&AdamConfig::default(), 0.1, &mut x, &[5.0, -0.01, 0.0]);
        assert!((x[0] - 0.9).abs() < 1e-9 && (x[1] - 2.1).abs() < 1e-6 && x[2] == 3.0, "{x:?}");
    }

    /// On an ill-conditioned quadratic Adam converges to the minimum.
    #[test]
    fn minimises_a_quadratic() {
        let mut s = AdamState::new(2);
        let mut x = [3.0, -2.0];
        for t in 0..2000 {
            let g = [2.0 * (x[0] - 1.0), 200.0 * (x[1] + 0.5)];
            s.step(&AdamConfig::default(), 0.05 * 0.998f64.powi(t), &mut x, &g);
        }
        assert!((x[0] - 1.0).abs() < 1e-3 && (x[1] + 0.5).abs() < 1e-3, "{x:?}");
    }
}
