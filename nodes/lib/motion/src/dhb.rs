//! DHB (Denavit–Hartenberg inspired bidirectional) invariants of rigid-body trajectories
//! (thesis Sec. 3.2.2, Algorithm 2, eq. 3.18–3.65, Table 3.1).
//!
//! A sequence of 3-vectors `u_t` (position differences `Δp_t` and rotation vectors `Δr_t` for the
//! position-based form; linear `v_t` and angular `ω_t` velocities for the velocity-based form)
//! becomes per sample `(m_t, θ¹_t, θ²_t)`: `m_t = ‖u_t‖` and the two DH-like angles that carry the
//! frame `F_t = [x̂ ŷ ẑ]` onto `F_{t+1} = F_t R_y(θ¹_t) R_x(θ²_t)`. With `N` vectors, `N − 2` rows
//! are produced (Algorithm 2). Angles are computed with `atan2` of the frame-based forms
//! (eq. 3.26–3.29), which equal the closed forms of Algorithm 2 where those are defined and extend
//! them to the singular cases of Table 3.1: an undefined `x̂` (zero vector) or `ŷ` (parallel
//! consecutive vectors) is taken from the previous instant (from the initial frame at `t = 0`),
//! which yields the table's zero invariants. `ŷ` keeps its sign continuous (flipped when
//! `ŷ_t · ŷ_{t−1} < 0`).
//!
//! Units: `m_t` in m (position-based), m/s (linear velocity), rad or rad/s (angular); angles in rad.
//! Orientation differences are world-frame: `R_{t+1} = exp(Δr_t) R_t`.

use nalgebra::{Matrix3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{MotionError, Result};

const EPS: f64 = 1e-12;

/// `(m, θ¹, θ²)` of one vector sequence, one row per instant.
pub type Triplet = [f64; 3];

/// Invariants of one vector sequence plus its initial frame (needed to reconstruct).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VectorInvariants {
    /// Rows `(m_t, θ¹_t, θ²_t)`.
    pub rows: Vec<Triplet>,
    /// Initial frame `F_1` (columns x̂, ŷ, ẑ) in the world frame.
    pub frame0: Matrix3<f64>,
}

fn any_perpendicular(x: &Vector3<f64>) -> Vector3<f64> {
    let a = if x.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    x.cross(&a).normalize()
}

/// Algorithm 2's `computeInvariants` for a sequence `u` (at least 3 vectors). `init` is a known
/// initial frame used where the data do not define one (pure rotation/translation, straight line).
pub fn compute_invariants(
    u: &[Vector3<f64>],
    init: Option<&Matrix3<f64>>,
) -> Result<VectorInvariants> {
    let n = u.len();
    if n < 3 {
        return Err(MotionError::TooFewSamples {
            what: "DHB vector sequence".into(),
            needed: 3,
            got: n,
        });
    }
    if let Some(i) = u.iter().position(|v| !v.iter().all(|x| x.is_finite())) {
        return Err(MotionError::NotFinite {
            what: "DHB input vector".into(),
            index: i,
        });
    }
    let init_x = init
        .map(|f| f.column(0).into_owned())
        .unwrap_or_else(Vector3::x);
    // x axes
    let mut xs: Vec<Vector3<f64>> = Vec::with_capacity(n);
    for (t, v) in u.iter().enumerate() {
        let nv = v.norm();
        let x = if nv > EPS {
            v / nv
        } else if t == 0 {
            init_x
        } else {
            xs[t - 1]
        };
        xs.push(x);
    }
    // y axes, t = 0..n-1 (the last one repeats the previous: only used for θ² of row n−3).
    let mut ys: Vec<Vector3<f64>> = Vec::with_capacity(n);
    for t in 0..n {
        let c = if t + 1 < n {
            xs[t].cross(&xs[t + 1])
        } else {
            Vector3::zeros()
        };
        let nc = c.norm();
        let y = if nc > EPS {
            let y = c / nc;
            match ys.last() {
                Some(prev) if y.dot(prev) < 0.0 => -y,
                _ => y,
            }
        } else if t == 0 {
            let cand = init
                .map(|f| f.column(1).into_owned())
                .unwrap_or_else(|| any_perpendicular(&xs[0]));
            let y = cand - xs[0] * xs[0].dot(&cand);
            if y.norm() > 1e-9 {
                y.normalize()
            } else {
                any_perpendicular(&xs[0])
            }
        } else {
            ys[t - 1]
        };
        ys.push(y);
    }
    let frame0 = Matrix3::from_columns(&[xs[0], ys[0], xs[0].cross(&ys[0])]);
    let rows = (0..n - 2)
        .map(|t| {
            let m = u[t].dot(&xs[t]);
            let th1 = xs[t]
                .cross(&xs[t + 1])
                .dot(&ys[t])
                .atan2(xs[t].dot(&xs[t + 1]));
            let th2 = ys[t]
                .cross(&ys[t + 1])
                .dot(&xs[t + 1])
                .atan2(ys[t].dot(&ys[t + 1]));
            [m, th1, th2]
        })
        .collect();
    Ok(VectorInvariants { rows, frame0 })
}

fn ry(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}
fn rx(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

/// Eq. 3.48–3.56: the vectors `u_t = F_t [s·m_t, 0, 0]ᵀ` with `F_{t+1} = F_t R_y(θ¹_t) R_x(θ²_t)`,
/// starting from `frame0` (roto-translated instances use a rotated `frame0`; `scale` is `s` of
/// the scaled reconstruction).
pub fn reconstruct_vectors(
    rows: &[Triplet],
    frame0: &Matrix3<f64>,
    scale: f64,
) -> Vec<Vector3<f64>> {
    let mut f = *frame0;
    rows.iter()
        .map(|[m, t1, t2]| {
            let u = f.column(0) * (scale * m);
            f = f * ry(*t1) * rx(*t2);
            u
        })
        .collect()
}

/// Which form of DHB.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum DhbKind {
    /// From poses: `Δp_t`, `Δr_t` (m, rad).
    Position,
    /// From twists: `v_t`, `ω_t` (m/s, rad/s).
    Velocity,
}

/// Six DHB invariants per instant with what is needed to reconstruct the motion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Dhb {
    /// Position- or velocity-based.
    pub kind: DhbKind,
    /// Linear part `(m_l, θ¹_l, θ²_l)`.
    pub linear: VectorInvariants,
    /// Angular part `(m_a, θ¹_a, θ²_a)`.
    pub angular: VectorInvariants,
    /// Initial position (m), position-based only.
    pub p0: Vector3<f64>,
    /// Initial orientation, position-based only.
    pub r0: Rotation3<f64>,
}

/// A pose trajectory: positions (m) and orientations (world frame).
#[derive(Debug, Clone, PartialEq)]
pub struct Poses {
    /// Positions.
    pub p: Vec<Vector3<f64>>,
    /// Orientations.
    pub r: Vec<Rotation3<f64>>,
}

impl Dhb {
    /// Position-based invariants of a pose trajectory (at least 4 poses).
    pub fn from_poses(poses: &Poses) -> Result<Self> {
        crate::error::check_dim(
            "DHB orientations vs positions",
            poses.p.len(),
            poses.r.len(),
        )?;
        if poses.p.len() < 4 {
            return Err(MotionError::TooFewSamples {
                what: "DHB pose trajectory".into(),
                needed: 4,
                got: poses.p.len(),
            });
        }
        let dp: Vec<Vector3<f64>> = poses.p.windows(2).map(|w| w[1] - w[0]).collect();
        let dr: Vec<Vector3<f64>> = poses
            .r
            .windows(2)
            .map(|w| (w[1] * w[0].inverse()).scaled_axis())
            .collect();
        Ok(Self {
            kind: DhbKind::Position,
            linear: compute_invariants(&dp, None)?,
            angular: compute_invariants(&dr, None)?,
            p0: poses.p[0],
            r0: poses.r[0],
        })
    }

    /// Velocity-based invariants of a twist trajectory (at least 3 samples).
    pub fn from_twists(v: &[Vector3<f64>], w: &[Vector3<f64>]) -> Result<Self> {
        crate::error::check_dim("DHB angular vs linear velocities", v.len(), w.len())?;
        Ok(Self {
            kind: DhbKind::Velocity,
            linear: compute_invariants(v, None)?,
            angular: compute_invariants(w, None)?,
            p0: Vector3::zeros(),
            r0: Rotation3::identity(),
        })
    }

    /// Rows of the six invariants `(m_l, θ¹_l, θ²_l, m_a, θ¹_a, θ²_a)`.
    pub fn rows(&self) -> Vec<[f64; 6]> {
        self.linear
            .rows
            .iter()
            .zip(&self.angular.rows)
            .map(|(l, a)| [l[0], l[1], l[2], a[0], a[1], a[2]])
            .collect()
    }

    /// Reconstructed twists `(v_t, ω_t)` (velocity-based) or differences `(Δp_t, Δr_t)`.
    pub fn reconstruct_vectors(&self) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
        (
            reconstruct_vectors(&self.linear.rows, &self.linear.frame0, 1.0),
            reconstruct_vectors(&self.angular.rows, &self.angular.frame0, 1.0),
        )
    }

    /// Reconstructed poses (position-based), `N − 1` of them for `N` input poses' `N − 2` rows + start.
    /// `scale` multiplies `m_l` (eq. after 3.56), `(rotation, translation)` roto-translates the
    /// initial pose and frames.
    pub fn reconstruct_poses(
        &self,
        scale: f64,
        rotation: &Rotation3<f64>,
        translation: &Vector3<f64>,
    ) -> Poses {
        let ra = rotation.matrix();
        let dp = reconstruct_vectors(&self.linear.rows, &(ra * self.linear.frame0), scale);
        let dr = reconstruct_vectors(&self.angular.rows, &(ra * self.angular.frame0), 1.0);
        let mut p = vec![ra * self.p0 + translation];
        let mut r = vec![rotation * self.r0];
        for (a, b) in dp.iter().zip(&dr) {
            let np = p[p.len() - 1] + a;
            let nr = Rotation3::from_scaled_axis(*b) * r[r.len() - 1];
            p.push(np);
            r.push(nr);
        }
        Poses { p, r }
    }
}

/// Time normalisation (eq. 3.60): every value multiplied by the duration `t_f` (s).
pub fn time_normalised(rows: &[[f64; 6]], t_f: f64) -> Vec<[f64; 6]> {
    rows.iter().map(|r| r.map(|v| v * t_f)).collect()
}

/// Scale normalisation (eq. 3.62): `m_l` and `m_a` divided by their sums of absolute values.
pub fn scale_normalised(rows: &[[f64; 6]]) -> Vec<[f64; 6]> {
    let sl: f64 = rows.iter().map(|r| r[0].abs()).sum();
    let sa: f64 = rows.iter().map(|r| r[3].abs()).sum();
    rows.iter()
        .map(|r| {
            let mut o = *r;
            if sl > 0.0 {
                o[0] /= sl;
            }
            if sa > 0.0 {
                o[3] /= sa;
            }
            o
        })
        .collect()
}

/// Reverse motion (eq. 3.63–3.65): `m` in reverse order, `θ¹` and `θ²` in reverse order shifted by
/// one and two samples. From `L` rows, `L − 2` rows are returned: row `r` is
/// `(m[L−1−r], θ¹[L−2−r], θ²[L−3−r])`, i.e. the invariants of the reversed motion from its third
/// sample on (angle signs follow the reversed frames' orientation and may differ).
pub fn reversed(rows: &[[f64; 6]]) -> Vec<[f64; 6]> {
    let l = rows.len();
    if l < 3 {
        return Vec::new();
    }
    (0..l - 2)
        .map(|r| {
            let (a, b, c) = (&rows[l - 1 - r], &rows[l - 2 - r], &rows[l - 3 - r]);
            [a[0], b[1], c[2], a[3], b[4], c[5]]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The synthetic twist of Fig. B.1.
    pub(crate) fn twist(dt: f64) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
        let n = (4.0 / dt).round() as usize + 1;
        (0..n)
            .map(|i| {
                let t = i as f64 * dt;
                (
                    Vector3::new(0.01 * t.exp(), 5.0 + 1.5 * t.sin(), t.cos()),
                    Vector3::new(0.5 * t.sin(), t.cos(), 0.1 * t),
                )
            })
            .unzip()
    }

    fn rmse(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
        (a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).norm_squared())
            .sum::<f64>()
            / a.len() as f64)
            .sqrt()
    }

    #[test]
    fn velocity_reconstruction_is_exact_on_fig_b1() {
        for dt in [0.1, 0.01, 0.001] {
            let (v, w) = twist(dt);
            let dhb = Dhb::from_twists(&v, &w).expect("dhb");
            let (rv, rw) = dhb.reconstruct_vectors();
            assert_eq!(rv.len(), v.len() - 2);
            let (el, ea) = (rmse(&rv, &v), rmse(&rw, &w));
            assert!(el < 1e-9 && ea < 1e-9, "dt {dt}: {el} {ea}");
        }
    }

    #[test]
    fn singular_cases_of_table_3_1() {
        // Pure translation along a straight line: angular part all zero, linear angles zero.
        let p: Vec<_> = (0..10)
            .map(|i| Vector3::new(i as f64 * 0.1, 0.0, 0.0))
            .collect();
        let r = vec![Rotation3::identity(); 10];
        let d = Dhb::from_poses(&Poses {
            p: p.clone(),
            r: r.clone(),
        })
        .expect("dhb");
        for row in d.rows() {
            assert!((row[0] - 0.1).abs() < 1e-12);
            assert_eq!(&row[1..], &[0.0; 5]);
        }
        let back = d.reconstruct_poses(1.0, &Rotation3::identity(), &Vector3::zeros());
        for (a, b) in back.p.iter().zip(&p) {
            assert!((a - b).norm() < 1e-12);
        }
        // Planar motion: θ²_l = 0, rotation about parallel axes → θ¹_a = θ²_a = 0.
        let p: Vec<_> = (0..30)
            .map(|i| {
                let t = i as f64 * 0.1;
                Vector3::new(t.cos(), (2.0 * t).sin(), 0.0)
            })
            .collect();
        let r: Vec<_> = (0..30)
            .map(|i| Rotation3::from_axis_angle(&Vector3::z_axis(), 0.1 * (i * i) as f64 / 30.0))
            .collect();
        let d = Dhb::from_poses(&Poses { p, r }).expect("dhb");
        for row in d.rows() {
            assert!(
                row[2].abs() < 1e-9 && row[4].abs() < 1e-9 && row[5].abs() < 1e-9,
                "{row:?}"
            );
        }
        // Pure rotation: linear part zero.
        let p = vec![Vector3::new(1.0, 2.0, 3.0); 10];
        let r: Vec<_> = (0..10)
            .map(|i| Rotation3::from_euler_angles(0.1 * i as f64, 0.05 * (i * i) as f64, 0.0))
            .collect();
        let d = Dhb::from_poses(&Poses { p, r: r.clone() }).expect("dhb");
        for row in d.rows() {
            assert_eq!(&row[..3], &[0.0; 3]);
        }
        let back = d.reconstruct_poses(1.0, &Rotation3::identity(), &Vector3::zeros());
        let dr: Vec<_> = r
            .windows(2)
            .map(|w| (w[1] * w[0].inverse()).scaled_axis())
            .collect();
        let (_, rdr) = d.reconstruct_vectors();
        for (a, b) in rdr.iter().zip(&dr) {
            assert!((a - b).norm() < 1e-9, "{a:?} {b:?}");
        }
        for (a, b) in back.r.iter().zip(&r) {
            assert!((a.matrix() - b.matrix()).norm() < 1e-9, "{a:?} {b:?}");
        }
    }

    #[test]
    fn time_normalisation_removes_the_execution_speed() {
        // The same path executed twice as slowly, sampled at the same number of instants.
        let (v, w) = twist(0.02);
        let slow_v: Vec<_> = v.iter().map(|x| x * 0.5).collect();
        let slow_w: Vec<_> = w.iter().map(|x| x * 0.5).collect();
        let t_f = 4.0;
        let a = time_normalised(&Dhb::from_twists(&v, &w).expect("dhb").rows(), t_f);
        let b = time_normalised(
            &Dhb::from_twists(&slow_v, &slow_w).expect("dhb").rows(),
            2.0 * t_f,
        );
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x[0] - y[0]).abs() < 1e-9 && (x[3] - y[3]).abs() < 1e-9,
                "{x:?} {y:?}"
            );
        }
        // Scale normalisation makes the magnitudes sum to one.
        let s = scale_normalised(&a);
        assert!((s.iter().map(|r| r[0].abs()).sum::<f64>() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn reversed_matches_invariants_of_reversed_motion() {
        let (v, w) = twist(0.05);
        let rows = Dhb::from_twists(&v, &w).expect("dhb").rows();
        let vr: Vec<_> = v.iter().rev().map(|x| -x).collect();
        let wr: Vec<_> = w.iter().rev().map(|x| -x).collect();
        let rows_r = Dhb::from_twists(&vr, &wr).expect("dhb").rows();
        let rev = reversed(&rows);
        assert_eq!(rev.len(), rows.len() - 2);
        for (r, (a, b)) in rev.iter().zip(rows_r.iter().skip(2)).enumerate() {
            for k in 0..6 {
                assert!(
                    (a[k].abs() - b[k].abs()).abs() < 1e-9,
                    "row {r} col {k}: {a:?} vs {b:?}"
                );
            }
        }
    }
}
