//! Capsules: how bodies of people reach the renderer.

use nalgebra::{Isometry3, Point3};

use crate::error::{Error, Result};

/// A capsule (a segment swept by a sphere): one body segment of a person, e.g. a forearm
/// from elbow to wrist. Points in the robot **base frame**, m.
///
/// `a == b` is allowed and is a sphere (a head, a hand).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capsule {
    /// One end of the axis, base frame, m.
    pub a: Point3<f64>,
    /// The other end of the axis, base frame, m.
    pub b: Point3<f64>,
    /// Radius, m.
    pub radius: f64,
}

impl Capsule {
    /// A capsule from `a` to `b` (base frame, m) of `radius` (m).
    pub fn new(a: Point3<f64>, b: Point3<f64>, radius: f64) -> Self {
        Self { a, b, radius }
    }

    /// Checks that the ends are finite and the radius finite and > 0.
    pub fn validate(&self) -> Result<()> {
        for (name, p) in [("capsule.a", &self.a), ("capsule.b", &self.b)] {
            if !p.coords.iter().all(|c| c.is_finite()) {
                return Err(Error::bad_value(name, format!("{:?}", p.coords.as_slice()), "must be finite"));
            }
        }
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return Err(Error::bad_value("capsule.radius", self.radius, "must be finite and > 0 m"));
        }
        Ok(())
    }

    /// The capsule with its ends mapped through `pose` (e.g. camera ← base).
    pub fn transformed(&self, pose: &Isometry3<f64>) -> Self {
        Self { a: pose * self.a, b: pose * self.b, radius: self.radius }
    }

    /// Distance from `p` (same frame, m) to the capsule surface; negative inside.
    pub fn signed_distance(&self, p: &Point3<f64>) -> f64 {
        let ab = self.b - self.a;
        let len2 = ab.norm_squared();
        let t = if len2 > 0.0 { ((p - self.a).dot(&ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
        (p - (self.a + ab * t)).norm() - self.radius
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validate_and_distance() {
        let c = Capsule::new(Point3::origin(), Point3::new(0.0, 0.0, 1.0), 0.1);
        assert!(c.validate().is_ok());
        assert!((c.signed_distance(&Point3::new(0.3, 0.0, 0.5)) - 0.2).abs() < 1e-12);
        assert!((c.signed_distance(&Point3::new(0.0, 0.0, 1.5)) - 0.4).abs() < 1e-12);
        assert!(c.signed_distance(&Point3::new(0.0, 0.0, 0.5)) < 0.0);
        let bad = Capsule { radius: 0.0, ..c };
        assert!(bad.validate().unwrap_err().to_string().contains("capsule.radius"));
        let bad = Capsule { a: Point3::new(f64::NAN, 0.0, 0.0), ..c };
        assert!(bad.validate().unwrap_err().to_string().contains("capsule.a"));
    }
}
