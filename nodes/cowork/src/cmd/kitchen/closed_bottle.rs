//! The person of `coffee-closed-bottle` (thesis Fig. 5.22): the bottle is closed, so when the
//! robot has carried it over the cup the person says `stop`, opens it while the robot holds
//! still, and says `repeat`; the task must resume where it stopped. Driven by `/lwr/world`,
//! judged from it (the bottle must not move while the robot is stopped) and from the
//! supervisor's `/supervisor/action` (the stop, and the action commanded after `repeat`).

use cowork_msgs::msg::WorldState;
use serde::Serialize;

use super::PERSON_OBJECT;

/// Held bottle within this horizontal distance of the cup's centre: "over the cup", m.
const OVER_CUP_M: f64 = 0.25;
/// How long the person takes to open the bottle (simulated s after `stop`).
const OPEN_S: f64 = 6.0;
/// The robot's time to come to rest after `stop` before stillness is judged, s.
const SETTLE_S: f64 = 1.0;
/// Largest bottle motion allowed while the robot is stopped, m.
pub const STILL_M: f64 = 0.02;

/// What happened around the stop.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SuspendOutcome {
    /// Simulated time `stop` was said, s.
    pub stop_at_s: Option<f64>,
    /// Simulated time `repeat` was said, s.
    pub repeat_at_s: Option<f64>,
    /// The action the supervisor stopped.
    pub stopped_action: Option<String>,
    /// Largest bottle displacement from SETTLE_S after `stop` until `repeat`, m.
    pub drift_while_stopped_m: f64,
    /// The first action commanded after `repeat`, and how long after it, simulated s.
    pub resumed_with: Option<String>,
    /// `repeat` → that action command, simulated s.
    pub resume_latency_s: Option<f64>,
}

impl SuspendOutcome {
    /// Why the suspension failed (empty when the robot stopped, held still and resumed).
    pub fn verdict(&self) -> Vec<String> {
        let mut why = Vec::new();
        if self.stop_at_s.is_none() {
            why.push("the robot never carried the bottle over the cup (no `stop` said)".to_owned());
            return why;
        }
        if self.stopped_action.is_none() {
            why.push("the supervisor stopped no action on `stop`".to_owned());
        }
        if self.drift_while_stopped_m > STILL_M {
            why.push(format!("the bottle moved {:.3} m while the robot was stopped", self.drift_while_stopped_m));
        }
        if self.resumed_with.is_none() {
            why.push("no action commanded after `repeat`".to_owned());
        }
        why
    }
}

/// The person's script.
#[derive(Debug, Default)]
pub struct Suspender {
    /// Bottle position when stillness starts being judged.
    still_from: Option<[f64; 3]>,
    /// The result.
    pub outcome: SuspendOutcome,
}

impl Suspender {
    /// At world report `w` (simulated `now`): what the person says, if anything.
    pub fn step(&mut self, w: &WorldState, now: f64) -> Option<&'static str> {
        let find = |n: &str| w.objects.iter().find(|o| o.name == n);
        let bottle = find(PERSON_OBJECT.0).map(|b| [b.pose.position.x, b.pose.position.y, b.pose.position.z]);
        match (self.outcome.stop_at_s, self.outcome.repeat_at_s) {
            (None, _) => {
                let (Some(b), Some(c)) = (bottle, find("cup")) else { return None };
                let over = (b[0] - c.pose.position.x).hypot(b[1] - c.pose.position.y) < OVER_CUP_M;
                (w.held_object == PERSON_OBJECT.0 && over).then(|| {
                    self.outcome.stop_at_s = Some(now);
                    "stop"
                })
            }
            (Some(stop), None) => {
                if now - stop >= SETTLE_S
                    && let Some(b) = bottle
                {
                    let from = *self.still_from.get_or_insert(b);
                    let d = ((b[0] - from[0]).powi(2) + (b[1] - from[1]).powi(2) + (b[2] - from[2]).powi(2)).sqrt();
                    self.outcome.drift_while_stopped_m = self.outcome.drift_while_stopped_m.max(d);
                }
                (now - stop >= OPEN_S).then(|| {
                    self.outcome.repeat_at_s = Some(now);
                    "repeat"
                })
            }
            _ => None,
        }
    }

    /// `/supervisor/action` at simulated `t`: the stop, and the first command after `repeat`.
    pub fn on_action(&mut self, t: f64, label: &str, stop: bool) {
        match (self.outcome.stop_at_s, self.outcome.repeat_at_s) {
            (Some(s), None) if stop && t >= s && self.outcome.stopped_action.is_none() => {
                self.outcome.stopped_action = Some(label.to_owned());
            }
            (Some(_), Some(r)) if !stop && t >= r && self.outcome.resumed_with.is_none() => {
                self.outcome.resumed_with = Some(label.to_owned());
                self.outcome.resume_latency_s = Some(t - r);
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cowork_msgs::builtin_interfaces::Time;
    use cowork_msgs::msg::WorldObject;

    fn world(t: f64, bottle: [f64; 3], held: bool) -> WorldState {
        let mut w = WorldState::default();
        w.header.stamp = Time::from_secs_f64(t);
        if held {
            w.held_object = "bottle".into();
        }
        for (name, p) in [("bottle", bottle), ("cup", [0.6, 0.0, 0.05])] {
            let mut o = WorldObject { name: name.into(), ..Default::default() };
            (o.pose.position.x, o.pose.position.y, o.pose.position.z) = (p[0], p[1], p[2]);
            w.objects.push(o);
        }
        w
    }

    #[test]
    fn stop_over_the_cup_then_repeat_after_opening_and_the_resumed_action_is_reported() {
        let mut p = Suspender::default();
        assert_eq!(p.step(&world(1.0, [0.45, 0.35, 0.2], true), 1.0), None, "held, not over the cup");
        assert_eq!(p.step(&world(2.0, [0.6, 0.1, 0.25], false), 2.0), None, "over the cup, not held");
        assert_eq!(p.step(&world(3.0, [0.6, 0.1, 0.25], true), 3.0), Some("stop"));
        p.on_action(3.01, "noa5(cup)", true);
        assert_eq!(p.step(&world(5.0, [0.6, 0.1, 0.25], true), 5.0), None);
        assert_eq!(p.step(&world(9.0, [0.6, 0.105, 0.25], true), 9.0), Some("repeat"));
        assert_eq!(p.step(&world(10.0, [0.6, 0.1, 0.25], true), 10.0), None, "said once");
        p.on_action(9.003, "noa5(cup)", false);
        let o = &p.outcome;
        assert_eq!(o.stopped_action.as_deref(), Some("noa5(cup)"));
        assert_eq!(o.resumed_with.as_deref(), Some("noa5(cup)"));
        assert!((o.resume_latency_s.unwrap() - 0.003).abs() < 1e-9);
        assert!((o.drift_while_stopped_m - 0.005).abs() < 1e-9);
        assert!(o.verdict().is_empty(), "{:?}", o.verdict());
    }

    #[test]
    fn a_bottle_that_keeps_moving_after_stop_fails() {
        let mut p = Suspender::default();
        p.step(&world(3.0, [0.6, 0.1, 0.25], true), 3.0);
        p.on_action(3.01, "noa5(cup)", true);
        p.step(&world(4.5, [0.6, 0.1, 0.25], true), 4.5);
        p.step(&world(5.5, [0.6, 0.2, 0.25], true), 5.5);
        assert!(p.outcome.verdict().iter().any(|w| w.contains("moved 0.100 m")), "{:?}", p.outcome.verdict());
        assert!(Suspender::default().outcome.verdict()[0].contains("no `stop`"));
    }
}
