//! First-order dynamical-system primitives ẋ = f(x − g) (thesis eq. 5.1–5.2).
//!
//! Positions are end-effector positions in the robot base frame (m), velocities in m/s. Every
//! primitive here is globally asymptotically stable at the goal, which modulation and
//! velocity scaling preserve (Sec. 5.1.1).

use nalgebra::Vector3;

/// A first-order DS evaluated at a position for a goal: ẋ = f(x − g).
///
/// Implementations must be allocation-free and return a finite velocity for finite inputs;
/// other primitives (DMP, GMR, C-GMR of `cowork_motion`) plug in by implementing this trait.
pub trait FirstOrderDs {
    /// Desired velocity (m/s, base frame) at position `x` (m) for goal `goal` (m).
    fn velocity(&self, x: &Vector3<f64>, goal: &Vector3<f64>) -> Vector3<f64>;
}

/// A learned, possibly stateful primitive (DMP, GMR-DS, C-GMR of `cowork_motion`), run by
/// [`crate::DsController::step_with_field`] for a [`Primitive::Learned`] command. It lives
/// outside the `Copy` command (it owns its model); the real-time side receives it once per
/// command.
pub trait LearnedField: Send + std::fmt::Debug {
    /// Restarts the internal state (phase, activation) for a motion that begins at `x0`
    /// towards `goal` (m, base frame). Allocation-free.
    fn reset(&mut self, x0: &Vector3<f64>, goal: &Vector3<f64>);

    /// Desired velocity (m/s, base frame) at `x` for `goal` (m), advancing the internal state
    /// by `dt` (s; the controller passes α_h-scaled time, so velocity scaling slows a DMP's
    /// phase too). Allocation-free; a non-finite result holds the robot.
    fn velocity(&mut self, x: &Vector3<f64>, goal: &Vector3<f64>, dt: f64) -> Vector3<f64>;

    /// The link whose origin a null-space motion primitive of this field moves (thesis Sec.
    /// 4.1.1: an elbow path run in the end-effector task's null space), if it has one.
    fn null_space_link(&self) -> Option<usize> {
        None
    }

    /// Desired velocity (m/s, base frame) of that link origin, now at `x` (m), on the clock the
    /// last [`velocity`](Self::velocity) call advanced. Allocation-free; a non-finite result
    /// holds the robot.
    fn null_space_velocity(&mut self, _x: &Vector3<f64>) -> Vector3<f64> {
        Vector3::zeros()
    }
}

/// Linear DS ẋ = k (g − x) (Fig. 5.3–5.6 use k = 2 and k = 3).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Linear {
    /// Gain k (1/s), > 0.
    pub gain: f64,
}

impl FirstOrderDs for Linear {
    fn velocity(&self, x: &Vector3<f64>, goal: &Vector3<f64>) -> Vector3<f64> {
        (goal - x) * self.gain
    }
}

/// Constant-speed DS ẋ = α (g − x)/‖g − x‖ (Sec. 5.1.3), smoothed near the goal as
/// ẋ = α (g − x)/√(‖g − x‖² + r²) so that it is C∞ and converges (it behaves like a linear
/// DS of gain α/r inside radius r and moves at ≈ α beyond a few r).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstantSpeed {
    /// Speed α far from the goal (m/s), > 0.
    pub speed: f64,
    /// Smoothing radius r (m), > 0.
    #[serde(default = "ConstantSpeed::default_smoothing")]
    pub smoothing: f64,
}

impl ConstantSpeed {
    /// Default smoothing radius (m).
    pub const DEFAULT_SMOOTHING: f64 = 0.01;

    fn default_smoothing() -> f64 {
        Self::DEFAULT_SMOOTHING
    }

    /// A constant-speed DS with the default smoothing radius.
    pub fn new(speed: f64) -> Self {
        Self {
            speed,
            smoothing: Self::DEFAULT_SMOOTHING,
        }
    }
}

impl FirstOrderDs for ConstantSpeed {
    fn velocity(&self, x: &Vector3<f64>, goal: &Vector3<f64>) -> Vector3<f64> {
        let e = goal - x;
        let r2 = self.smoothing * self.smoothing;
        e * (self.speed / (e.norm_squared() + r2).sqrt())
    }
}

/// A move in joint space (ours, beyond the thesis): q̇ = k (q_g − q), no joint faster than
/// `max_speed`, times α_h; the link damper, the tool's allowed speed and the joint limits act
/// on it as on every motion. The robot manager unwinds an arm a turned pour left wound up
/// with it (joint 7 on its limit), back to its ready pose, before the next approach.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointMove {
    /// Goal joint positions q_g (rad).
    pub joints: [f64; 7],
    /// Gain k (1/s), > 0.
    pub gain: f64,
    /// Largest joint speed (rad/s), > 0.
    pub max_speed: f64,
}

impl JointMove {
    /// The move reaches its goal when every joint is within this of it (rad).
    pub const TOLERANCE_RAD: f64 = 0.01;
}

/// The primitives a [`crate::ControlInput`] can carry (`Copy`, so the real-time thread can
/// receive it through a mailbox).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum Primitive {
    /// [`Linear`].
    Linear(Linear),
    /// [`ConstantSpeed`].
    ConstantSpeed(ConstantSpeed),
    /// Hold the current position: ẋ = 0 (the robot brakes to rest).
    Hold,
    /// A learned primitive: f is the [`LearnedField`] handed to
    /// [`crate::DsController::step_with_field`] (without one the step faults and holds).
    Learned,
    /// [`JointMove`]: the goal position is the tool's at the goal joints.
    Joints(JointMove),
}

/// For logs: `linear DS (gain 2 1/s)`, `constant-speed DS (0.1 m/s)`, `hold`, `learned
/// primitive`, `joint move (gain 1 1/s, ≤ 0.5 rad/s)`.
impl std::fmt::Display for Primitive {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Primitive::Linear(l) => write!(f, "linear DS (gain {} 1/s)", l.gain),
            Primitive::ConstantSpeed(c) => write!(f, "constant-speed DS ({} m/s)", c.speed),
            Primitive::Hold => f.write_str("hold"),
            Primitive::Learned => f.write_str("learned primitive"),
            Primitive::Joints(j) => write!(f, "joint move (gain {} 1/s, ≤ {} rad/s)", j.gain, j.max_speed),
        }
    }
}

impl Primitive {
    /// The first parameter that is not finite and positive, as `(name, value)`.
    pub fn invalid_parameter(&self) -> Option<(&'static str, f64)> {
        let bad = |v: f64| !(v.is_finite() && v > 0.0);
        match *self {
            Primitive::Linear(l) if bad(l.gain) => Some(("gain", l.gain)),
            Primitive::ConstantSpeed(c) if bad(c.speed) => Some(("speed", c.speed)),
            Primitive::ConstantSpeed(c) if bad(c.smoothing) => Some(("smoothing", c.smoothing)),
            Primitive::Joints(j) if bad(j.gain) => Some(("gain", j.gain)),
            Primitive::Joints(j) if bad(j.max_speed) => Some(("max_speed", j.max_speed)),
            Primitive::Joints(j) => j.joints.iter().find(|v| !v.is_finite()).map(|v| ("joints", *v)),
            _ => None,
        }
    }
}

impl FirstOrderDs for Primitive {
    fn velocity(&self, x: &Vector3<f64>, goal: &Vector3<f64>) -> Vector3<f64> {
        match self {
            Primitive::Linear(l) => l.velocity(x, goal),
            Primitive::ConstantSpeed(c) => c.velocity(x, goal),
            // The field is not part of the `Copy` command; see `LearnedField`.
            // A joint move is not a field over x (see `JointMove`).
            Primitive::Hold | Primitive::Learned | Primitive::Joints(_) => Vector3::zeros(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_points_to_goal_with_gain() {
        let v = Linear { gain: 2.0 }.velocity(&Vector3::new(1.0, 0.0, 0.0), &Vector3::zeros());
        assert_eq!(v, Vector3::new(-2.0, 0.0, 0.0));
    }

    #[test]
    fn constant_speed_far_and_near() {
        let ds = ConstantSpeed::new(0.3);
        let far = ds.velocity(&Vector3::new(1.0, 0.0, 0.0), &Vector3::zeros());
        assert!((far.norm() - 0.3).abs() < 1e-4, "{far}");
        let at = ds.velocity(&Vector3::zeros(), &Vector3::zeros());
        assert_eq!(at, Vector3::zeros());
        // Inside the smoothing radius it is linear with gain α/r.
        let near = ds.velocity(&Vector3::new(1e-5, 0.0, 0.0), &Vector3::zeros());
        assert!((near.x + 1e-5 * 0.3 / 0.01).abs() < 1e-9, "{near}");
    }

    #[test]
    fn invalid_parameters_are_named() {
        assert_eq!(
            Primitive::Linear(Linear { gain: -1.0 }).invalid_parameter(),
            Some(("gain", -1.0))
        );
        assert!(
            Primitive::ConstantSpeed(ConstantSpeed::new(f64::NAN))
                .invalid_parameter()
                .is_some()
        );
        assert_eq!(Primitive::Hold.invalid_parameter(), None);
    }
}
