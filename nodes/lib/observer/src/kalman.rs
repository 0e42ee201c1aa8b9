//! Constant-velocity Kalman filter of a point in 3-D (a hand), thesis Sec. 5.1.3.
//!
//! State `x = [p; v]` (position m, velocity m/s, base frame). Between measurements the point
//! moves at constant velocity disturbed by white acceleration noise of spectral density `q`
//! (m²/s³), the discretised continuous white-noise model, per axis:
//!
//! ```text
//! F = [1 dt; 0 1],   Q = q [dt³/3 dt²/2; dt²/2 dt]
//! ```
//!
//! The measurement is the position with independent Gaussian noise of standard deviation `r`
//! (m) per axis: `H = [I 0]`, `R = r² I`. The update uses the Joseph form
//! `P = (I − K H) P (I − K H)ᵀ + K R Kᵀ`, which keeps `P` symmetric positive definite; it is the
//! same filter as `filterpy.kalman.KalmanFilter` with `Q = Q_continuous_white_noise(2, dt, q)`
//! per axis (cross-checked to 1e-9 by `tests/crosscheck/check_observer.sh`).

use nalgebra::{Matrix3, Matrix3x6, Matrix6, Point3, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::error::{ObserverError, Result, check};

/// Noise of the filter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct KalmanConfig {
    /// Spectral density of the white acceleration noise, m²/s³ (how hard a hand may change
    /// its velocity; larger follows faster, smooths less).
    pub process_noise: f64,
    /// Standard deviation of the position measurement per axis, m.
    pub measurement_noise_m: f64,
    /// Standard deviation of the velocity at the first measurement (taken as 0), m/s.
    pub initial_velocity_std: f64,
}

impl Default for KalmanConfig {
    fn default() -> Self {
        Self { process_noise: 1.0, measurement_noise_m: 0.015, initial_velocity_std: 1.0 }
    }
}

impl KalmanConfig {
    /// Rejects NaN and out-of-range values; `place` prefixes the parameter names.
    pub fn validate(&self, place: &str) -> Result<()> {
        check(&format!("{place}process_noise"), self.process_noise, 1e-9, 1e6, "must be in (0, 1e6] m²/s³")?;
        check(&format!("{place}measurement_noise_m"), self.measurement_noise_m, 1e-6, 1.0, "must be in [1e-6, 1] m")?;
        check(&format!("{place}initial_velocity_std"), self.initial_velocity_std, 1e-6, 100.0, "must be in [1e-6, 100] m/s")
    }
}

/// Filtered position and velocity at some time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Time of the estimate, s.
    pub stamp: f64,
    /// Position, m.
    pub position: Point3<f64>,
    /// Velocity, m/s.
    pub velocity: Vector3<f64>,
    /// Covariance of `[p; v]`.
    pub covariance: Matrix6<f64>,
}

/// A constant-velocity Kalman filter (see the module docs). No allocation.
#[derive(Clone, Debug)]
pub struct ConstantVelocityKf {
    config: KalmanConfig,
    x: Vector6<f64>,
    p: Matrix6<f64>,
    stamp: f64,
    initialised: bool,
}

fn transition(dt: f64) -> Matrix6<f64> {
    let mut f = Matrix6::identity();
    f.fixed_view_mut::<3, 3>(0, 3).copy_from(&(Matrix3::identity() * dt));
    f
}

fn process(q: f64, dt: f64) -> Matrix6<f64> {
    let mut m = Matrix6::zeros();
    let i = Matrix3::identity();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&(i * (q * dt.powi(3) / 3.0)));
    m.fixed_view_mut::<3, 3>(0, 3).copy_from(&(i * (q * dt * dt / 2.0)));
    m.fixed_view_mut::<3, 3>(3, 0).copy_from(&(i * (q * dt * dt / 2.0)));
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&(i * (q * dt)));
    m
}

impl ConstantVelocityKf {
    /// A filter with no measurement yet.
    pub fn new(config: KalmanConfig) -> Result<Self> {
        config.validate("kalman.")?;
        Ok(Self { config, x: Vector6::zeros(), p: Matrix6::identity(), stamp: f64::NEG_INFINITY, initialised: false })
    }

    /// The noise parameters.
    pub fn config(&self) -> &KalmanConfig {
        &self.config
    }

    /// Sets the measurement noise (m), e.g. per source (Xsens vs depth tracker).
    pub fn set_measurement_noise(&mut self, r: f64) -> Result<()> {
        check("kalman.measurement_noise_m", r, 1e-6, 1.0, "must be in [1e-6, 1] m")?;
        self.config.measurement_noise_m = r;
        Ok(())
    }

    /// Whether a measurement has been taken.
    pub fn is_initialised(&self) -> bool {
        self.initialised
    }

    /// Time of the last update, s (−∞ before the first).
    pub fn stamp(&self) -> f64 {
        self.stamp
    }

    /// Takes the position measurement `z` (m) made at `stamp` (s): predicts to `stamp`, then
    /// corrects. The first measurement initialises the state (velocity 0). A stamp before the
    /// last one, or a non-finite `z`, is rejected and the state is unchanged.
    pub fn update(&mut self, stamp: f64, z: &Point3<f64>) -> Result<Estimate> {
        if !stamp.is_finite() || !z.coords.iter().all(|v| v.is_finite()) {
            return Err(ObserverError::InvalidParameter { name: "kalman measurement".into(), value: f64::NAN, expected: "finite stamp and position" });
        }
        let r2 = self.config.measurement_noise_m.powi(2);
        if !self.initialised {
            self.x = Vector6::new(z.x, z.y, z.z, 0.0, 0.0, 0.0);
            let v2 = self.config.initial_velocity_std.powi(2);
            self.p = Matrix6::from_diagonal(&Vector6::new(r2, r2, r2, v2, v2, v2));
            self.stamp = stamp;
            self.initialised = true;
            return Ok(self.estimate());
        }
        let dt = stamp - self.stamp;
        if dt < 0.0 {
            return Err(ObserverError::InvalidParameter { name: "kalman measurement stamp".into(), value: dt, expected: "not before the previous measurement" });
        }
        if dt > 0.0 {
            let f = transition(dt);
            self.x = f * self.x;
            self.p = f * self.p * f.transpose() + process(self.config.process_noise, dt);
        }
        let mut h = Matrix3x6::zeros();
        h.fixed_view_mut::<3, 3>(0, 0).copy_from(&Matrix3::identity());
        let y = z.coords - h * self.x;
        let pht = self.p * h.transpose();
        let s = h * pht + Matrix3::identity() * r2;
        let Some(s_inv) = s.try_inverse() else {
            return Err(ObserverError::InvalidParameter { name: "kalman innovation covariance".into(), value: f64::NAN, expected: "invertible" });
        };
        let k = pht * s_inv;
        self.x += k * y;
        let i_kh = Matrix6::identity() - k * h;
        self.p = i_kh * self.p * i_kh.transpose() + k * (Matrix3::identity() * r2) * k.transpose();
        self.stamp = stamp;
        Ok(self.estimate())
    }

    /// The estimate at the last update.
    pub fn estimate(&self) -> Estimate {
        Estimate {
            stamp: self.stamp,
            position: Point3::new(self.x[0], self.x[1], self.x[2]),
            velocity: Vector3::new(self.x[3], self.x[4], self.x[5]),
            covariance: self.p,
        }
    }

    /// The state predicted to `stamp` (s) without changing the filter: "where is the hand
    /// now". A time before the last update returns the last estimate; `None` before the first
    /// measurement.
    pub fn predict_to(&self, stamp: f64) -> Option<Estimate> {
        if !self.initialised {
            return None;
        }
        let dt = stamp - self.stamp;
        if dt.is_nan() || dt <= 0.0 || !dt.is_finite() {
            return Some(self.estimate());
        }
        let f = transition(dt);
        let x = f * self.x;
        Some(Estimate {
            stamp,
            position: Point3::new(x[0], x[1], x[2]),
            velocity: Vector3::new(x[3], x[4], x[5]),
            covariance: f * self.p * f.transpose() + process(self.config.process_noise, dt),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tracks_a_constant_velocity_point_exactly_without_noise() {
        let mut kf = ConstantVelocityKf::new(KalmanConfig::default()).expect("kf");
        let v = Vector3::new(0.3, -0.2, 0.1);
        for i in 0..300 {
            let t = i as f64 / 30.0;
            kf.update(t, &(Point3::new(0.1, 0.2, 0.3) + v * t)).expect("update");
        }
        let e = kf.estimate();
        assert!((e.velocity - v).norm() < 1e-6, "{}", e.velocity);
        let ahead = kf.predict_to(10.0 + 0.5).expect("predict");
        assert!((ahead.position - (Point3::new(0.1, 0.2, 0.3) + v * 10.5)).norm() < 1e-5);
        // The prediction did not change the filter.
        assert_eq!(kf.estimate(), e);
        assert!(ahead.covariance[(0, 0)] > e.covariance[(0, 0)]);
    }

    #[test]
    fn rejects_backwards_stamps_and_nan() {
        let mut kf = ConstantVelocityKf::new(KalmanConfig::default()).expect("kf");
        kf.update(1.0, &Point3::origin()).expect("first");
        let before = kf.estimate();
        assert!(kf.update(0.5, &Point3::new(1.0, 0.0, 0.0)).is_err());
        assert!(kf.update(1.1, &Point3::new(f64::NAN, 0.0, 0.0)).is_err());
        assert_eq!(kf.estimate(), before);
        assert!(ConstantVelocityKf::new(KalmanConfig { process_noise: f64::NAN, ..Default::default() }).is_err());
        assert!(ConstantVelocityKf::new(KalmanConfig { measurement_noise_m: -1.0, ..Default::default() }).is_err());
    }
}
