//! Human-aware velocity scaling (thesis eq. 5.3, Sec. 5.1.3): ẋ = α_h f(x) with α_h from the
//! state of the person (far: nominal speed 0.3 m/s, interaction: 0.1 m/s, stopped: 0).

/// Far / interaction, as decided by the human observer from the human–robot distance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HumanMode {
    /// The person is outside the workspace: nominal speed.
    Far,
    /// The person is close: reduced, safe speed.
    Interaction,
}

/// What the controller needs of `/human/state`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HumanState {
    /// A person is tracked. When false the mode is ignored and the robot runs at nominal speed.
    pub present: bool,
    /// Far or interaction.
    pub mode: HumanMode,
    /// A stop gesture or spoken "stop" is in force: α_h = 0 until released.
    pub stopped: bool,
}

impl Default for HumanState {
    fn default() -> Self {
        Self {
            present: false,
            mode: HumanMode::Far,
            stopped: false,
        }
    }
}

/// Speeds of eq. 5.3 / Sec. 5.1.3.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ScalingConfig {
    /// End-effector speed with nobody close (m/s): α_max of eq. 5.3 in speed units.
    pub far_speed: f64,
    /// End-effector speed while a person interacts (m/s): α_min.
    pub interaction_speed: f64,
}

impl Default for ScalingConfig {
    fn default() -> Self {
        Self {
            far_speed: 0.3,
            interaction_speed: 0.1,
        }
    }
}

impl ScalingConfig {
    /// The allowed end-effector speed (m/s) for `human`: far, interaction or 0 when stopped.
    pub fn speed(&self, human: &HumanState) -> f64 {
        if human.stopped {
            0.0
        } else if human.present && human.mode == HumanMode::Interaction {
            self.interaction_speed
        } else {
            self.far_speed
        }
    }

    /// α_h of eq. 5.3 as a ratio in [0, 1]: the allowed speed over the nominal (far) speed. A
    /// primitive designed for the nominal speed (e.g. a constant-speed DS at 0.3 m/s) then
    /// moves at exactly [`speed`](Self::speed).
    pub fn alpha(&self, human: &HumanState) -> f64 {
        self.speed(human) / self.far_speed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thesis_speeds() {
        let c = ScalingConfig::default();
        let mut h = HumanState::default();
        assert_eq!(c.speed(&h), 0.3);
        h.present = true;
        h.mode = HumanMode::Interaction;
        assert_eq!(c.speed(&h), 0.1);
        assert!((c.alpha(&h) - 1.0 / 3.0).abs() < 1e-12);
        h.stopped = true;
        assert_eq!(c.alpha(&h), 0.0);
        // Not present: mode is stale, nominal speed.
        let h = HumanState {
            present: false,
            mode: HumanMode::Interaction,
            stopped: false,
        };
        assert_eq!(c.alpha(&h), 1.0);
    }
}
