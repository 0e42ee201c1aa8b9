//! EFS and DS invariants of pose trajectories (App. B, Table B.1), with their reconstruction, for
//! `cowork learn dhb --kind efs|ds` (DHB itself is [`crate::dhb::Dhb::from_poses`]).
//!
//! Both need a uniform sampling period `dt` (s): their invariants are time derivatives. EFS takes
//! the twist `v_t = (p_{t+1} − p_t)/dt` (m/s), `ω_t = log(R_{t+1} R_tᵀ)/dt` (rad/s, world frame);
//! DS the spatial twist `log(T_{t+1} T_t⁻¹)/dt` ([`crate::screw::spatial_twists_from_poses`]).
//! `N` poses give `N − 1` rows; the reconstruction gives `N` poses.

use nalgebra::{Rotation3, Vector3};

use crate::dhb::Poses;
use crate::error::{MotionError, Result, invalid};
use crate::invariants::{EfsSignal, efs_reconstruct, efs_signal};
use crate::screw::{
    DsInvariants, ds_invariants, ds_reconstruct, poses_from_spatial_twists, so3_log,
    spatial_twists_from_poses,
};

/// The sampling period of `t` (s) if it is uniform to 1 % (at least 4 samples).
pub fn uniform_dt(t: &[f64]) -> Result<f64> {
    if t.len() < 4 {
        return Err(MotionError::TooFewSamples {
            what: "pose trajectory".into(),
            needed: 4,
            got: t.len(),
        });
    }
    let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    if !(dt > 0.0) || !dt.is_finite() {
        return Err(invalid("t", "must be strictly increasing"));
    }
    if let Some(i) = t
        .windows(2)
        .position(|w| ((w[1] - w[0]) - dt).abs() > 0.01 * dt)
    {
        return Err(invalid(
            "t",
            format!(
                "EFS and DS need uniform sampling: step {i} is {} s, the mean step {dt} s (resample first)",
                t[i + 1] - t[i]
            ),
        ));
    }
    Ok(dt)
}

/// EFS invariants of a pose trajectory.
#[derive(Debug, Clone, PartialEq)]
pub struct EfsPoses {
    /// Sampling period (s).
    pub dt: f64,
    /// Initial position (m).
    pub p0: Vector3<f64>,
    /// Initial orientation.
    pub r0: Rotation3<f64>,
    /// EFS of the linear velocity.
    pub linear: EfsSignal,
    /// EFS of the angular velocity.
    pub angular: EfsSignal,
}

impl EfsPoses {
    /// Invariants of `poses` sampled every `dt` s.
    pub fn from_poses(poses: &Poses, dt: f64) -> Result<Self> {
        crate::error::check_dim("orientations vs positions", poses.p.len(), poses.r.len())?;
        let v: Vec<Vector3<f64>> = poses.p.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
        let w: Vec<Vector3<f64>> = poses
            .r
            .windows(2)
            .map(|w| so3_log(&(w[1] * w[0].inverse())) / dt)
            .collect();
        Ok(Self {
            dt,
            p0: poses.p.first().copied().unwrap_or_default(),
            r0: poses.r.first().copied().unwrap_or_else(Rotation3::identity),
            linear: efs_signal(&v, dt)?,
            angular: efs_signal(&w, dt)?,
        })
    }

    /// Rows `(e¹_v, e²_v, e³_v, e¹_ω, e²_ω, e³_ω)`.
    pub fn rows(&self) -> Vec<[f64; 6]> {
        self.linear
            .rows
            .iter()
            .zip(&self.angular.rows)
            .map(|(l, a)| [l[0], l[1], l[2], a[0], a[1], a[2]])
            .collect()
    }

    /// Poses integrated from the reconstructed twists.
    pub fn reconstruct(&self) -> Poses {
        let v = efs_reconstruct(&self.linear, self.dt);
        let w = efs_reconstruct(&self.angular, self.dt);
        let mut p = vec![self.p0];
        let mut r = vec![self.r0];
        for (vv, ww) in v.iter().zip(&w) {
            let np = p[p.len() - 1] + vv * self.dt;
            let nr = Rotation3::from_scaled_axis(ww * self.dt) * r[r.len() - 1];
            p.push(np);
            r.push(nr);
        }
        Poses { p, r }
    }
}

/// DS invariants of a pose trajectory.
#[derive(Debug, Clone, PartialEq)]
pub struct DsPoses {
    /// Sampling period (s).
    pub dt: f64,
    /// Initial position (m).
    pub p0: Vector3<f64>,
    /// Initial orientation.
    pub r0: Rotation3<f64>,
    /// Invariants of the spatial twists.
    pub inv: DsInvariants,
}

impl DsPoses {
    /// Invariants of `poses` sampled every `dt` s.
    pub fn from_poses(poses: &Poses, dt: f64) -> Result<Self> {
        let (v, w) = spatial_twists_from_poses(&poses.p, &poses.r, dt)?;
        Ok(Self {
            dt,
            p0: poses.p[0],
            r0: poses.r[0],
            inv: ds_invariants(&v, &w, dt)?,
        })
    }

    /// Poses integrated from the reconstructed spatial twists.
    pub fn reconstruct(&self) -> Poses {
        let (v, w) = ds_reconstruct(&self.inv, self.dt);
        let (p, r) = poses_from_spatial_twists(&v, &w, self.dt, self.p0, self.r0);
        Poses { p, r }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trajectory(dt: f64, n: usize) -> Poses {
        let (p, r) = (0..n)
            .map(|i| {
                let t = i as f64 * dt;
                (
                    Vector3::new(0.3 * t.cos(), 0.2 * (1.3 * t).sin(), 0.1 * t),
                    Rotation3::from_euler_angles(0.4 * t, 0.3 * t.sin(), 0.2 * t * t),
                )
            })
            .unzip();
        Poses { p, r }
    }

    fn max_err(a: &Poses, b: &Poses) -> (f64, f64) {
        let ep =
            a.p.iter()
                .zip(&b.p)
                .map(|(x, y)| (x - y).norm())
                .fold(0.0, f64::max);
        let er =
            a.r.iter()
                .zip(&b.r)
                .map(|(x, y)| (x.inverse() * y).angle())
                .fold(0.0, f64::max);
        (ep, er)
    }

    #[test]
    fn efs_and_ds_reconstruct_poses_with_small_error() {
        let dt = 0.005;
        let poses = trajectory(dt, 601);
        let efs = EfsPoses::from_poses(&poses, dt).expect("efs");
        let ds = DsPoses::from_poses(&poses, dt).expect("ds");
        assert_eq!(efs.rows().len(), 600);
        assert_eq!(ds.inv.rows.len(), 600);
        let (ep, er) = max_err(&efs.reconstruct(), &poses);
        assert!(ep < 1e-3 && er < 1e-3, "EFS {ep} m {er} rad");
        let (ep, er) = max_err(&ds.reconstruct(), &poses);
        assert!(ep < 1e-3 && er < 1e-3, "DS {ep} m {er} rad");
    }

    #[test]
    fn uniform_sampling_is_required() {
        assert!(uniform_dt(&[0.0, 0.1, 0.2, 0.3]).is_ok());
        assert!(uniform_dt(&[0.0, 0.1, 0.25, 0.3]).is_err());
        assert!(uniform_dt(&[0.0, 0.1, 0.2]).is_err());
    }
}
