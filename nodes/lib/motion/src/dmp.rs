//! Dynamic movement primitives (thesis Sec. 3.1.1, eq. 3.3–3.4), the variant with the
//! `−K(g − x₀)s` term, for positions and for orientations (unit quaternions).
//!
//! ```text
//! τ ẋ = v
//! τ v̇ = K(g − x) − D v − K(g − x₀) s + K f(s)
//! τ ṡ = −γ s,      f(s) = Σ φ_k(s) w_k / Σ φ_k(s) · s,   φ_k(s) = exp(−h_k (s − c_k)²)
//! ```
//!
//! Time is in seconds with `τ = 1` reproducing the demonstration's duration; `γ = 5 / duration`
//! so that `s ≈ 0` at the end of the demonstration. `K` and `D` are scalar gains (1/s², 1/s).
//! The weights are the least-squares solution for the normalised, `s`-weighted basis (a tiny
//! ridge term keeps it well posed), which is what the per-basis weighted regression of App. A.3.1
//! converges to as the basis functions stop overlapping.

use nalgebra::{DMatrix, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::demo::Demonstration;
use crate::ds::Trajectory;
use crate::error::{MotionError, Result, check_dim, check_finite, invalid};

/// Settings of DMP learning.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DmpConfig {
    /// Number of basis functions.
    pub n_basis: usize,
    /// Stiffness `K` (1/s²).
    pub stiffness: f64,
    /// Damping `D` (1/s); `None` gives the critical `2√K`.
    pub damping: Option<f64>,
    /// `γ · duration` (5 in the thesis: `γ = 5 / duration`).
    pub gamma_times_duration: f64,
    /// Ridge regularisation of the weight regression.
    pub ridge: f64,
}

impl Default for DmpConfig {
    fn default() -> Self {
        Self {
            n_basis: 30,
            stiffness: 70.0,
            damping: None,
            gamma_times_duration: 5.0,
            ridge: 1e-8,
        }
    }
}

impl DmpConfig {
    /// Rejects NaN and out-of-range values.
    pub fn validate(&self) -> Result<()> {
        if self.n_basis == 0 {
            return Err(invalid("n_basis", "must be at least 1"));
        }
        for (name, v) in [
            ("stiffness", self.stiffness),
            ("gamma_times_duration", self.gamma_times_duration),
        ] {
            if !(v > 0.0) || !v.is_finite() {
                return Err(invalid(name, format!("must be finite and > 0, got {v}")));
            }
        }
        if let Some(d) = self.damping
            && (!(d >= 0.0) || !d.is_finite())
        {
            return Err(invalid(
                "damping",
                format!("must be finite and >= 0, got {d}"),
            ));
        }
        if !(self.ridge >= 0.0) || !self.ridge.is_finite() {
            return Err(invalid("ridge", "must be finite and >= 0"));
        }
        Ok(())
    }
}

/// Shared canonical system and basis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Basis {
    /// Centres `c_k` in phase space.
    pub centers: Vec<f64>,
    /// Widths `h_k`.
    pub widths: Vec<f64>,
    /// `γ` (1/s).
    pub gamma: f64,
}

impl Basis {
    /// Checks a basis read from a file or a message: equal, non-zero numbers of centres and
    /// widths, finite centres, positive finite widths and phase decay `γ`.
    pub fn validate(&self) -> Result<()> {
        if self.centers.is_empty() {
            return Err(invalid("basis.centers", "no basis function"));
        }
        check_dim("basis.widths (one per centre)", self.centers.len(), self.widths.len())?;
        check_finite("basis.centers", &self.centers)?;
        if let Some(i) = self.widths.iter().position(|w| !(w.is_finite() && *w > 0.0)) {
            return Err(invalid("basis.widths", format!("width {i} is {} (must be positive and finite)", self.widths[i])));
        }
        if !(self.gamma.is_finite() && self.gamma > 0.0) {
            return Err(invalid("basis.gamma", format!("{} (must be positive and finite)", self.gamma)));
        }
        Ok(())
    }

    fn new(n: usize, gamma: f64, duration: f64) -> Self {
        let centers: Vec<f64> = (0..n)
            .map(|k| {
                let t = if n == 1 {
                    0.0
                } else {
                    duration * k as f64 / (n - 1) as f64
                };
                (-gamma * t).exp()
            })
            .collect();
        let widths = (0..n)
            .map(|k| {
                let d = if n == 1 {
                    0.5
                } else if k + 1 < n {
                    centers[k + 1] - centers[k]
                } else {
                    centers[k] - centers[k - 1]
                };
                1.0 / (d * d).max(1e-12)
            })
            .collect();
        Self {
            centers,
            widths,
            gamma,
        }
    }

    /// Normalised, phase-weighted activations `φ_k(s) s / Σ φ_j(s)` into `out`.
    fn features(&self, s: f64, out: &mut [f64]) {
        let mut sum = 0.0;
        for (k, o) in out.iter_mut().enumerate() {
            let d = s - self.centers[k];
            *o = (-self.widths[k] * d * d).exp();
            sum += *o;
        }
        let scale = if sum > 1e-300 { s / sum } else { 0.0 };
        out.iter_mut().for_each(|o| *o *= scale);
    }
}

/// Solves the ridge-regularised least squares `min ‖Φ w − y‖² + λ‖w‖²` for each column of `y`.
fn fit_weights(phi: &DMatrix<f64>, y: &DMatrix<f64>, ridge: f64) -> Result<DMatrix<f64>> {
    let mut a = phi.transpose() * phi;
    let scale = (a.trace() / a.nrows() as f64).max(1e-12);
    for i in 0..a.nrows() {
        a[(i, i)] += ridge * scale;
    }
    let b = phi.transpose() * y;
    let chol = a.cholesky().ok_or_else(|| {
        invalid(
            "n_basis",
            "basis regression is singular (too many basis functions for the samples?)",
        )
    })?;
    Ok(chol.solve(&b))
}

/// A position DMP for an `n`-dimensional motion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Dmp {
    /// Dimension.
    pub dim: usize,
    /// Basis and canonical system.
    pub basis: Basis,
    /// Weights, row-major `n_basis × dim`.
    pub weights: Vec<f64>,
    /// `K` (1/s²).
    pub stiffness: f64,
    /// `D` (1/s).
    pub damping: f64,
    /// Demonstrated start `x₀`.
    pub start: Vec<f64>,
    /// Demonstrated goal `g`.
    pub goal: Vec<f64>,
    /// Demonstration duration (s).
    pub duration: f64,
}

/// Checks the gains and duration shared by position and orientation DMPs.
fn validate_gains(stiffness: f64, damping: f64, duration: f64) -> Result<()> {
    if !(stiffness.is_finite() && stiffness > 0.0) {
        return Err(invalid("stiffness", format!("{stiffness} (must be positive and finite)")));
    }
    if !(damping.is_finite() && damping >= 0.0) {
        return Err(invalid("damping", format!("{damping} (must be non-negative and finite)")));
    }
    if !(duration.is_finite() && duration > 0.0) {
        return Err(invalid("duration", format!("{duration} s (must be positive and finite)")));
    }
    Ok(())
}

impl Dmp {
    /// Checks a DMP read from a file or a message before it is run: every array has the length
    /// its dimension and basis imply (`weights`: `n_basis × dim`, `start` and `goal`: `dim`),
    /// every value is finite, gains and duration are in range. A DMP that passes can be run by
    /// [`forcing`](Self::forcing) and [`rollout`](Self::rollout) without indexing out of bounds.
    pub fn validate(&self) -> Result<()> {
        if self.dim == 0 || self.dim > crate::gmr::MAX_DIM {
            return Err(invalid("dim", format!("{} (must be in 1..={})", self.dim, crate::gmr::MAX_DIM)));
        }
        self.basis.validate()?;
        check_dim("weights (n_basis × dim)", self.basis.centers.len() * self.dim, self.weights.len())?;
        check_dim("start", self.dim, self.start.len())?;
        check_dim("goal", self.dim, self.goal.len())?;
        check_finite("weights", &self.weights)?;
        check_finite("start", &self.start)?;
        check_finite("goal", &self.goal)?;
        validate_gains(self.stiffness, self.damping, self.duration)
    }

    /// Learns from one demonstration (velocities from the demo, accelerations by differences).
    pub fn fit(demo: &Demonstration, cfg: &DmpConfig) -> Result<Self> {
        cfg.validate()?;
        let n = demo.dim;
        let len = demo.len();
        if len < 3 {
            return Err(MotionError::TooFewSamples {
                what: "DMP demonstration".into(),
                needed: 3,
                got: len,
            });
        }
        let duration = demo.duration();
        let gamma = cfg.gamma_times_duration / duration;
        let k = cfg.stiffness;
        let d = cfg.damping.unwrap_or(2.0 * k.sqrt());
        let basis = Basis::new(cfg.n_basis, gamma, duration);
        let acc = crate::demo::finite_differences(n, &demo.t, &demo.vel);
        let x0 = demo.position(0).to_vec();
        let g = demo.position(len - 1).to_vec();
        let mut phi = DMatrix::zeros(len, cfg.n_basis);
        let mut y = DMatrix::zeros(len, n);
        let mut row = vec![0.0; cfg.n_basis];
        for i in 0..len {
            let s = (-gamma * (demo.t[i] - demo.t[0])).exp();
            basis.features(s, &mut row);
            for (c, v) in row.iter().enumerate() {
                phi[(i, c)] = *v;
            }
            for j in 0..n {
                let x = demo.position(i)[j];
                let v = demo.velocity(i)[j];
                let a = acc[i * n + j];
                y[(i, j)] = (a + d * v) / k - (g[j] - x) + (g[j] - x0[j]) * s;
            }
        }
        let w = fit_weights(&phi, &y, cfg.ridge)?;
        let weights = (0..cfg.n_basis)
            .flat_map(|b| (0..n).map(move |j| (b, j)))
            .map(|(b, j)| w[(b, j)])
            .collect();
        Ok(Self {
            dim: n,
            basis,
            weights,
            stiffness: k,
            damping: d,
            start: x0,
            goal: g,
            duration,
        })
    }

    /// Forcing term `f(s)` into `out` (allocation-free).
    pub fn forcing(&self, s: f64, out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        let mut sum = 0.0;
        for k in 0..self.basis.centers.len() {
            let d = s - self.basis.centers[k];
            let p = (-self.basis.widths[k] * d * d).exp();
            sum += p;
            for (j, o) in out.iter_mut().enumerate() {
                *o += p * self.weights[k * self.dim + j];
            }
        }
        let scale = if sum > 1e-300 { s / sum } else { 0.0 };
        out.iter_mut().for_each(|o| *o *= scale);
    }

    /// Integrates the DMP (semi-implicit Euler, step `dt` s) from `start` to `goal` (the
    /// demonstrated ones when `None`) with temporal scaling `tau` (> 1 slower). Runs for
    /// `tau · duration`, then on until `‖x − g‖ ≤ tol` or `max_steps`.
    pub fn rollout(
        &self,
        start: Option<&[f64]>,
        goal: Option<&[f64]>,
        tau: f64,
        dt: f64,
        max_steps: usize,
        tol: f64,
    ) -> Result<Trajectory> {
        let x0 = start.unwrap_or(&self.start).to_vec();
        let g = goal.unwrap_or(&self.goal).to_vec();
        check_dim("DMP start", self.dim, x0.len())?;
        check_dim("DMP goal", self.dim, g.len())?;
        check_finite("DMP start", &x0)?;
        check_finite("DMP goal", &g)?;
        if !(tau > 0.0) || !(dt > 0.0) || !tau.is_finite() || !dt.is_finite() {
            return Err(invalid("tau/dt", "must be finite and > 0"));
        }
        let n = self.dim;
        let nominal = (tau * self.duration / dt).round() as usize;
        let mut x = x0.clone();
        let mut v = vec![0.0; n];
        let mut f = vec![0.0; n];
        let mut s = 1.0;
        let decay = (-self.basis.gamma * dt / tau).exp();
        let mut tr = Trajectory {
            dim: n,
            ..Default::default()
        };
        for i in 0..=max_steps {
            tr.t.push(i as f64 * dt);
            tr.pos.extend_from_slice(&x);
            tr.vel.extend(v.iter().map(|v| v / tau));
            let err: f64 = x
                .iter()
                .zip(&g)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
            if i >= nominal && err <= tol {
                tr.reached = true;
                break;
            }
            if i == max_steps {
                break;
            }
            self.forcing(s, &mut f);
            for j in 0..n {
                let a = self.stiffness * (g[j] - x[j])
                    - self.damping * v[j]
                    - self.stiffness * (g[j] - x0[j]) * s
                    + self.stiffness * f[j];
                v[j] += dt / tau * a;
                x[j] += dt / tau * v[j];
            }
            s *= decay;
        }
        Ok(tr)
    }
}

/// An orientation DMP on unit quaternions (Ude et al. form): with `e(q) = 2 log(g ∘ q̄)` (rotation
/// vector, rad) and `η = τ ω` (world-frame angular velocity, rad/s),
/// `τ η̇ = K e(q) − D η − K e(q₀) s + K f(s)`, `q ← exp(dt/τ · η/2) ∘ q`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrientationDmp {
    /// Basis and canonical system.
    pub basis: Basis,
    /// Weights, row-major `n_basis × 3`.
    pub weights: Vec<f64>,
    /// `K` (1/s²).
    pub stiffness: f64,
    /// `D` (1/s).
    pub damping: f64,
    /// Demonstrated start orientation.
    pub start: UnitQuaternion<f64>,
    /// Demonstrated goal orientation.
    pub goal: UnitQuaternion<f64>,
    /// Demonstration duration (s).
    pub duration: f64,
}

fn rot_err(g: &UnitQuaternion<f64>, q: &UnitQuaternion<f64>) -> Vector3<f64> {
    (g * q.inverse()).scaled_axis()
}

impl OrientationDmp {
    /// Checks an orientation DMP read from a file or a message (as [`Dmp::validate`]; the
    /// start and goal quaternions must be finite and of unit norm within 1e-6).
    pub fn validate(&self) -> Result<()> {
        self.basis.validate()?;
        check_dim("weights (n_basis × 3)", self.basis.centers.len() * 3, self.weights.len())?;
        check_finite("weights", &self.weights)?;
        for (name, q) in [("start", &self.start), ("goal", &self.goal)] {
            let c = q.as_ref().coords;
            if !(c.iter().all(|v| v.is_finite()) && (c.norm() - 1.0).abs() <= 1e-6) {
                return Err(invalid(name, format!("quaternion {:?} is not a finite unit quaternion", c.as_slice())));
            }
        }
        validate_gains(self.stiffness, self.damping, self.duration)
    }

    /// Learns from sampled orientations at strictly increasing times `t` (s).
    pub fn fit(t: &[f64], q: &[UnitQuaternion<f64>], cfg: &DmpConfig) -> Result<Self> {
        cfg.validate()?;
        let len = t.len();
        check_dim("orientation samples vs times", len, q.len())?;
        if len < 3 {
            return Err(MotionError::TooFewSamples {
                what: "orientation DMP demonstration".into(),
                needed: 3,
                got: len,
            });
        }
        check_finite("orientation DMP times", t)?;
        let duration = t[len - 1] - t[0];
        if !(duration > 0.0) {
            return Err(invalid("t", "times must increase"));
        }
        let gamma = cfg.gamma_times_duration / duration;
        let k = cfg.stiffness;
        let d = cfg.damping.unwrap_or(2.0 * k.sqrt());
        let basis = Basis::new(cfg.n_basis, gamma, duration);
        // ω by forward differences (zero at the end), η̇ by central differences.
        let mut omega = vec![0.0; len * 3];
        for i in 0..len - 1 {
            let w = (q[i + 1] * q[i].inverse()).scaled_axis() / (t[i + 1] - t[i]);
            omega[i * 3..i * 3 + 3].copy_from_slice(w.as_slice());
        }
        let domega = crate::demo::finite_differences(3, t, &omega);
        let (q0, g) = (q[0], q[len - 1]);
        let e0 = rot_err(&g, &q0);
        let mut phi = DMatrix::zeros(len, cfg.n_basis);
        let mut y = DMatrix::zeros(len, 3);
        let mut row = vec![0.0; cfg.n_basis];
        for i in 0..len {
            let s = (-gamma * (t[i] - t[0])).exp();
            basis.features(s, &mut row);
            for (c, v) in row.iter().enumerate() {
                phi[(i, c)] = *v;
            }
            let e = rot_err(&g, &q[i]);
            for j in 0..3 {
                y[(i, j)] = (domega[i * 3 + j] + d * omega[i * 3 + j]) / k - e[j] + e0[j] * s;
            }
        }
        let w = fit_weights(&phi, &y, cfg.ridge)?;
        let weights = (0..cfg.n_basis)
            .flat_map(|b| (0..3).map(move |j| (b, j)))
            .map(|(b, j)| w[(b, j)])
            .collect();
        Ok(Self {
            basis,
            weights,
            stiffness: k,
            damping: d,
            start: q0,
            goal: g,
            duration,
        })
    }

    /// Integrates for `tau · duration` seconds with step `dt`; returns the orientations.
    pub fn rollout(
        &self,
        start: Option<UnitQuaternion<f64>>,
        goal: Option<UnitQuaternion<f64>>,
        tau: f64,
        dt: f64,
    ) -> Result<Vec<UnitQuaternion<f64>>> {
        if !(tau > 0.0) || !(dt > 0.0) || !tau.is_finite() || !dt.is_finite() {
            return Err(invalid("tau/dt", "must be finite and > 0"));
        }
        let q0 = start.unwrap_or(self.start);
        let g = goal.unwrap_or(self.goal);
        let e0 = rot_err(&g, &q0);
        let steps = (tau * self.duration / dt).round() as usize;
        let mut q = q0;
        let mut eta = Vector3::zeros();
        let mut s = 1.0;
        let decay = (-self.basis.gamma * dt / tau).exp();
        let mut out = Vec::with_capacity(steps + 1);
        let nb = self.basis.centers.len();
        for _ in 0..=steps {
            out.push(q);
            let mut f = Vector3::zeros();
            let mut sum = 0.0;
            for k in 0..nb {
                let dd = s - self.basis.centers[k];
                let p = (-self.basis.widths[k] * dd * dd).exp();
                sum += p;
                for j in 0..3 {
                    f[j] += p * self.weights[k * 3 + j];
                }
            }
            if sum > 1e-300 {
                f *= s / sum;
            }
            let e = rot_err(&g, &q);
            let deta = self.stiffness * e - self.damping * eta - self.stiffness * e0 * s
                + self.stiffness * f;
            eta += dt / tau * deta;
            q = UnitQuaternion::from_scaled_axis(eta * (dt / tau)) * q;
            s *= decay;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn demo() -> Demonstration {
        let t: Vec<f64> = (0..=200).map(|i| i as f64 * 0.01).collect();
        // Starts and ends at rest, as kinesthetic demonstrations do.
        let pos = t
            .iter()
            .flat_map(|t| {
                let s = t / 2.0;
                let mj = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
                [
                    mj + 0.3 * (std::f64::consts::PI * mj).sin().powi(2),
                    (2.0 * std::f64::consts::PI * mj).sin() * 0.5,
                ]
            })
            .collect();
        Demonstration::new(2, t, pos, None).expect("demo")
    }

    #[test]
    fn reproduces_the_demonstration() {
        let d = demo();
        let dmp = Dmp::fit(
            &d,
            &DmpConfig {
                n_basis: 50,
                ..Default::default()
            },
        )
        .expect("fit");
        let tr = dmp
            .rollout(None, None, 1.0, 0.01, 1000, 1e-3)
            .expect("rollout");
        let mut se = 0.0;
        for i in 0..d.len() {
            for j in 0..2 {
                se += (tr.position(i)[j] - d.position(i)[j]).powi(2);
            }
        }
        let rmse = (se / d.len() as f64).sqrt();
        assert!(rmse < 0.01, "rmse {rmse}");
        let last = tr.position(tr.len() - 1);
        assert!((last[0] - d.position(d.len() - 1)[0]).abs() < 1e-3);
    }

    #[test]
    fn new_goal_and_temporal_scaling() {
        let d = demo();
        let dmp = Dmp::fit(&d, &DmpConfig::default()).expect("fit");
        let goal = [5.0, -1.0];
        let tr = dmp
            .rollout(Some(&[0.5, 0.5]), Some(&goal), 2.0, 0.01, 5000, 1e-3)
            .expect("rollout");
        assert!(tr.reached);
        assert!(tr.t[tr.len() - 1] >= 2.0 * d.duration() - 1e-9);
    }

    #[test]
    fn orientation_dmp_reaches_goal_and_tracks_demo() {
        let t: Vec<f64> = (0..=100).map(|i| i as f64 * 0.02).collect();
        let q: Vec<_> = t
            .iter()
            .map(|t| UnitQuaternion::from_euler_angles(0.5 * t, (2.0 * t).sin() * 0.3, -0.2 * t))
            .collect();
        let dmp = OrientationDmp::fit(
            &t,
            &q,
            &DmpConfig {
                n_basis: 40,
                ..Default::default()
            },
        )
        .expect("fit");
        let out = dmp.rollout(None, None, 1.0, 0.02).expect("rollout");
        let max_err = out
            .iter()
            .zip(&q)
            .map(|(a, b)| a.angle_to(b))
            .fold(0.0, f64::max);
        assert!(max_err < 0.05, "max angle error {max_err}");
    }
}
