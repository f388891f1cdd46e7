//! How each optimised parameter maps from the unconstrained vector Adam moves (u) to the scene value (θ):
//! constraints are expressed by parametrisation and projection, never by penalties a user must tune.
//! - `Linear`: θ = u, clamped into [lower, upper] after each step (albedo in [0, 1], roughness in [0.02, 1]).
//! - `Log`: θ = exp(u) per component: positive, and steps are relative (radiance, scale, uv scale).
//! - `UniformLog`: θ = θ₀ · exp(u) with one u for all components (uniform scale keeps an object's proportions).
//! - `Range`: θ = lower + u · (upper − lower), u in [0, 1]: a procedural graph's parameters, whose declared
//!   ranges differ by orders of magnitude (a gap of 0..0.15, a warp of 0..2.5), so a rate is a fraction of one.
//! - `free`: components that may move; the others keep their start value (translation `free: "xz"` moves an
//!   object in the floor plane only, so one standing on the floor keeps its height).

use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::scene::{ParamPath, TextureSlot};
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Space {
    Linear,
    Log,
    UniformLog,
    Range,
}

/// Learning-rate schedule: the factor applied to a group's rate at iteration t of T.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Schedule {
    Constant,
    /// gamma^t.
    Exponential {
        gamma: f64,
    },
    /// gamma^floor(t / every).
    Step {
        every: usize,
        gamma: f64,
    },
    /// Cosine from 1 down to `min` at the last iteration.
    Cosine {
        min: f64,
    },
}

impl Schedule {
    pub fn factor(&self, t: usize, iters: usize) -> f64 {
        match *self {
            Schedule::Constant => 1.0,
            Schedule::Exponential { gamma } => gamma.powi(t as i32),
            Schedule::Step { every, gamma } => gamma.powi((t / every.max(1)) as i32),
            Schedule::Cosine { min } => {
                let x = t as f64 / (iters.max(2) - 1) as f64;
                min + (1.0 - min) * 0.5 * (1.0 + (std::f64::consts::PI * x.min(1.0)).cos())
            }
        }
    }
}

/// One optimised parameter: its path, parametrisation, bounds, rate and schedule.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamSpec {
    #[serde(with = "path_text")]
    pub path: ParamPath,
    pub space: Space,
    /// Per component of θ: may it move.
    pub free: Vec<bool>,
    /// Bounds of every θ component (the projection after each step); infinite bounds are written as null.
    #[serde(with = "lower_bound")]
    pub lower: f32,
    #[serde(with = "upper_bound")]
    pub upper: f32,
    /// Per-component bounds on top of `lower`/`upper` (empty: none); a translation kept inside a box whose
    /// sides differ per axis (a light inside the room).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lower_each: Vec<f32>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub upper_each: Vec<f32>,
    pub lr: f64,
    pub schedule: Schedule,
    /// θ when the spec was made: the value of locked components, and θ₀ of `UniformLog`.
    pub start: Vec<f32>,
}

/// JSON has no infinities: an unbounded side is written as null.
macro_rules! bound_serde {
    ($name:ident, $inf:expr) => {
        mod $name {
            use serde::{Deserialize, Deserializer, Serializer};
            pub fn serialize<S: Serializer>(v: &f32, s: S) -> Result<S::Ok, S::Error> {
                if v.is_finite() {
                    s.serialize_f32(*v)
                } else {
                    s.serialize_none()
                }
            }
            pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
                Ok(Option::<f32>::deserialize(d)?.unwrap_or($inf))
            }
        }
    };
}
bound_serde!(lower_bound, f32::NEG_INFINITY);
bound_serde!(upper_bound, f32::INFINITY);

/// Serialises a parameter path as its text.
mod path_text {
    use crate::scene::ParamPath;
    use serde::{Deserialize, Deserializer, Serializer};
    pub fn serialize<S: Serializer>(p: &ParamPath, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&p.to_string())
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<ParamPath, D::Error> {
        String::deserialize(d)?.parse().map_err(serde::de::Error::custom)
    }
}

/// Defaults per kind of parameter: (space, lower, upper, learning rate). Rates are per Adam step in u's units:
/// metres, radians and degrees for linear poses and uv rotation, relative change for log spaces.
pub fn defaults(path: &ParamPath) -> (Space, f32, f32, f64) {
    use ParamPath::*;
    let inf = f32::INFINITY;
    match path {
        LightRadiance(_) => (Space::Log, 1e-6, inf, 0.05),
        MaterialAlbedo(_) => (Space::Linear, 0.0, 1.0, 0.02),
        MaterialRoughness(_) => (Space::Linear, 0.02, 1.0, 0.02),
        MaterialSpecular(_) => (Space::Linear, 0.0, 1.0, 0.02),
        MaterialTexel { slot: TextureSlot::Roughness, .. } => (Space::Linear, 0.02, 1.0, 0.02),
        MaterialTexel { .. } => (Space::Linear, 0.0, 1.0, 0.02),
        UvScale(_) => (Space::Log, 1e-3, 1e3, 0.02),
        UvRotation(_) => (Space::Linear, -inf, inf, 1.0),
        Translation(_) => (Space::Linear, -inf, inf, 0.01),
        Yaw(_) | Rotation(_) => (Space::Linear, -inf, inf, 0.02),
        Scale(_) => (Space::Log, 1e-3, 1e3, 0.02),
        Vertices(_) => (Space::Linear, -inf, inf, 0.002),
        // Bounds from the graph (ParamSpec::new); the rate is a fraction of the range.
        GraphParam { .. } => (Space::Range, 0.0, 1.0, 0.02),
        ProceduralTint(_) => (Space::Log, 1e-3, 1e3, 0.02),
    }
}

impl ParamSpec {
    /// The default spec of `path` at the scene's current value.
    pub fn new(scene: &Scene, path: ParamPath) -> Result<ParamSpec> {
        let start = path.get(scene)?;
        let (space, mut lower, mut upper, lr) = defaults(&path);
        if let ParamPath::GraphParam { material, name } = &path {
            let p = scene.materials[scene.material_index(material).expect("checked by get")]
                .procedural
                .as_ref()
                .expect("checked by get");
            let info = p.load_graph()?.param(name).cloned().expect("checked by get");
            lower = info.min.iter().cloned().fold(f64::INFINITY, f64::min) as f32;
            upper = info.max.iter().cloned().fold(f64::NEG_INFINITY, f64::max) as f32;
        }
        Ok(ParamSpec {
            free: vec![true; start.len()],
            path,
            space,
            lower,
            upper,
            lower_each: vec![],
            upper_each: vec![],
            lr,
            schedule: Schedule::Constant,
            start,
        })
    }

    /// Parses a free-component spec: "xz" (3-vectors), "xyz", or one letter per component of r/g/b; all other
    /// parameters take a list of booleans through `free` directly.
    pub fn set_free_axes(&mut self, axes: &str) -> Result<()> {
        let names = ['x', 'y', 'z'];
        if self.start.len() != 3 || axes.is_empty() || !axes.chars().all(|c| names.contains(&c)) {
            return Err(Error::Invalid(format!(
                "{}: free axes '{axes}' must be letters of xyz, for a 3-vector parameter",
                self.path
            )));
        }
        self.free = names.iter().map(|c| axes.contains(*c)).collect();
        Ok(())
    }

    /// Checks the spec is usable: sensible bounds, a positive rate, log spaces with positive values.
    pub fn check(&self) -> Result<()> {
        let bad = |m: String| Err(Error::Invalid(format!("{}: {m}", self.path)));
        if !(self.lr.is_finite() && self.lr > 0.0) {
            return bad(format!("learning rate {} must be positive and finite", self.lr));
        }
        if self.lower.is_nan() || self.upper.is_nan() || self.lower > self.upper {
            return bad(format!("bounds [{}, {}] are empty", self.lower, self.upper));
        }
        if self.space == Space::Range && !(self.lower.is_finite() && self.upper.is_finite() && self.upper > self.lower)
        {
            return bad(format!("a range parametrisation needs finite bounds, not [{}, {}]", self.lower, self.upper));
        }
        if matches!(self.space, Space::Log | Space::UniformLog) && self.start.iter().any(|&v| v <= 0.0) {
            return bad(format!("a log parametrisation needs positive values, the start is {:?}", self.start));
        }
        for (each, side) in [(&self.lower_each, "min"), (&self.upper_each, "max")] {
            if !each.is_empty() && (each.len() != self.start.len() || !each.iter().all(|v| v.is_finite())) {
                return bad(format!("{side} has {} finite entries for {} components", each.len(), self.start.len()));
            }
            if !each.is_empty() && self.space == Space::Range {
                return bad(format!("a range parametrisation takes one {side}, not one per component"));
            }
        }
        if (0..self.start.len()).any(|i| self.bound(i).0 > self.bound(i).1) {
            return bad(format!(
                "per-component bounds {:?}..{:?} are empty somewhere",
                self.lower_each, self.upper_each
            ));
        }
        if self.free.len() != self.start.len() {
            return bad(format!("free has {} entries for {} components", self.free.len(), self.start.len()));
        }
        Ok(())
    }

    /// Length of u.
    pub fn dims(&self) -> usize {
        match self.space {
            Space::UniformLog => 1,
            _ => self.start.len(),
        }
    }

    /// u for a scene value θ.
    pub fn to_u(&self, theta: &[f32]) -> Vec<f64> {
        match self.space {
            Space::Linear => theta.iter().map(|&v| v as f64).collect(),
            Space::Log => theta.iter().map(|&v| (v.max(1e-30) as f64).ln()).collect(),
            Space::Range => theta.iter().map(|&v| (v as f64 - self.lower as f64) / self.range()).collect(),
            Space::UniformLog => {
                // Mean log ratio to the start: exact when θ is a multiple of θ₀.
                let n = theta.len().max(1) as f64;
                vec![
                    theta.iter().zip(&self.start).map(|(&t, &s)| (t as f64 / s as f64).max(1e-30).ln()).sum::<f64>()
                        / n,
                ]
            }
        }
    }

    /// θ for u (locked components keep their start value).
    pub fn to_theta(&self, u: &[f64]) -> Vec<f32> {
        let mut theta: Vec<f32> = match self.space {
            Space::Linear => u.iter().map(|&v| v as f32).collect(),
            Space::Log => u.iter().map(|&v| v.exp() as f32).collect(),
            Space::Range => u.iter().map(|&v| (self.lower as f64 + v * self.range()) as f32).collect(),
            Space::UniformLog => self.start.iter().map(|&s| (s as f64 * u[0].exp()) as f32).collect(),
        };
        for (i, t) in theta.iter_mut().enumerate() {
            if !self.free[i] {
                *t = self.start[i];
            }
        }
        theta
    }

    /// dL/du from dL/dθ at θ (the chain rule of `to_theta`); locked components contribute nothing.
    pub fn grad_u(&self, theta: &[f32], g_theta: &[f64]) -> Vec<f64> {
        let g = |i: usize| if self.free[i] { g_theta[i] } else { 0.0 };
        match self.space {
            Space::Linear => (0..theta.len()).map(g).collect(),
            Space::Log => (0..theta.len()).map(|i| g(i) * theta[i] as f64).collect(),
            Space::Range => (0..theta.len()).map(|i| g(i) * self.range()).collect(),
            Space::UniformLog => vec![(0..theta.len()).map(|i| g(i) * theta[i] as f64).sum()],
        }
    }

    /// Component i's bounds: the common ones tightened by the per-component ones.
    fn bound(&self, i: usize) -> (f64, f64) {
        let lo = self.lower_each.get(i).map_or(self.lower, |&v| v.max(self.lower));
        let hi = self.upper_each.get(i).map_or(self.upper, |&v| v.min(self.upper));
        (lo as f64, hi as f64)
    }

    fn range(&self) -> f64 {
        self.upper as f64 - self.lower as f64
    }

    /// Projects u so that every θ component lies in [lower, upper].
    pub fn project(&self, u: &mut [f64]) {
        match self.space {
            Space::Linear => u.iter_mut().enumerate().for_each(|(i, v)| {
                let (lo, hi) = self.bound(i);
                *v = v.clamp(lo, hi)
            }),
            Space::Log => u.iter_mut().enumerate().for_each(|(i, v)| {
                let (lo, hi) = self.bound(i);
                *v = v.clamp(lo.max(1e-30).ln(), hi.ln())
            }),
            Space::Range => u.iter_mut().for_each(|v| *v = v.clamp(0.0, 1.0)),
            Space::UniformLog => {
                // The tightest bound over components: θ₀ᵢ·e^u within [lo, hi] for every i.
                let (mut ulo, mut uhi) = (f64::NEG_INFINITY, f64::INFINITY);
                for (i, &s) in self.start.iter().enumerate() {
                    let (lo, hi) = self.bound(i);
                    ulo = ulo.max((lo.max(1e-30) / s as f64).ln());
                    uhi = uhi.min((hi / s as f64).ln());
                }
                if ulo <= uhi {
                    u[0] = u[0].clamp(ulo, uhi);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Specs survive a checkpoint's JSON, unbounded sides included.
    #[test]
    fn specs_round_trip_through_json() {
        let spec = ParamSpec {
            path: "object/a/translation".parse().unwrap(),
            space: Space::Linear,
            free: vec![true, false, true],
            lower: f32::NEG_INFINITY,
            upper: f32::INFINITY,
            lower_each: vec![-3.0, -1.0, -4.0],
            upper_each: vec![3.0, 1.0, 0.5],
            lr: 0.01,
            schedule: Schedule::Step { every: 5, gamma: 0.5 },
            start: vec![1.0, 0.0, -2.0],
        };
        let back: ParamSpec = serde_json::from_str(&serde_json::to_string(&spec).unwrap()).unwrap();
        assert_eq!(back, spec);
    }

    /// Per-component bounds keep each component in its own interval, in linear and log spaces, and an
    /// interval that excludes the common bounds' is refused.
    #[test]
    fn per_component_bounds_project_each_component() {
        let mut spec = ParamSpec {
            path: "light/a/radiance".parse().unwrap(),
            space: Space::Log,
            free: vec![true; 3],
            lower: 1e-6,
            upper: f32::INFINITY,
            lower_each: vec![],
            upper_each: vec![],
            lr: 0.05,
            schedule: Schedule::Constant,
            start: vec![1.0; 3],
        };
        spec.lower_each = vec![0.5, 2.0, 1e-3];
        spec.upper_each = vec![1.0, 4.0, 8.0];
        spec.check().unwrap();
        let mut u = vec![0.0f64, 0.0, 5.0f64.ln()]; // θ = 1, 1, 5
        spec.project(&mut u);
        let theta = spec.to_theta(&u);
        assert!((theta[0] - 1.0).abs() < 1e-6 && (theta[1] - 2.0).abs() < 1e-6 && (theta[2] - 5.0).abs() < 1e-5);
        spec.space = Space::Linear;
        let mut u = vec![-1.0, 9.0, 3.0];
        spec.project(&mut u);
        assert_eq!(u, vec![0.5, 4.0, 3.0]);
        spec.lower = 5.0;
        assert!(spec.check().is_err(), "component 0 has no room between max(5, 0.5) and 1");
        spec.lower = 1e-6;
        spec.upper_each = vec![1.0, 4.0];
        assert!(spec.check().is_err(), "two bounds for three components");
    }

    /// θ → u → θ is the identity in every space, and the chain rule of grad_u matches differences of to_theta.
    #[test]
    fn parametrisations_invert_and_differentiate() {
        for space in [Space::Linear, Space::Log, Space::UniformLog, Space::Range] {
            let start = vec![0.5f32, 2.0, 1.5];
            let spec = ParamSpec {
                path: "object/a/scale".parse().unwrap(),
                space,
                free: vec![true; 3],
                lower: 1e-3,
                upper: 1e3,
                lower_each: vec![],
                upper_each: vec![],
                lr: 0.1,
                schedule: Schedule::Constant,
                start: start.clone(),
            };
            let u = spec.to_u(&start);
            for (a, b) in spec.to_theta(&u).iter().zip(&start) {
                assert!((a - b).abs() < 1e-6 * b, "{space:?}: {a} vs {b}");
            }
            let g_theta = [0.3, -1.0, 2.0];
            let gu = spec.grad_u(&start, &g_theta);
            for k in 0..u.len() {
                let h = 1e-4;
                let (mut up, mut dn) = (u.clone(), u.clone());
                up[k] += h;
                dn[k] -= h;
                let (tu, td) = (spec.to_theta(&up), spec.to_theta(&dn));
                let fd: f64 = (0..3).map(|i| g_theta[i] * (tu[i] as f64 - td[i] as f64) / (2.0 * h)).sum();
                assert!((fd - gu[k]).abs() < 1e-3 * (1.0 + fd.abs()), "{space:?} u[{k}]: FD {fd} vs {}", gu[k]);
            }
        }
    }
}
