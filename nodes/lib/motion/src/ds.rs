//! First-order dynamical systems `ẋ = f(x)` and their integration.
//!
//! [`FirstOrderDs`] is the autonomous field (GMR-DS, linear DS); [`DsPolicy`] is the stateful
//! form a controller steps at its own rate (C-GMR keeps its activation `ω` and clock there).
//! Both take the state in the frame and unit of the demonstrations (Cartesian position in m
//! for the robot) and write the velocity in the same unit per second.

use serde::{Deserialize, Serialize};

use crate::error::{Result, check_dim, check_finite, invalid};

/// An autonomous first-order dynamical system.
pub trait FirstOrderDs {
    /// State dimension.
    fn dim(&self) -> usize;
    /// Writes `f(x)` to `out` (both of length [`FirstOrderDs::dim`]). Implementations used in the
    /// control loop do not allocate.
    fn velocity(&self, x: &[f64], out: &mut [f64]) -> Result<()>;
}

/// A first-order system with internal state (time, activation), stepped at the caller's rate.
pub trait DsPolicy {
    /// State dimension.
    fn dim(&self) -> usize;
    /// Restarts the internal state for a motion that begins at `x0`.
    fn reset(&mut self, x0: &[f64]) -> Result<()>;
    /// Advances the internal state by `dt` seconds at state `x` and writes the commanded velocity.
    fn step(&mut self, x: &[f64], dt: f64, out: &mut [f64]) -> Result<()>;
    /// The equilibrium the system converges to.
    fn goal(&self) -> &[f64];
}

/// Adapter making an autonomous field with an explicit goal a [`DsPolicy`].
#[derive(Debug, Clone)]
pub struct Autonomous<'a, T: FirstOrderDs> {
    /// The field.
    pub ds: &'a T,
    /// Its equilibrium.
    pub goal: Vec<f64>,
}

impl<T: FirstOrderDs> DsPolicy for Autonomous<'_, T> {
    fn dim(&self) -> usize {
        self.ds.dim()
    }
    fn reset(&mut self, _x0: &[f64]) -> Result<()> {
        Ok(())
    }
    fn step(&mut self, x: &[f64], _dt: f64, out: &mut [f64]) -> Result<()> {
        self.ds.velocity(x, out)
    }
    fn goal(&self) -> &[f64] {
        &self.goal
    }
}

/// A linear DS `ẋ = A (x − g)` (used for FOA primitives and as a test system).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearDs {
    /// Row-major `n × n` system matrix (1/s).
    pub a: Vec<f64>,
    /// Goal `g`.
    pub goal: Vec<f64>,
}

impl FirstOrderDs for LinearDs {
    fn dim(&self) -> usize {
        self.goal.len()
    }
    fn velocity(&self, x: &[f64], out: &mut [f64]) -> Result<()> {
        let n = self.goal.len();
        check_dim("linear DS state", n, x.len())?;
        check_dim("linear DS output", n, out.len())?;
        for r in 0..n {
            out[r] = (0..n)
                .map(|c| self.a[r * n + c] * (x[c] - self.goal[c]))
                .sum();
        }
        Ok(())
    }
}

/// A sampled trajectory: times (s), positions and velocities (row-major `len × dim`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Trajectory {
    /// State dimension.
    pub dim: usize,
    /// Sample times (s).
    pub t: Vec<f64>,
    /// Positions, row-major.
    pub pos: Vec<f64>,
    /// Velocities, row-major.
    pub vel: Vec<f64>,
    /// Whether the last position is within the tolerance of the goal.
    pub reached: bool,
}

impl Trajectory {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }
    /// True when there is no sample.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
    /// Position of sample `i`.
    pub fn position(&self, i: usize) -> &[f64] {
        &self.pos[i * self.dim..(i + 1) * self.dim]
    }
    /// Velocity of sample `i`.
    pub fn velocity(&self, i: usize) -> &[f64] {
        &self.vel[i * self.dim..(i + 1) * self.dim]
    }
}

/// Settings of [`rollout`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RolloutConfig {
    /// Integration step (s).
    pub dt: f64,
    /// Maximum number of steps.
    pub max_steps: usize,
    /// Stop when `‖x − goal‖ ≤ tol` (state unit).
    pub tol: f64,
}

impl RolloutConfig {
    /// Rejects non-positive or non-finite settings.
    pub fn validate(&self) -> Result<()> {
        if !(self.dt > 0.0) || !self.dt.is_finite() {
            return Err(invalid(
                "dt",
                format!("must be finite and > 0, got {}", self.dt),
            ));
        }
        if !(self.tol >= 0.0) || !self.tol.is_finite() {
            return Err(invalid(
                "tol",
                format!("must be finite and >= 0, got {}", self.tol),
            ));
        }
        if self.max_steps == 0 {
            return Err(invalid("max_steps", "must be at least 1"));
        }
        Ok(())
    }
}

/// Integrates `policy` from `start` by explicit Euler (`x ← x + dt·ẋ`) until the goal is within
/// `tol` or `max_steps` are done. Every sample, including the start, is recorded.
pub fn rollout<P: DsPolicy + ?Sized>(
    policy: &mut P,
    start: &[f64],
    cfg: &RolloutConfig,
) -> Result<Trajectory> {
    cfg.validate()?;
    let n = policy.dim();
    check_dim("rollout start", n, start.len())?;
    check_finite("rollout start", start)?;
    policy.reset(start)?;
    let goal = policy.goal().to_vec();
    let mut x = start.to_vec();
    let mut v = vec![0.0; n];
    let mut tr = Trajectory {
        dim: n,
        ..Default::default()
    };
    let dist = |x: &[f64]| {
        x.iter()
            .zip(&goal)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt()
    };
    for i in 0..=cfg.max_steps {
        policy.step(&x, cfg.dt, &mut v)?;
        tr.t.push(i as f64 * cfg.dt);
        tr.pos.extend_from_slice(&x);
        tr.vel.extend_from_slice(&v);
        if dist(&x) <= cfg.tol {
            tr.reached = true;
            break;
        }
        if i == cfg.max_steps {
            break;
        }
        for j in 0..n {
            x[j] += cfg.dt * v[j];
        }
        if x.iter().any(|v| !v.is_finite()) {
            return Err(invalid(
                "rollout",
                format!("state diverged to a non-finite value at step {i}"),
            ));
        }
    }
    Ok(tr)
}
