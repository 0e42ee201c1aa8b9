//! Smooth Cartesian paths (minimum-jerk segments) and the "teacher" that turns them into the
//! wrench a person would apply to a gravity-compensated arm (eq. 4.6 inverted: `f = v / c`).

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// Desired tool state at one instant, base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathSample {
    /// Pose of the tool.
    pub pose: Isometry3<f64>,
    /// Linear velocity, m/s.
    pub linear: Vector3<f64>,
    /// Angular velocity, rad/s.
    pub angular: Vector3<f64>,
}

#[derive(Debug, Clone)]
struct Segment {
    t0: f64,
    duration: f64,
    from: Isometry3<f64>,
    to: Isometry3<f64>,
    /// Rotation from `from` to `to` as a scaled axis in the base frame, rad.
    rotation: Vector3<f64>,
}

/// A piecewise path of minimum-jerk segments between poses, each at rest at its ends.
#[derive(Debug, Clone)]
pub struct CartesianPath {
    start: Isometry3<f64>,
    segments: Vec<Segment>,
}

/// Minimum-jerk time scaling `s(τ) = 10τ³ − 15τ⁴ + 6τ⁵` and its derivative `ds/dτ`.
pub(crate) fn min_jerk(tau: f64) -> (f64, f64) {
    let t = tau.clamp(0.0, 1.0);
    let t2 = t * t;
    let t3 = t2 * t;
    (t3 * (10.0 - 15.0 * t + 6.0 * t2), 30.0 * t2 * (1.0 - 2.0 * t + t2))
}

impl CartesianPath {
    /// A path that starts (at rest) at `start`.
    pub fn new(start: Isometry3<f64>) -> Self {
        Self { start, segments: Vec::new() }
    }

    /// End of the path, s.
    pub fn duration(&self) -> f64 {
        self.segments.last().map_or(0.0, |s| s.t0 + s.duration)
    }

    /// Last pose of the path.
    pub fn end_pose(&self) -> Isometry3<f64> {
        self.segments.last().map_or(self.start, |s| s.to)
    }

    /// Moves to `to` in `duration` s (minimum jerk, shortest rotation).
    pub fn move_to(&mut self, to: Isometry3<f64>, duration: f64) -> &mut Self {
        let from = self.end_pose();
        let rel = to.rotation * from.rotation.inverse();
        self.segments.push(Segment {
            t0: self.duration(),
            duration: duration.max(1e-3),
            from,
            to,
            rotation: rel.scaled_axis(),
        });
        self
    }

    /// Stays still for `duration` s.
    pub fn hold(&mut self, duration: f64) -> &mut Self {
        let here = self.end_pose();
        self.move_to(here, duration)
    }

    /// The desired tool state at `t` s (held at the ends).
    pub fn sample(&self, t: f64) -> PathSample {
        let Some(seg) = self
            .segments
            .iter()
            .find(|s| t < s.t0 + s.duration)
            .or(self.segments.last())
        else {
            return PathSample { pose: self.start, linear: Vector3::zeros(), angular: Vector3::zeros() };
        };
        let (s, ds) = min_jerk((t - seg.t0) / seg.duration);
        let rate = if (0.0..seg.duration).contains(&(t - seg.t0)) { ds / seg.duration } else { 0.0 };
        let dp = seg.to.translation.vector - seg.from.translation.vector;
        let p = seg.from.translation.vector + s * dp;
        let r = UnitQuaternion::from_scaled_axis(seg.rotation * s) * seg.from.rotation;
        PathSample {
            pose: Isometry3::from_parts(Translation3::from(p), r),
            linear: dp * rate,
            angular: seg.rotation * rate,
        }
    }
}

/// A simulated person guiding the tool along a path by pushing it: feed-forward of the path
/// velocity plus a proportional correction of the pose error, divided by the admittance gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Teacher {
    /// Admittance gain `c`, m/(N s) (eq. 4.6).
    pub gain: f64,
    /// Rotational admittance gain, rad/(N m s).
    pub rotational_gain: f64,
    /// Position error correction, 1/s.
    pub kp: f64,
    /// Orientation error correction, 1/s.
    pub kr: f64,
    /// Largest force a person applies, N.
    pub max_force: f64,
    /// Largest torque a person applies, N m.
    pub max_torque: f64,
}

impl Teacher {
    /// Force (N) and torque (N m), base frame, that move the tool from `actual` towards `desired`.
    pub fn wrench(&self, desired: &PathSample, actual: &Isometry3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let dp = desired.pose.translation.vector - actual.translation.vector;
        let dr = (desired.pose.rotation * actual.rotation.inverse()).scaled_axis();
        let v = desired.linear + self.kp * dp;
        let w = desired.angular + self.kr * dr;
        (
            cap(v / self.gain, self.max_force),
            cap(w / self.rotational_gain, self.max_torque),
        )
    }
}

fn cap(v: Vector3<f64>, max: f64) -> Vector3<f64> {
    let n = v.norm();
    if n > max { v * (max / n) } else { v }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_reaches_each_pose_at_rest_and_velocity_integrates_to_displacement() {
        let a = Isometry3::translation(0.5, 0.0, 0.3);
        let b = Isometry3::from_parts(
            Translation3::new(0.6, 0.2, 0.4),
            UnitQuaternion::from_euler_angles(1.0, 0.0, 0.3),
        );
        let mut path = CartesianPath::new(a);
        path.move_to(b, 2.0).hold(1.0);
        assert!((path.duration() - 3.0).abs() < 1e-12);
        let end = path.sample(2.0);
        assert!((end.pose.translation.vector - b.translation.vector).norm() < 1e-9);
        assert!(end.pose.rotation.angle_to(&b.rotation) < 1e-9);
        assert!(end.linear.norm() < 1e-9);
        // Integrate the velocities: they must reproduce the poses.
        let dt = 1e-4;
        let mut p = a.translation.vector;
        let mut r = a.rotation;
        let mut t = 0.0;
        while t < 2.0 {
            let s = path.sample(t + 0.5 * dt);
            p += s.linear * dt;
            r = UnitQuaternion::from_scaled_axis(s.angular * dt) * r;
            t += dt;
        }
        assert!((p - b.translation.vector).norm() < 1e-6, "{p}");
        assert!(r.angle_to(&b.rotation) < 1e-6);
    }
}
