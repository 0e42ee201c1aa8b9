//! Demonstrations: sampled positions with times and velocities.

use serde::{Deserialize, Serialize};

use crate::error::{MotionError, Result, check_dim, check_finite, invalid};

/// One demonstration of an `dim`-dimensional motion (positions in m or the data's unit, times
/// in s). Positions and velocities are row-major `len × dim`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Demonstration {
    /// State dimension.
    pub dim: usize,
    /// Strictly increasing sample times (s).
    pub t: Vec<f64>,
    /// Positions, row-major.
    pub pos: Vec<f64>,
    /// Velocities, row-major (unit/s).
    pub vel: Vec<f64>,
}

impl Demonstration {
    /// Builds a demonstration; velocities are estimated by finite differences (central inside,
    /// one-sided at the ends) when `vel` is `None`. Needs at least 2 samples, finite values and
    /// strictly increasing times.
    pub fn new(dim: usize, t: Vec<f64>, pos: Vec<f64>, vel: Option<Vec<f64>>) -> Result<Self> {
        if dim == 0 {
            return Err(invalid("dim", "must be at least 1"));
        }
        let n = t.len();
        if n < 2 {
            return Err(MotionError::TooFewSamples {
                what: "demonstration".into(),
                needed: 2,
                got: n,
            });
        }
        check_dim("demonstration positions", n * dim, pos.len())?;
        check_finite("demonstration times", &t)?;
        check_finite("demonstration positions", &pos)?;
        if let Some(i) = t.windows(2).position(|w| w[1] <= w[0]) {
            return Err(invalid(
                "t",
                format!("times must increase strictly (sample {})", i + 1),
            ));
        }
        let vel = match vel {
            Some(v) => {
                check_dim("demonstration velocities", n * dim, v.len())?;
                check_finite("demonstration velocities", &v)?;
                v
            }
            None => finite_differences(dim, &t, &pos),
        };
        Ok(Self { dim, t, pos, vel })
    }

    /// A synthetic point-to-point demonstration (how a person moves an object from one place
    /// to another): a minimum-jerk profile from `start` to `end` over `duration_s` plus
    /// `bow`·sin(π s) (an arc, zero at both ends; s the normalised time), then `rest_s` at rest at
    /// `end` (the person holds the object there), sampled every `dt` s from t = 0. `start`,
    /// `end` and `bow` have the same length (the dimension; m or the data's unit).
    pub fn minimum_jerk(start: &[f64], end: &[f64], bow: &[f64], duration_s: f64, rest_s: f64, dt: f64) -> Result<Self> {
        let dim = start.len();
        check_dim("minimum-jerk end", dim, end.len())?;
        check_dim("minimum-jerk bow", dim, bow.len())?;
        if !(dt.is_finite() && dt > 0.0 && duration_s.is_finite() && duration_s >= 2.0 * dt) {
            return Err(invalid("minimum-jerk timing", format!("duration {duration_s} s with period {dt} s")));
        }
        if !(rest_s.is_finite() && rest_s >= 0.0) {
            return Err(invalid("minimum-jerk rest", format!("{rest_s} s")));
        }
        let n = (duration_s / dt).round() as usize + 1;
        let total = n + (rest_s / dt).round() as usize;
        let mut t = Vec::with_capacity(total);
        let mut pos = Vec::with_capacity(total * dim);
        for k in 0..total {
            let s = (k as f64 / (n - 1) as f64).min(1.0);
            let m = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
            let arc = (std::f64::consts::PI * s).sin();
            t.push(k as f64 * dt);
            pos.extend((0..dim).map(|j| start[j] + (end[j] - start[j]) * m + bow[j] * arc));
        }
        Self::new(dim, t, pos, None)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }
    /// Always false: a demonstration has at least two samples.
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
    /// Duration (s).
    pub fn duration(&self) -> f64 {
        self.t[self.t.len() - 1] - self.t[0]
    }
    /// Keeps every `step`-th sample (and always the last one).
    pub fn subsampled(&self, step: usize) -> Self {
        if step <= 1 {
            return self.clone();
        }
        let mut idx: Vec<usize> = (0..self.len()).step_by(step).collect();
        if idx.last() != Some(&(self.len() - 1)) {
            idx.push(self.len() - 1);
        }
        let pick = |v: &[f64]| {
            idx.iter()
                .flat_map(|&i| v[i * self.dim..(i + 1) * self.dim].iter().copied())
                .collect()
        };
        Self {
            dim: self.dim,
            t: idx.iter().map(|&i| self.t[i]).collect(),
            pos: pick(&self.pos),
            vel: pick(&self.vel),
        }
    }
}

/// Central differences inside, one-sided differences at both ends (like `numpy.gradient`).
pub fn finite_differences(dim: usize, t: &[f64], pos: &[f64]) -> Vec<f64> {
    let n = t.len();
    let mut vel = vec![0.0; n * dim];
    for i in 0..n {
        let (a, b) = if i == 0 {
            (0, 1)
        } else if i == n - 1 {
            (n - 2, n - 1)
        } else {
            (i - 1, i + 1)
        };
        let dt = t[b] - t[a];
        for j in 0..dim {
            vel[i * dim + j] = (pos[b * dim + j] - pos[a * dim + j]) / dt;
        }
    }
    vel
}

/// Checks that all demonstrations share one dimension and returns it.
pub fn common_dim(demos: &[Demonstration]) -> Result<usize> {
    let first = demos.first().ok_or(MotionError::TooFewSamples {
        what: "demonstrations".into(),
        needed: 1,
        got: 0,
    })?;
    for (i, d) in demos.iter().enumerate() {
        check_dim(&format!("demonstration {i} dimension"), first.dim, d.dim)?;
    }
    Ok(first.dim)
}

/// Mean of the final positions: the target `x*` of a point-to-point motion.
pub fn mean_end_point(demos: &[Demonstration]) -> Result<Vec<f64>> {
    let n = common_dim(demos)?;
    let mut g = vec![0.0; n];
    for d in demos {
        for (gj, pj) in g.iter_mut().zip(d.position(d.len() - 1)) {
            *gj += pj / demos.len() as f64;
        }
    }
    Ok(g)
}

#[cfg(test)]
mod minimum_jerk_tests {
    use super::*;

    #[test]
    fn goes_from_start_to_end_with_the_bow_then_rests() {
        let d = Demonstration::minimum_jerk(&[0.0, 0.0], &[1.0, 0.0], &[0.0, 0.1], 2.0, 0.5, 0.01).expect("demo");
        assert_eq!(d.len(), 251);
        assert_eq!(d.position(0), &[0.0, 0.0]);
        assert!((d.position(100)[0] - 0.5).abs() < 1e-12 && (d.position(100)[1] - 0.1).abs() < 1e-12);
        assert!((d.position(200)[0] - 1.0).abs() < 1e-12 && d.position(200)[1].abs() < 1e-12);
        assert_eq!(d.position(250), d.position(200));
        assert!(Demonstration::minimum_jerk(&[0.0], &[1.0, 0.0], &[0.0], 2.0, 0.0, 0.01).is_err());
        assert!(Demonstration::minimum_jerk(&[0.0], &[1.0], &[0.0], f64::NAN, 0.0, 0.01).is_err());
    }
}
