//! View- and size-normalised hand trajectories, a simple descriptor for gesture recognition.

use cowork_msgs::msg::Skeleton;
use nalgebra::{Point3, Quaternion, UnitQuaternion, Vector3};

use crate::error::{PeopleError, Result};
use crate::pose::{Segment, Side};

fn point(msg: &Skeleton, s: Segment) -> Result<Point3<f64>> {
    let p = msg.segment(s.name()).ok_or_else(|| PeopleError::MissingSegment { name: s.name().to_owned() })?;
    Ok(Point3::new(p.position.x, p.position.y, p.position.z))
}

fn orientation(msg: &Skeleton, s: Segment) -> Result<UnitQuaternion<f64>> {
    let p = msg.segment(s.name()).ok_or_else(|| PeopleError::MissingSegment { name: s.name().to_owned() })?;
    let o = &p.orientation;
    let q = Quaternion::new(o.w, o.x, o.y, o.z);
    let n = q.norm();
    if n.is_nan() || n <= 1e-6 {
        return Err(PeopleError::Malformed { reason: format!("degenerate {} orientation", s.name()) });
    }
    Ok(UnitQuaternion::from_quaternion(q))
}

/// The hand of `side` relative to the sternum, in the sternum frame (x forward, y left, z up),
/// divided by the mean upper-arm + forearm length measured in the messages: one row per
/// message. Invariant to where the person stands, which way they face and (to first order)
/// their size.
pub fn hand_relative_to_sternum(msgs: &[Skeleton], side: Side) -> Result<Vec<Vector3<f64>>> {
    let [sh, el, wr, ha] = Segment::arm(side);
    let mut arm = 0.0;
    let mut rows = Vec::with_capacity(msgs.len());
    for m in msgs {
        let (s, e, w) = (point(m, sh)?, point(m, el)?, point(m, wr)?);
        arm += (e - s).norm() + (w - e).norm();
        let q = orientation(m, Segment::Sternum)?;
        rows.push(q.inverse() * (point(m, ha)? - point(m, Segment::Sternum)?));
    }
    if msgs.is_empty() {
        return Ok(rows);
    }
    let arm = arm / msgs.len() as f64;
    if !arm.is_finite() || arm <= 1e-6 {
        return Err(PeopleError::Malformed { reason: "arm length is zero or not finite".into() });
    }
    for r in rows.iter_mut() {
        *r /= arm;
    }
    Ok(rows)
}

/// `rows` resampled to `n` rows by linear interpolation over the row index (n ≥ 2, rows
/// non-empty), flattened row-major for DTW.
pub fn resample_flat(rows: &[Vector3<f64>], n: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(3 * n);
    if rows.is_empty() || n == 0 {
        return out;
    }
    for i in 0..n {
        let x = if n > 1 { i as f64 * (rows.len() - 1) as f64 / (n - 1) as f64 } else { 0.0 };
        let j = (x.floor() as usize).min(rows.len() - 1);
        let k = (j + 1).min(rows.len() - 1);
        let f = x - j as f64;
        let v = rows[j] * (1.0 - f) + rows[k] * f;
        out.extend_from_slice(&[v.x, v.y, v.z]);
    }
    out
}
