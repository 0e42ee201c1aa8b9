//! A sampled end-effector path run as a [`LearnedField`]: the desired velocity is the path's
//! reference velocity plus position feedback towards the path, ẋ = v_ref(τ) + k_p (p_ref(τ) − x),
//! with the path's clock τ advanced by the controller's α_h-scaled time (a person close slows
//! the path down instead of leaving the tool behind it).
//!
//! This is how a trajectory-generating primitive — an HMM (thesis Algorithm 3, App. A.3.3,
//! Sec. 4.1.3) — runs in the DS controller: the path is generated once, on the ROS side, and
//! the 1 kHz step only interpolates it (no allocation). The path is relative to its start: at
//! [`reset`](LearnedField::reset) it is translated so that it begins at the tool's position
//! x₀, as `HmmPrimitive::generate(Some(x0), ..)` does.
//!
//! Frames and units: robot base frame, m, m/s, s.

use nalgebra::Vector3;

use crate::error::{Error, Result};
use crate::primitive::LearnedField;

/// Position feedback gain k_p of the tracking (1/s): a deviation decays with a 0.2 s time
/// constant, quick against the 3–6 s of a pick-and-place, slow against the 1 ms step.
pub const DEFAULT_GAIN: f64 = 5.0;

/// A sampled path tracked with position feedback (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct PathTracker {
    pos: Vec<Vector3<f64>>,
    vel: Vec<Vector3<f64>>,
    sample_s: f64,
    gain: f64,
    tau: f64,
    offset: Vector3<f64>,
}

impl PathTracker {
    /// A path of positions `pos` (m) and reference velocities `vel` (m/s), one every
    /// `sample_s` s from τ = 0, tracked with feedback gain `gain` (1/s). Fails unless there are
    /// at least two samples, as many velocities as positions, every value finite, and
    /// `sample_s` and `gain` finite and > 0.
    pub fn new(pos: Vec<Vector3<f64>>, vel: Vec<Vector3<f64>>, sample_s: f64, gain: f64) -> Result<Self> {
        let bad = |reason: String| Err(Error::Path { reason });
        if pos.len() < 2 {
            return bad(format!("{} position sample(s); a path needs at least 2", pos.len()));
        }
        if vel.len() != pos.len() {
            return bad(format!("{} velocities for {} positions", vel.len(), pos.len()));
        }
        if let Some(i) = pos.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
            return bad(format!("position sample {i} is not finite"));
        }
        if let Some(i) = vel.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
            return bad(format!("velocity sample {i} is not finite"));
        }
        if !(sample_s.is_finite() && sample_s > 0.0) {
            return bad(format!("sample period {sample_s} s must be finite and > 0"));
        }
        if !(gain.is_finite() && gain > 0.0) {
            return bad(format!("feedback gain {gain} 1/s must be finite and > 0"));
        }
        Ok(Self { pos, vel, sample_s, gain, tau: 0.0, offset: Vector3::zeros() })
    }

    /// [`new`](Self::new) from row-major 3-D `[x, y, z, x, y, z, …]` positions and velocities
    /// (the layout of `cowork_motion::Trajectory`).
    pub fn from_flat(pos: &[f64], vel: &[f64], sample_s: f64, gain: f64) -> Result<Self> {
        if !pos.len().is_multiple_of(3) || !vel.len().is_multiple_of(3) {
            return Err(Error::Path {
                reason: format!("{} position and {} velocity values are not 3-D samples", pos.len(), vel.len()),
            });
        }
        let v3 = |s: &[f64]| s.chunks_exact(3).map(Vector3::from_column_slice).collect();
        Self::new(v3(pos), v3(vel), sample_s, gain)
    }

    /// Reference position (m, untranslated) and velocity (m/s) at path time `tau` (s), linearly
    /// interpolated; before 0 the start, after the end the end point at rest.
    pub fn at(&self, tau: f64) -> (Vector3<f64>, Vector3<f64>) {
        let last = self.pos.len() - 1;
        let s = (tau / self.sample_s).max(0.0);
        let i = (s.floor() as usize).min(last);
        let j = (i + 1).min(last);
        let a = (s - i as f64).clamp(0.0, 1.0);
        let v = if tau >= self.duration_s() { Vector3::zeros() } else { self.vel[i] * (1.0 - a) + self.vel[j] * a };
        (self.pos[i] * (1.0 - a) + self.pos[j] * a, v)
    }

    /// Duration of the path (s): from the first to the last sample.
    pub fn duration_s(&self) -> f64 {
        (self.pos.len() - 1) as f64 * self.sample_s
    }

    /// The path's positions (m, untranslated).
    pub fn positions(&self) -> &[Vector3<f64>] {
        &self.pos
    }

    /// Sample period (s).
    pub fn sample_s(&self) -> f64 {
        self.sample_s
    }

    /// Path time τ reached so far (s of α_h-scaled time since the last reset).
    pub fn tau(&self) -> f64 {
        self.tau
    }

    /// Where the path ends when it starts at `x0` (m, base frame).
    pub fn end_from(&self, x0: &Vector3<f64>) -> Vector3<f64> {
        self.pos[self.pos.len() - 1] + (x0 - self.pos[0])
    }
}

impl PathTracker {
    /// Desired velocity at `x` (m) at path time `tau` (s) without advancing the own clock:
    /// ẋ = v_ref(τ) + k_p (p_ref(τ) + offset − x). A path run on another path's clock (a
    /// null-space primitive on the end-effector path's τ) uses this.
    pub fn velocity_at(&self, tau: f64, x: &Vector3<f64>) -> Vector3<f64> {
        self.velocity_with_offset(tau, x, &self.offset)
    }

    /// [`velocity_at`](Self::velocity_at) with the path translated by `offset` (m) instead of
    /// the one [`reset`](LearnedField::reset) set.
    pub fn velocity_with_offset(&self, tau: f64, x: &Vector3<f64>, offset: &Vector3<f64>) -> Vector3<f64> {
        let (p, v) = self.at(tau);
        v + (p + offset - x) * self.gain
    }
}

impl LearnedField for PathTracker {
    fn reset(&mut self, x0: &Vector3<f64>, _goal: &Vector3<f64>) {
        self.tau = 0.0;
        self.offset = x0 - self.pos[0];
    }

    fn velocity(&mut self, x: &Vector3<f64>, _goal: &Vector3<f64>, dt: f64) -> Vector3<f64> {
        self.tau += dt;
        self.velocity_at(self.tau, x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line() -> PathTracker {
        let pos: Vec<_> = (0..=100).map(|k| Vector3::new(k as f64 * 0.001, 0.0, 0.0)).collect();
        let vel = vec![Vector3::new(0.1, 0.0, 0.0); 101];
        PathTracker::new(pos, vel, 0.01, DEFAULT_GAIN).expect("path")
    }

    #[test]
    fn follows_the_path_translated_to_the_start_and_stops_at_its_end() {
        let mut t = line();
        let x0 = Vector3::new(0.5, 0.2, 0.3);
        t.reset(&x0, &Vector3::zeros());
        let mut x = x0;
        for _ in 0..2000 {
            let v = t.velocity(&x, &Vector3::zeros(), 1e-3);
            x += v * 1e-3;
        }
        assert!((x - t.end_from(&x0)).norm() < 1e-4, "{x:?}");
        assert!((t.end_from(&x0) - (x0 + Vector3::new(0.1, 0.0, 0.0))).norm() < 1e-12);
        // Off the path: pulled back at k_p.
        let v = t.velocity(&(x + Vector3::new(0.0, 0.01, 0.0)), &Vector3::zeros(), 1e-3);
        assert!((v.y + 0.01 * DEFAULT_GAIN).abs() < 1e-9, "{v:?}");
    }

    #[test]
    fn the_clock_runs_on_the_scaled_time() {
        let mut t = line();
        t.reset(&Vector3::zeros(), &Vector3::zeros());
        let _ = t.velocity(&Vector3::zeros(), &Vector3::zeros(), 0.0);
        assert_eq!(t.tau(), 0.0);
        let _ = t.velocity(&Vector3::zeros(), &Vector3::zeros(), 0.5);
        assert!((t.tau() - 0.5).abs() < 1e-12);
    }

    #[test]
    fn bad_paths_are_refused_naming_what() {
        let ok = vec![Vector3::zeros(); 3];
        let cases = [
            (PathTracker::new(vec![Vector3::zeros()], vec![Vector3::zeros()], 0.01, 5.0), "at least 2"),
            (PathTracker::new(ok.clone(), vec![Vector3::zeros(); 2], 0.01, 5.0), "2 velocities for 3"),
            (PathTracker::new(vec![Vector3::zeros(), Vector3::new(f64::NAN, 0.0, 0.0)], vec![Vector3::zeros(); 2], 0.01, 5.0), "position sample 1"),
            (PathTracker::new(ok.clone(), vec![Vector3::zeros(), Vector3::zeros(), Vector3::repeat(f64::INFINITY)], 0.01, 5.0), "velocity sample 2"),
            (PathTracker::new(ok.clone(), ok.clone(), 0.0, 5.0), "sample period"),
            (PathTracker::new(ok.clone(), ok.clone(), 0.01, f64::NAN), "feedback gain"),
            (PathTracker::from_flat(&[0.0; 7], &[0.0; 6], 0.01, 5.0), "not 3-D"),
        ];
        for (r, want) in cases {
            let e = r.expect_err(want).to_string();
            assert!(e.contains(want), "{e:?} should name {want:?}");
        }
    }
}
