use serde::{Deserialize, Serialize};

use crate::error::{Result, SimError};

/// Parameters of the simulator (the `lwr_sim: ros__parameters:` block of its YAML file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimParams {
    /// Integration step of simulated time, s (1 kHz, the LWR's FRI rate).
    pub step_s: f64,
    /// A joint velocity command is applied for at most this long, s; then the joints stop
    /// (the robot is held) until a new command arrives.
    pub command_timeout_s: f64,
    /// Admittance gain `c` of eq. 4.6, m/(N s): external force → end-point linear velocity.
    pub admittance_gain: f64,
    /// Rotational admittance gain, rad/(N m s): external torque → angular velocity.
    pub admittance_rotational_gain: f64,
    /// Damping λ of the damped pseudo-inverse used for admittance motion.
    pub admittance_damping: f64,
    /// An external wrench is applied for at most this long after its last message, s.
    pub wrench_timeout_s: f64,
    /// The gripper grasps the nearest graspable object whose surface is at most this far from
    /// the tool point, m.
    pub grasp_reach_m: f64,
    /// Released objects drop onto the table top or the top of the object below them.
    pub drop_released_objects: bool,
    /// Following a joint position target ([`crate::Simulator::set_arm_joint_target`],
    /// imitation teaching): joint velocity = this × (target − position), 1/s, within the joint
    /// speed limits. A target is followed for at most `command_timeout_s` after it was set.
    pub follow_gain: f64,
}

impl Default for SimParams {
    fn default() -> Self {
        Self {
            step_s: 0.001,
            command_timeout_s: 0.1,
            admittance_gain: 0.005,
            admittance_rotational_gain: 0.05,
            admittance_damping: 0.05,
            wrench_timeout_s: 0.1,
            grasp_reach_m: 0.05,
            drop_released_objects: true,
            follow_gain: 20.0,
        }
    }
}

impl SimParams {
    /// Rejects NaN and out-of-range values; `place` names the file for the error message.
    pub fn validate(&self, place: &str) -> Result<()> {
        let positive = [
            ("step_s", self.step_s),
            ("command_timeout_s", self.command_timeout_s),
            ("wrench_timeout_s", self.wrench_timeout_s),
        ];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(bad(place, field, value, "must be a finite number > 0"));
            }
        }
        if self.step_s > 0.1 {
            return Err(bad(place, "step_s", self.step_s, "must be at most 0.1 s"));
        }
        let non_negative = [
            ("admittance_gain", self.admittance_gain),
            ("admittance_rotational_gain", self.admittance_rotational_gain),
            ("admittance_damping", self.admittance_damping),
            ("grasp_reach_m", self.grasp_reach_m),
            ("follow_gain", self.follow_gain),
        ];
        for (field, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(bad(place, field, value, "must be a finite number >= 0"));
            }
        }
        if self.follow_gain > 1000.0 {
            return Err(bad(place, "follow_gain", self.follow_gain, "must be at most 1000 1/s"));
        }
        Ok(())
    }
}

fn bad(place: &str, field: &str, value: f64, reason: &str) -> SimError {
    SimError::BadValue {
        place: place.to_owned(),
        field: field.to_owned(),
        value: value.to_string(),
        reason: reason.to_owned(),
    }
}
