//! DS invariants of Table B.1 (thesis App. B, De Schutter's screw-based description of rigid-body
//! motion, ref. [42]): the motion is described along its instantaneous screw axis (ISA) and by the
//! motion of the ISA itself.
//!
//! **Twist convention.** `ω_t` (rad/s) is the angular velocity and `v_t` (m/s) the linear velocity
//! of the body point that coincides with the world origin at time `t` (the spatial twist), both in
//! the world frame. [`ds_from_hybrid`] converts the usual "velocity of a reference point `p_t`"
//! twist; [`spatial_twists_from_poses`] gets the twists of a pose trajectory.
//!
//! **The ISA frame.** `e_x = ω/‖ω‖` (the ISA direction), `e_z ∥ ω × ω̇` (the common normal of
//! consecutive ISAs), `e_y = e_z × e_x`; its origin `o` is the striction point of the ISA (the foot
//! of that common normal). The six invariants per sample, in the order of Table B.1:
//!
//! | column | Table B.1 | meaning (frame axes above) |
//! |---|---|---|
//! | `d¹_ω` | `‖ω‖` | rotation speed about the ISA (rad/s) |
//! | `d²_ω` | `‖ω×ω̇‖/‖ω‖²` | rotation speed of the ISA about `e_z` (rad/s) |
//! | `d³_ω` | `‖ω‖ (ω×ω̇)·ω̈ / ‖ω×ω̇‖²` | rotation speed of the common normal about `e_x` (rad/s) |
//! | `d¹_v` | `v·ω/‖ω‖` | translation speed along the ISA (m/s) |
//! | `d²_v` | `(ω×ω̇)/‖ω×ω̇‖ · ṗ` | translation speed of the ISA along `e_z` (m/s) |
//! | `d³_v` | `e_x · ȯ` | translation speed of the striction point along the ISA (m/s) |
//!
//! with `p = ω×v/‖ω‖²` (the ISA point closest to the origin) and
//! `ṗ = [‖ω‖²(ω̇×v + ω×v̇) − 2(ω×v)(ω·ω̇)]/‖ω‖⁴` as in Table B.1. The frame moves with the body
//! twist `(d³_ω, 0, d²_ω | d³_v, 0, d²_v)` (Frenet–Serret-like: no `e_y` components), the body with
//! `ω = d¹_ω e_x`, `v = d¹_v e_x + d¹_ω o × e_x`; [`ds_reconstruct`] integrates exactly that.
//!
//! **Deviation from Table B.1 as printed:** its `d³_v` is the time derivative of the striction
//! offset `s = −(e_y·ṗ)/d²_ω` along the ISA (the quotient-rule expansion, with typos in the
//! printed third term); the translation of the striction point along the ISA is `e_x·ṗ + ṡ`, and
//! that is what is stored here, so that the reconstruction converges as `Δt → 0` (Fig. B.2 shows
//! it does). Signs: `e_x` and `e_z` keep their direction continuous between samples (flipped when
//! they turn by more than 90°), which makes `d¹_ω` and `d²_ω` signed (the ± of Table B.1).
//!
//! Derivatives are central finite differences (one-sided at the ends), as for EFS. Singular cases:
//! with `ω = 0` at every sample (pure translation) the representation is the EFS of `v` (`d¹_v =
//! e¹_v`, `d²_ω = e²_v`, `d³_ω = e³_v`, App. B.1.2); where `ω` vanishes at some samples only, or
//! `ω × ω̇ = 0` (the ISA keeps its direction, e.g. planar motion), the frame of the previous sample
//! is kept and the translation of the ISA across `e_y` is lost: the reconstruction is then
//! inexact.

use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::error::{MotionError, Result, check_dim};
use crate::invariants::{check_signal, derivative, efs_signal};

/// Below this `‖ω‖` (rad/s) the ISA is undefined.
const EPS_W: f64 = 1e-9;
/// Below this `‖ω × ω̇‖` (rad²/s³) the common normal is undefined.
const EPS_A: f64 = 1e-12;

/// `(d¹_ω, d²_ω, d³_ω, d¹_v, d²_v, d³_v)` of one sample (rad/s and m/s).
pub type DsRow = [f64; 6];

/// DS invariants of a twist trajectory with the initial ISA frame needed to reconstruct it.
#[derive(Debug, Clone, PartialEq)]
pub struct DsInvariants {
    /// One row per twist sample.
    pub rows: Vec<DsRow>,
    /// Initial ISA frame orientation (columns `e_x, e_y, e_z`, world frame).
    pub frame0: Matrix3<f64>,
    /// Initial ISA frame origin (striction point, m, world frame).
    pub origin0: Vector3<f64>,
}

impl DsInvariants {
    /// The same motion expressed after the world transformation `x ↦ λ R x + t`: the linear
    /// invariants scale by `λ`, the angular ones do not change, the initial ISA frame moves.
    pub fn transformed(
        &self,
        rotation: &Rotation3<f64>,
        translation: &Vector3<f64>,
        scale: f64,
    ) -> Self {
        Self {
            rows: self
                .rows
                .iter()
                .map(|r| [r[0], r[1], r[2], scale * r[3], scale * r[4], scale * r[5]])
                .collect(),
            frame0: rotation.matrix() * self.frame0,
            origin0: rotation * self.origin0 * scale + translation,
        }
    }
}

/// Linear invariants divided by `Σ|d¹_v|` (scale normalisation as eq. 3.62 does for DHB).
pub fn ds_scale_normalised(rows: &[DsRow]) -> Vec<DsRow> {
    let s: f64 = rows.iter().map(|r| r[3].abs()).sum();
    rows.iter()
        .map(|r| {
            let mut o = *r;
            if s > 0.0 {
                for v in &mut o[3..] {
                    *v /= s;
                }
            }
            o
        })
        .collect()
}

fn perpendicular(x: &Vector3<f64>) -> Vector3<f64> {
    let a = if x.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    x.cross(&a).normalize()
}

/// DS invariants of the spatial twist `(v_t, ω_t)` sampled every `dt` s (at least 3 samples).
pub fn ds_invariants(v: &[Vector3<f64>], w: &[Vector3<f64>], dt: f64) -> Result<DsInvariants> {
    check_dim("DS angular vs linear velocities", v.len(), w.len())?;
    check_signal(v, dt, "DS linear velocity")?;
    check_signal(w, dt, "DS angular velocity")?;
    if w.iter().all(|x| x.norm() <= EPS_W) {
        // Pure translation: the EFS of v (App. B.1.2).
        let e = efs_signal(v, dt)?;
        return Ok(DsInvariants {
            rows: e
                .rows
                .iter()
                .map(|r| [0.0, r[1], r[2], r[0], 0.0, 0.0])
                .collect(),
            frame0: e.frame0,
            origin0: Vector3::zeros(),
        });
    }
    let dw = derivative(w, dt);
    let ddw = derivative(&dw, dt);
    let dv = derivative(v, dt);
    let ddv = derivative(&dv, dt);
    let n = v.len();
    let mut rows = Vec::with_capacity(n);
    let mut prev: Option<(Vector3<f64>, Vector3<f64>)> = None;
    let mut frame0 = Matrix3::identity();
    let mut origin0 = Vector3::zeros();
    for t in 0..n {
        let (om, om1, om2) = (w[t], dw[t], ddw[t]);
        let (vv, v1, v2) = (v[t], dv[t], ddv[t]);
        let wn2 = om.norm_squared();
        let wn = wn2.sqrt();
        if wn <= EPS_W {
            // ISA undefined here: keep the previous frame (or a default one at the start).
            let (ex, ez) = prev.unwrap_or_else(|| {
                let ex = Vector3::x();
                (ex, ex.cross(&perpendicular(&ex)))
            });
            rows.push([0.0, 0.0, 0.0, vv.dot(&ex), 0.0, 0.0]);
            prev = Some((ex, ez));
            if t == 0 {
                frame0 = Matrix3::from_columns(&[ex, ez.cross(&ex), ez]);
            }
            continue;
        }
        let ex_raw = om / wn;
        let ex = match prev {
            Some((pex, _)) if ex_raw.dot(&pex) < 0.0 => -ex_raw,
            _ => ex_raw,
        };
        let sx = ex.dot(&ex_raw);
        let a = om.cross(&om1);
        let an = a.norm();
        let a1 = om.cross(&om2);
        let (ez, ez_dot) = if an > EPS_A {
            let ez_raw = a / an;
            let sz = match prev {
                Some((_, pez)) if ez_raw.dot(&pez) < 0.0 => -1.0,
                _ => 1.0,
            };
            (ez_raw * sz, (a1 - ez_raw * ez_raw.dot(&a1)) * (sz / an))
        } else {
            let cand = prev.map_or_else(|| perpendicular(&ex), |(_, pez)| pez);
            let ez = cand - ex * ex.dot(&cand);
            let ez = if ez.norm() > 1e-9 {
                ez.normalize()
            } else {
                perpendicular(&ex)
            };
            (ez, Vector3::zeros())
        };
        let ey = ez.cross(&ex);
        let ex_dot = (om1 - ex_raw * ex_raw.dot(&om1)) * (sx / wn);
        let d1w = om.dot(&ex);
        let d2w = ex_dot.dot(&ey);
        let d3w = -ez_dot.dot(&ey);
        // The ISA point closest to the origin and its first two derivatives (p = q g).
        let q = om.cross(&vv);
        let q1 = om1.cross(&vv) + om.cross(&v1);
        let q2 = om2.cross(&vv) + 2.0 * om1.cross(&v1) + om.cross(&v2);
        let wd = om.dot(&om1);
        let g = 1.0 / wn2;
        let g1 = -2.0 * wd * g * g;
        let g2 = -2.0 * (om1.norm_squared() + om.dot(&om2)) * g * g + 8.0 * wd * wd * g * g * g;
        let p = q * g;
        let p1 = q1 * g + q * g1;
        let p2 = q2 * g + 2.0 * q1 * g1 + q * g2;
        let d1v = vv.dot(&ex);
        let d2v = p1.dot(&ez);
        let (s, d3v) = if d2w.abs() > EPS_A {
            // Striction offset s along the ISA and its rate.
            let s = -p1.dot(&ey) / d2w;
            let ey_dot = -d2w * ex + d3w * ez;
            let d2w_dot = (a.dot(&a1) / (an * wn2) - 2.0 * an * wd * g * g) * d2w.signum();
            let s_dot =
                -((ey_dot.dot(&p1) + ey.dot(&p2)) * d2w - p1.dot(&ey) * d2w_dot) / (d2w * d2w);
            (s, ex.dot(&p1) + s_dot)
        } else {
            (0.0, ex.dot(&p1))
        };
        if t == 0 {
            frame0 = Matrix3::from_columns(&[ex, ey, ez]);
            origin0 = p + s * ex;
        }
        rows.push([d1w, d2w, d3w, d1v, d2v, d3v]);
        prev = Some((ex, ez));
    }
    Ok(DsInvariants {
        rows,
        frame0,
        origin0,
    })
}

/// DS invariants of a twist given as the velocity `v_t` (m/s) of a body reference point at `p_t`
/// (m) and the angular velocity `ω_t`: the spatial twist is `v_t − ω_t × p_t`. The result does not
/// depend on which body point is used (Table B.2).
pub fn ds_from_hybrid(
    v: &[Vector3<f64>],
    w: &[Vector3<f64>],
    p: &[Vector3<f64>],
    dt: f64,
) -> Result<DsInvariants> {
    check_dim("DS reference points vs velocities", v.len(), p.len())?;
    check_dim("DS angular vs linear velocities", v.len(), w.len())?;
    let vo: Vec<Vector3<f64>> = v
        .iter()
        .zip(w)
        .zip(p)
        .map(|((v, w), p)| v - w.cross(p))
        .collect();
    ds_invariants(&vo, w, dt)
}

/// `exp` of the body twist `(ω, v)` (already multiplied by the time step): rotation and
/// translation of the rigid displacement.
pub fn se3_exp(w: &Vector3<f64>, v: &Vector3<f64>) -> (Rotation3<f64>, Vector3<f64>) {
    let th2 = w.norm_squared();
    let th = th2.sqrt();
    let wv = w.cross(v);
    let wwv = w.cross(&wv);
    let (b, c) = if th < 1e-6 {
        (0.5 - th2 / 24.0, 1.0 / 6.0 - th2 / 120.0)
    } else {
        ((1.0 - th.cos()) / th2, (th - th.sin()) / (th2 * th))
    };
    (Rotation3::from_scaled_axis(*w), v + wv * b + wwv * c)
}

/// Rotation vector (rad) of `r`, accurate for small angles too (`atan2` of the sine and cosine
/// parts instead of `acos` of the trace).
pub fn so3_log(r: &Rotation3<f64>) -> Vector3<f64> {
    let m = r.matrix();
    let s2 = Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    );
    let sin = 0.5 * s2.norm();
    let cos = 0.5 * (m.trace() - 1.0);
    if cos < -0.99 {
        // Near π the skew part vanishes; nalgebra takes the axis from the symmetric part.
        return r.scaled_axis();
    }
    let th = sin.atan2(cos);
    let f = if th < 1e-6 {
        0.5 * (1.0 + th * th / 6.0)
    } else {
        0.5 * th / sin
    };
    s2 * f
}

/// Inverse of [`se3_exp`]: the twist `(ω, v)` of the displacement `(R, t)` (rotation angle < π).
pub fn se3_log(r: &Rotation3<f64>, t: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let w = so3_log(r);
    let th2 = w.norm_squared();
    let th = th2.sqrt();
    let wt = w.cross(t);
    let wwt = w.cross(&wt);
    let c = if th < 1e-6 {
        1.0 / 12.0 + th2 / 720.0
    } else {
        (1.0 - th * th.sin() / (2.0 * (1.0 - th.cos()))) / th2
    };
    (w, t - 0.5 * wt + wwt * c)
}

/// Reconstructs the spatial twists `(v_t, ω_t)` from DS invariants sampled every `dt` s: the ISA
/// frame is carried by the exponential of its body twist at the mid-step value.
pub fn ds_reconstruct(inv: &DsInvariants, dt: f64) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    let n = inv.rows.len();
    let mut r = Rotation3::from_matrix_unchecked(inv.frame0);
    let mut o = inv.origin0;
    let mut vs = Vec::with_capacity(n);
    let mut ws = Vec::with_capacity(n);
    for k in 0..n {
        let row = &inv.rows[k];
        let ex = r.matrix().column(0).into_owned();
        ws.push(ex * row[0]);
        vs.push(ex * row[3] + o.cross(&ex) * row[0]);
        if k + 1 < n {
            let nx = &inv.rows[k + 1];
            let m = |i: usize| 0.5 * (row[i] + nx[i]) * dt;
            let (dr, dp) = se3_exp(
                &Vector3::new(m(2), 0.0, m(1)),
                &Vector3::new(m(5), 0.0, m(4)),
            );
            o += r * dp;
            r *= dr;
        }
    }
    (vs, ws)
}

/// Linear and angular velocities of a sampled motion, one vector per interval.
pub type VelocityPairs = (Vec<Vector3<f64>>, Vec<Vector3<f64>>);

/// Spatial twists of a pose trajectory sampled every `dt` s: `(v_t, ω_t) = log(T_{t+1} T_t⁻¹)/dt`,
/// so that `T_{t+1} = exp((ω_t, v_t) dt) T_t` exactly. `N` poses give `N − 1` twists.
pub fn spatial_twists_from_poses(
    p: &[Vector3<f64>],
    r: &[Rotation3<f64>],
    dt: f64,
) -> Result<VelocityPairs> {
    check_dim("orientations vs positions", p.len(), r.len())?;
    if !(dt > 0.0) || !dt.is_finite() {
        return Err(crate::error::invalid("dt", "must be finite and > 0"));
    }
    if p.len() < 2 {
        return Err(MotionError::TooFewSamples {
            what: "pose trajectory".into(),
            needed: 2,
            got: p.len(),
        });
    }
    Ok((0..p.len() - 1)
        .map(|i| {
            let dr = r[i + 1] * r[i].inverse();
            let (w, v) = se3_log(&dr, &(p[i + 1] - dr * p[i]));
            (v / dt, w / dt)
        })
        .unzip())
}

/// Poses from spatial twists: `T_{t+1} = exp((ω_t, v_t) dt) T_t` from `(p0, r0)`; `N` twists give
/// `N + 1` poses.
pub fn poses_from_spatial_twists(
    v: &[Vector3<f64>],
    w: &[Vector3<f64>],
    dt: f64,
    p0: Vector3<f64>,
    r0: Rotation3<f64>,
) -> (Vec<Vector3<f64>>, Vec<Rotation3<f64>>) {
    let mut p = vec![p0];
    let mut r = vec![r0];
    for (vv, ww) in v.iter().zip(w) {
        let (dr, dp) = se3_exp(&(ww * dt), &(vv * dt));
        let np = dr * p[p.len() - 1] + dp;
        let nr = dr * r[r.len() - 1];
        p.push(np);
        r.push(nr);
    }
    (p, r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn se3_log_inverts_exp() {
        for (w, v) in [
            (Vector3::new(0.3, -0.2, 1.1), Vector3::new(1.0, 2.0, -0.5)),
            (Vector3::new(1e-8, 0.0, 0.0), Vector3::new(0.0, 0.1, 0.0)),
        ] {
            let (r, t) = se3_exp(&w, &v);
            let (w2, v2) = se3_log(&r, &t);
            let (ew, ev) = ((w - w2).norm(), (v - v2).norm());
            assert!(ew < 1e-12 && ev < 1e-12, "{ew:e} {ev:e}");
        }
    }

    #[test]
    fn constant_screw_motion_has_constant_invariants() {
        // Rotation about the axis through (1, 2, 0) along z with pitch 0.5 m/rad, ω = 2 rad/s:
        // d¹_ω = 2, d¹_v = 1, every ISA-motion invariant 0 (the ISA does not move).
        let dt = 0.01;
        let c = Vector3::new(1.0, 2.0, 0.0);
        let w = Vector3::new(0.0, 0.0, 2.0);
        let vo = w * 0.5 - w.cross(&c);
        let ds = ds_invariants(&vec![vo; 50], &vec![w; 50], dt).expect("ds");
        for r in &ds.rows {
            assert!(
                (r[0] - 2.0).abs() < 1e-12 && (r[3] - 1.0).abs() < 1e-12,
                "{r:?}"
            );
            assert!(
                r[1].abs() < 1e-12 && r[2].abs() < 1e-12 && r[4].abs() < 1e-12,
                "{r:?}"
            );
        }
        // The ISA passes through c: the origin is on it.
        assert!((ds.origin0 - c).cross(&ds.frame0.column(0)).norm() < 1e-12);
    }

    #[test]
    fn pure_translation_is_efs_of_v() {
        let dt = 0.01;
        let v: Vec<_> = (0..200)
            .map(|i| {
                let t = i as f64 * dt;
                Vector3::new(t.cos(), t.sin(), 0.3)
            })
            .collect();
        let w = vec![Vector3::zeros(); 200];
        let ds = ds_invariants(&v, &w, dt).expect("ds");
        let e = efs_signal(&v, dt).expect("efs");
        for (a, b) in ds.rows.iter().zip(&e.rows) {
            assert_eq!([a[3], a[1], a[2]], *b);
        }
        let (rv, rw) = ds_reconstruct(&ds, dt);
        assert!(rw.iter().all(|x| x.norm() == 0.0));
        let err = rv
            .iter()
            .zip(&v)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        assert!(err < 1e-3, "{err}");
    }

    #[test]
    fn poses_round_trip_through_spatial_twists() {
        let dt = 0.02;
        let p: Vec<_> = (0..50)
            .map(|i| {
                let t = i as f64 * dt;
                Vector3::new(t.cos(), (2.0 * t).sin(), t)
            })
            .collect();
        let r: Vec<_> = (0..50)
            .map(|i| {
                let t = i as f64 * dt;
                Rotation3::from_euler_angles(t, 0.5 * t * t, -t)
            })
            .collect();
        let (v, w) = spatial_twists_from_poses(&p, &r, dt).expect("twists");
        let (p2, r2) = poses_from_spatial_twists(&v, &w, dt, p[0], r[0]);
        for i in 0..50 {
            assert!((p[i] - p2[i]).norm() < 1e-12);
            assert!((r[i].matrix() - r2[i].matrix()).norm() < 1e-12);
        }
    }
}
