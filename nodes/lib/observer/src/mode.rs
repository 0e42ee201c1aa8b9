//! Far / interaction with hysteresis and α_h (thesis Sec. 5.1.3, eq. 5.3): 0.3 m/s far,
//! 0.1 m/s interaction, 0 after a stop gesture or the spoken `stop` until a `come` gesture or
//! the spoken `repeat`.
//!
//! Interaction starts at once when the body comes closer than `interaction_enter_m` (or the
//! distance becomes unknown: fail closed), and ends only when the body has stayed further
//! than `interaction_leave_m` for `interaction_dwell_s`: slowing down is never delayed,
//! speeding up waits until the person has clearly gone. Without the dwell, any signal that
//! spends time inside the hysteresis band and has excursions of more than the band's width
//! (10 cm) — see `README.md`, "Mode flicker" — switches α_h back and forth many times a second.

use serde::{Deserialize, Serialize};

use crate::error::{ObserverError, Result, check};

/// Far or interaction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Nobody close: nominal speed.
    Far,
    /// A person is close: reduced speed.
    Interaction,
}

impl Mode {
    /// `far` / `interaction`.
    pub fn as_str(self) -> &'static str {
        match self {
            Mode::Far => "far",
            Mode::Interaction => "interaction",
        }
    }
}

/// Thresholds and speeds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModeConfig {
    /// Interaction starts when the body comes closer to the robot than this, m.
    pub interaction_enter_m: f64,
    /// Interaction ends when the body is further than this (> enter: hysteresis), m.
    pub interaction_leave_m: f64,
    /// ... for at least this long without interruption (and with the distance known), s.
    pub interaction_dwell_s: f64,
    /// α_h with nobody close, m/s.
    pub far_speed: f64,
    /// α_h while interacting, m/s.
    pub interaction_speed: f64,
    /// Gesture labels that stop the robot.
    pub stop_gestures: Vec<String>,
    /// Gesture labels that release a stop.
    pub resume_gestures: Vec<String>,
    /// Spoken words (`/speech_command`) that stop the robot.
    pub stop_words: Vec<String>,
    /// Spoken words that release a stop.
    pub resume_words: Vec<String>,
}

impl Default for ModeConfig {
    fn default() -> Self {
        Self {
            interaction_enter_m: 0.8,
            interaction_leave_m: 0.9,
            interaction_dwell_s: 1.0,
            far_speed: 0.3,
            interaction_speed: 0.1,
            stop_gestures: vec!["stop".into()],
            resume_gestures: vec!["come".into()],
            stop_words: vec!["stop".into()],
            resume_words: vec!["repeat".into()],
        }
    }
}

impl ModeConfig {
    /// Rejects NaN, negative values, leave ≤ enter and interaction speed above far speed.
    pub fn validate(&self, place: &str) -> Result<()> {
        check(&format!("{place}interaction_enter_m"), self.interaction_enter_m, 0.0, 20.0, "must be in [0, 20] m")?;
        check(&format!("{place}interaction_leave_m"), self.interaction_leave_m, self.interaction_enter_m, 20.0, "must be in [interaction_enter_m, 20] m")?;
        check(&format!("{place}interaction_dwell_s"), self.interaction_dwell_s, 0.0, 60.0, "must be in [0, 60] s")?;
        check(&format!("{place}far_speed"), self.far_speed, 0.0, 2.0, "must be in [0, 2] m/s")?;
        check(&format!("{place}interaction_speed"), self.interaction_speed, 0.0, self.far_speed, "must be in [0, far_speed] m/s")?;
        for (name, list) in [
            ("stop_gestures", &self.stop_gestures),
            ("resume_gestures", &self.resume_gestures),
            ("stop_words", &self.stop_words),
            ("resume_words", &self.resume_words),
        ] {
            if list.iter().any(|w| w.trim().is_empty()) {
                return Err(ObserverError::InvalidParameter { name: format!("{place}{name}"), value: f64::NAN, expected: "no empty word" });
            }
        }
        Ok(())
    }
}

/// What stopped the robot.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StopCause {
    /// A gesture with this label.
    Gesture(String),
    /// A spoken word.
    Speech(String),
}

/// The far/interaction state machine and the stop latch.
#[derive(Clone, Debug)]
pub struct SpeedGovernor {
    config: ModeConfig,
    mode: Mode,
    stopped: Option<StopCause>,
    /// Since when (s) the distance has been beyond `interaction_leave_m` while interacting.
    clear_since: Option<f64>,
}

impl SpeedGovernor {
    /// Starts far, not stopped.
    pub fn new(config: ModeConfig) -> Result<Self> {
        config.validate("mode.")?;
        Ok(Self { config, mode: Mode::Far, stopped: None, clear_since: None })
    }

    /// The configuration.
    pub fn config(&self) -> &ModeConfig {
        &self.config
    }

    /// Feeds the minimum body–robot distance at time `t` (s; `None`: unknown → interaction,
    /// fail closed). Returns the mode. Times may come slightly out of order (frame stamps and
    /// ticks); a `t` before the start of the current clear run never ends it.
    pub fn on_distance(&mut self, distance: Option<f64>, t: f64) -> Mode {
        let c = &self.config;
        match (self.mode, distance.filter(|d| d.is_finite())) {
            (_, None) => {
                self.mode = Mode::Interaction;
                self.clear_since = None;
            }
            (Mode::Far, Some(d)) if d < c.interaction_enter_m => {
                self.mode = Mode::Interaction;
                self.clear_since = None;
            }
            (Mode::Far, Some(_)) => {}
            (Mode::Interaction, Some(d)) if d > c.interaction_leave_m => {
                let since = *self.clear_since.get_or_insert(t);
                if t - since >= c.interaction_dwell_s {
                    self.mode = Mode::Far;
                    self.clear_since = None;
                }
            }
            (Mode::Interaction, Some(_)) => self.clear_since = None,
        }
        self.mode
    }

    /// Nobody tracked any more (every person silent for longer than the tracker's timeout):
    /// far at once (the stop latch is kept).
    pub fn on_nobody(&mut self) {
        self.mode = Mode::Far;
        self.clear_since = None;
    }

    /// A recognised gesture; returns true when it changed the stop latch.
    pub fn on_gesture(&mut self, label: &str) -> bool {
        if self.config.stop_gestures.iter().any(|g| g == label) {
            let was = self.stopped.is_some();
            self.stopped = Some(StopCause::Gesture(label.to_owned()));
            !was
        } else if self.config.resume_gestures.iter().any(|g| g == label) {
            self.stopped.take().is_some()
        } else {
            false
        }
    }

    /// A spoken command (any case, surrounding blanks ignored); returns true when it changed
    /// the stop latch. Other words are ignored.
    pub fn on_speech(&mut self, words: &str) -> bool {
        let w = words.trim().to_lowercase();
        if self.config.stop_words.iter().any(|s| s.to_lowercase() == w) {
            let was = self.stopped.is_some();
            self.stopped = Some(StopCause::Speech(w));
            !was
        } else if self.config.resume_words.iter().any(|s| s.to_lowercase() == w) {
            self.stopped.take().is_some()
        } else {
            false
        }
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The stop in force, if any.
    pub fn stopped(&self) -> Option<&StopCause> {
        self.stopped.as_ref()
    }

    /// α_h (m/s) with `present` people: 0 when stopped, the interaction speed while
    /// interacting, else the far speed.
    pub fn speed(&self, present: bool) -> f64 {
        if self.stopped.is_some() {
            0.0
        } else if present && self.mode == Mode::Interaction {
            self.config.interaction_speed
        } else {
            self.config.far_speed
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hysteresis_and_the_stop_latch() {
        let mut g = SpeedGovernor::new(ModeConfig { interaction_dwell_s: 0.0, ..Default::default() }).expect("governor");
        assert_eq!(g.on_distance(Some(1.0), 0.0), Mode::Far);
        assert_eq!(g.on_distance(Some(0.79), 0.1), Mode::Interaction);
        assert_eq!(g.on_distance(Some(0.85), 0.2), Mode::Interaction);
        assert_eq!(g.on_distance(Some(0.91), 0.3), Mode::Far);
        assert_eq!(g.on_distance(Some(0.85), 0.4), Mode::Far);
        assert_eq!(g.speed(true), 0.3);
        assert_eq!(g.on_distance(None, 0.5), Mode::Interaction, "unknown distance fails closed");
        assert_eq!(g.on_distance(Some(f64::NAN), 0.6), Mode::Interaction);
        assert_eq!(g.speed(true), 0.1);
        assert!(g.on_gesture("stop"));
        assert_eq!(g.speed(true), 0.0);
        assert!(!g.on_speech("repeatedly"));
        assert!(!g.on_gesture("handover_right"));
        assert_eq!(g.speed(false), 0.0);
        assert!(g.on_speech(" Repeat\n"));
        assert_eq!(g.speed(true), 0.1);
        assert!(g.on_speech("STOP"));
        assert!(g.on_gesture("come"));
        assert!(g.stopped().is_none());
    }

    #[test]
    fn interaction_ends_only_after_the_dwell_and_starts_at_once() {
        let mut g = SpeedGovernor::new(ModeConfig::default()).expect("governor");
        assert_eq!(g.on_distance(Some(0.7), 0.0), Mode::Interaction, "slowing down is immediate");
        // Clear for 0.9 s, then back inside the band: the clear run starts again.
        for k in 0..=9 {
            assert_eq!(g.on_distance(Some(0.95), 0.1 + 0.1 * k as f64), Mode::Interaction);
        }
        assert_eq!(g.on_distance(Some(0.85), 1.05), Mode::Interaction);
        assert_eq!(g.on_distance(Some(0.95), 1.1), Mode::Interaction);
        assert_eq!(g.on_distance(Some(0.95), 1.5), Mode::Interaction);
        assert_eq!(g.on_distance(Some(0.95), 0.5), Mode::Interaction, "a time before the run does not end it");
        assert_eq!(g.on_distance(Some(0.95), 2.05), Mode::Interaction);
        assert_eq!(g.on_distance(Some(0.95), 2.1), Mode::Far, "clear for 1.0 s");
        assert_eq!(g.on_distance(Some(0.79), 2.2), Mode::Interaction);
        assert_eq!(g.on_distance(None, 2.3), Mode::Interaction);
        assert_eq!(g.on_distance(Some(2.0), 2.4), Mode::Interaction, "unknown distance restarts the clear run");
        g.on_nobody();
        assert_eq!(g.mode(), Mode::Far, "nobody: far at once");
    }

    #[test]
    fn bad_configs_are_rejected() {
        let c = ModeConfig { interaction_dwell_s: -0.1, ..Default::default() };
        assert!(SpeedGovernor::new(c).is_err());
        let c = ModeConfig { interaction_leave_m: 0.5, ..Default::default() };
        assert!(SpeedGovernor::new(c).is_err());
        let c = ModeConfig { interaction_speed: 0.5, ..Default::default() };
        assert!(SpeedGovernor::new(c).is_err());
        let c = ModeConfig { far_speed: f64::NAN, ..Default::default() };
        assert!(SpeedGovernor::new(c).is_err());
    }
}
