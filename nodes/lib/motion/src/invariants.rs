//! Unidirectional invariants (thesis Sec. 3.2.1, eq. 3.16–3.17) and the EFS invariants of
//! Table B.1 with their reconstruction, for the Appendix-B comparison with DHB.
//!
//! Derivatives are central finite differences (one-sided at the ends) at the sampling period `dt`
//! (s). EFS of a vector signal `u` (linear velocity in m/s or angular velocity in rad/s):
//! `e¹ = ‖u‖`, `e² = ‖u × u̇‖ / ‖u‖²` (curvature × speed), `e³ = ‖u‖ (u · (u̇ × ü)) / ‖u × u̇‖²`
//! (torsion × speed, signed). The reconstruction integrates the Frenet–Serret frame with the
//! Darboux vector `(e³, 0, e²)` by the exponential map at the mid-step value.
//! The DS invariants of Table B.1 (screw-axis based) are in [`crate::screw`]; the comparison of
//! App. B.2 is [`crate::appendix_b`].

use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::error::{MotionError, Result};

const EPS: f64 = 1e-12;

/// Central finite differences of `u` sampled every `dt` s (one-sided at the ends).
pub(crate) fn derivative(u: &[Vector3<f64>], dt: f64) -> Vec<Vector3<f64>> {
    let n = u.len();
    (0..n)
        .map(|i| {
            if i == 0 {
                (u[1] - u[0]) / dt
            } else if i == n - 1 {
                (u[n - 1] - u[n - 2]) / dt
            } else {
                (u[i + 1] - u[i - 1]) / (2.0 * dt)
            }
        })
        .collect()
}

/// At least 3 finite samples and a finite `dt > 0`.
pub(crate) fn check_signal(u: &[Vector3<f64>], dt: f64, what: &str) -> Result<()> {
    if u.len() < 3 {
        return Err(MotionError::TooFewSamples {
            what: what.into(),
            needed: 3,
            got: u.len(),
        });
    }
    if let Some(i) = u.iter().position(|v| !v.iter().all(|x| x.is_finite())) {
        return Err(MotionError::NotFinite {
            what: what.into(),
            index: i,
        });
    }
    if !(dt > 0.0) || !dt.is_finite() {
        return Err(crate::error::invalid("dt", "must be finite and > 0"));
    }
    Ok(())
}

/// Eq. 3.16–3.17: `γ_t = ‖v × v̇‖/‖v‖²` and `ξ_t = ‖ω × ω̇‖/‖ω‖²` (0 where the velocity vanishes).
/// Invariant to roto-translation (and `γ` to linear scale), not to speed.
pub fn unidirectional(v: &[Vector3<f64>], w: &[Vector3<f64>], dt: f64) -> Result<Vec<[f64; 2]>> {
    crate::error::check_dim("angular vs linear velocities", v.len(), w.len())?;
    check_signal(v, dt, "linear velocity")?;
    check_signal(w, dt, "angular velocity")?;
    let dv = derivative(v, dt);
    let dw = derivative(w, dt);
    let f = |a: &Vector3<f64>, b: &Vector3<f64>| {
        let n2 = a.norm_squared();
        if n2 > EPS {
            a.cross(b).norm() / n2
        } else {
            0.0
        }
    };
    Ok((0..v.len())
        .map(|t| [f(&v[t], &dv[t]), f(&w[t], &dw[t])])
        .collect())
}

/// EFS invariants of one vector signal and its initial Frenet–Serret frame.
#[derive(Debug, Clone, PartialEq)]
pub struct EfsSignal {
    /// Rows `(e¹, e², e³)`.
    pub rows: Vec<[f64; 3]>,
    /// Initial frame (columns T, N, B).
    pub frame0: Matrix3<f64>,
}

/// EFS invariants of `u` sampled at `dt`.
pub fn efs_signal(u: &[Vector3<f64>], dt: f64) -> Result<EfsSignal> {
    check_signal(u, dt, "EFS signal")?;
    let du = derivative(u, dt);
    let ddu = derivative(&du, dt);
    let rows = (0..u.len())
        .map(|t| {
            let e1 = u[t].norm();
            let c = u[t].cross(&du[t]);
            let c2 = c.norm_squared();
            let e2 = if e1 > EPS { c.norm() / (e1 * e1) } else { 0.0 };
            let e3 = if c2 > EPS {
                e1 * u[t].dot(&du[t].cross(&ddu[t])) / c2
            } else {
                0.0
            };
            [e1, e2, e3]
        })
        .collect();
    let t0 = if u[0].norm() > EPS {
        u[0].normalize()
    } else {
        Vector3::x()
    };
    let c0 = u[0].cross(&du[0]);
    let b0 = if c0.norm() > EPS {
        c0.normalize()
    } else {
        let a = if t0.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        t0.cross(&a).normalize()
    };
    let frame0 = Matrix3::from_columns(&[t0, b0.cross(&t0), b0]);
    Ok(EfsSignal { rows, frame0 })
}

/// Reconstructs the signal from its EFS invariants.
pub fn efs_reconstruct(s: &EfsSignal, dt: f64) -> Vec<Vector3<f64>> {
    let mut r = Rotation3::from_matrix_unchecked(s.frame0);
    let n = s.rows.len();
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        out.push(r.matrix().column(0) * s.rows[k][0]);
        if k + 1 < n {
            let e2 = 0.5 * (s.rows[k][1] + s.rows[k + 1][1]);
            let e3 = 0.5 * (s.rows[k][2] + s.rows[k + 1][2]);
            r *= Rotation3::from_scaled_axis(Vector3::new(e3, 0.0, e2) * dt);
        }
    }
    out
}

/// Residual signal-to-noise ratio (dB) of invariants computed on noisy data: the power of the
/// clean invariants over the power of their point-wise difference (App. B.2.2).
pub fn residual_snr_db(clean: &[f64], noisy: &[f64]) -> f64 {
    let ps: f64 = clean.iter().map(|v| v * v).sum();
    let pr: f64 = clean
        .iter()
        .zip(noisy)
        .map(|(a, b)| (a - b) * (a - b))
        .sum();
    10.0 * (ps / pr.max(1e-300)).log10()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unidirectional_is_roto_scale_invariant() {
        let dt = 0.01;
        let v: Vec<_> = (0..200)
            .map(|i| {
                let t = i as f64 * dt;
                Vector3::new(t.cos(), (2.0 * t).sin(), 0.3 * t)
            })
            .collect();
        let w: Vec<_> = (0..200)
            .map(|i| {
                let t = i as f64 * dt;
                Vector3::new(0.2, t.sin(), 1.0)
            })
            .collect();
        let a = unidirectional(&v, &w, dt).expect("inv");
        let r = Rotation3::from_euler_angles(0.3, -1.0, 2.0);
        let v2: Vec<_> = v.iter().map(|x| r * x * 3.5).collect();
        let w2: Vec<_> = w.iter().map(|x| r * x).collect();
        let b = unidirectional(&v2, &w2, dt).expect("inv");
        for (x, y) in a.iter().zip(&b) {
            assert!((x[0] - y[0]).abs() < 1e-9 && (x[1] - y[1]).abs() < 1e-9);
        }
    }

    #[test]
    fn efs_of_a_helix_is_constant_and_reconstructs() {
        // v(t) of a helix: constant speed, curvature and torsion.
        let dt = 0.001;
        let v: Vec<_> = (0..2000)
            .map(|i| {
                let t = i as f64 * dt;
                Vector3::new(-t.sin(), t.cos(), 0.5)
            })
            .collect();
        let s = efs_signal(&v, dt).expect("efs");
        let mid = s.rows[1000];
        assert!((mid[0] - 1.25f64.sqrt()).abs() < 1e-9);
        let back = efs_reconstruct(&s, dt);
        let rmse = (back
            .iter()
            .zip(&v)
            .map(|(a, b)| (a - b).norm_squared())
            .sum::<f64>()
            / v.len() as f64)
            .sqrt();
        assert!(rmse < 1e-2, "{rmse}");
    }
}
