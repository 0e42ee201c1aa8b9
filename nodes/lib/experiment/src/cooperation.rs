//! Judging the cooperative stacking of Sec. 5.1.3 (`gestures-hri`): how the robot reacted to
//! each gesture the human observer recognised, from what the simulated world did (tool speed
//! from `/lwr/world`, where the handed-over block was released against the person's true
//! hand), not from what was commanded.
//!
//! Times are simulated seconds on the graph's clock unless named `*_s` in a result, which are
//! relative to the trial's start.

use nalgebra::{Isometry3, Point3, Vector3};
use serde::{Deserialize, Serialize};

use crate::judge::Series;
use crate::sequencer::HandoverLog;

/// A `stop` must bring the tool to rest within this time of its recognition (s; the thesis's
/// α_h = 0, the 0.5 s).
pub const STOP_REACTION_S: f64 = 0.5;
/// Tool speed under which the robot counts as at rest (m/s).
pub const AT_REST_M_S: f64 = 0.01;
/// Tool speed over which the robot counts as moving again after a `come` (m/s).
pub const MOVING_M_S: f64 = 0.02;
/// A `come` must set the robot moving within this time of its recognition (s).
pub const COME_REACTION_S: f64 = 2.0;
/// The handed-over block must be released within this distance of the person's hand (m:
/// from the middle of the true right hand to the block's box).
pub const RELEASE_MAX_DISTANCE_M: f64 = 0.05;
/// A recognition is matched to a performed gesture of the same label whose end lies within
/// this window around it (s).
const MATCH_WINDOW_S: f64 = 3.0;

/// A gesture the scripted person performed (trial time, s).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Performed {
    /// `cowork_msgs/Gesture` label.
    pub label: String,
    /// Start and end of the gesture (s, trial time).
    pub start_s: f64,
    /// End (s, trial time).
    pub end_s: f64,
}

/// Where a handed-over object was released.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Release {
    /// The object.
    pub object: String,
    /// Time the gripper was opened (s, simulated).
    pub t: f64,
    /// Distance from the middle of the person's true right hand to the object's box (m).
    pub distance_to_hand_m: f64,
    /// The true hand (base frame, m).
    pub hand: [f64; 3],
    /// The object's centre (base frame, m).
    pub object_centre: [f64; 3],
}

/// How the robot reacted to one gesture (a recognised one, or a performed one that was never
/// recognised).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GestureReaction {
    /// `come`, `stop`, `handover_right`.
    pub label: String,
    /// End of the matching performed gesture (s, trial time); `None`: the observer reported a
    /// gesture nobody performed.
    pub performed_end_s: Option<f64>,
    /// When the observer reported it (s, trial time); `None`: performed, never recognised.
    pub recognised_s: Option<f64>,
    /// Reaction time after the recognition (s): `stop` → tool at rest (< 1 cm/s); `come` →
    /// tool moving (> 2 cm/s); `handover_right` → motion towards the hand commanded (it waits
    /// for the grasp when it comes before).
    pub reaction_s: Option<f64>,
    /// `stop`: fastest tool speed from 0.5 s after the recognition until the next `come` (m/s).
    pub held_max_speed_m_s: Option<f64>,
    /// `handover_right`: release distance to the hand (m).
    pub release_distance_m: Option<f64>,
    /// A second report of a gesture already reported within 3 s (not a new command).
    pub repeat: bool,
    /// Acted on as Sec. 5.1.3 requires.
    pub acted: bool,
    /// What was wrong, if anything.
    pub note: String,
}

/// The performed gestures of a timeline's spans, shifted to trial time.
pub fn performed(people: &cowork_people::Timeline) -> Vec<Performed> {
    people
        .spans()
        .iter()
        .filter_map(|s| match s.span.kind {
            cowork_people::SpanKind::Gesture(k) => Some(Performed {
                label: k.label().to_owned(),
                start_s: s.span.start,
                end_s: s.span.end,
            }),
            _ => None,
        })
        .collect()
}

/// Distance from `hand` to the box of half sizes `half` at `pose` (m, 0 inside).
pub fn point_box_distance(hand: &Point3<f64>, pose: &Isometry3<f64>, half: &Vector3<f64>) -> f64 {
    let local = pose.inverse_transform_point(hand);
    let outside = Vector3::new(
        (local.x.abs() - half.x).max(0.0),
        (local.y.abs() - half.y).max(0.0),
        (local.z.abs() - half.z).max(0.0),
    );
    outside.norm()
}

fn first_after(series: &[(f64, f64)], t: f64, pred: impl Fn(f64) -> bool) -> Option<f64> {
    series.iter().find(|(s, v)| *s >= t && pred(*v)).map(|(s, _)| *s)
}

/// Reactions to every gesture: each recognised one (matched to a performed one of the same
/// label, or flagged as never performed) and each performed one never recognised. `t0` is the
/// simulated time of the trial's start; `end` the last simulated time judged.
pub fn reactions(
    series: &Series,
    t0: f64,
    end: f64,
    performed: &[Performed],
    handovers: &[HandoverLog],
    releases: &[Release],
) -> Vec<GestureReaction> {
    let speed = &series.tool_speed;
    let mut out: Vec<GestureReaction> = Vec::new();
    let mut matched = vec![false; performed.len()];
    for (k, (tg, label)) in series.gestures.iter().enumerate() {
        let rel = tg - t0;
        let repeat = series.gestures[..k]
            .iter()
            .any(|(s, l)| l == label && tg - s <= MATCH_WINDOW_S);
        let m = performed
            .iter()
            .enumerate()
            .filter(|(_, p)| p.label == *label && (rel - p.end_s).abs() <= MATCH_WINDOW_S)
            .min_by(|a, b| {
                (rel - a.1.end_s)
                    .abs()
                    .total_cmp(&(rel - b.1.end_s).abs())
            });
        if let Some((i, _)) = m {
            matched[i] = true;
        }
        let mut r = GestureReaction {
            label: label.clone(),
            performed_end_s: m.map(|(_, p)| p.end_s),
            recognised_s: Some(rel),
            reaction_s: None,
            held_max_speed_m_s: None,
            release_distance_m: None,
            repeat,
            acted: false,
            note: String::new(),
        };
        match label.as_str() {
            "stop" => {
                r.reaction_s = first_after(speed, *tg, |v| v < AT_REST_M_S).map(|s| s - tg);
                let until = series
                    .gestures
                    .iter()
                    .find(|(s, l)| s > tg && l == "come")
                    .map_or(end, |c| c.0);
                r.held_max_speed_m_s = speed
                    .iter()
                    .filter(|(s, _)| *s >= tg + STOP_REACTION_S && *s < until)
                    .map(|(_, v)| *v)
                    .reduce(f64::max);
                let fast = r.reaction_s.is_some_and(|x| x <= STOP_REACTION_S);
                let held = r.held_max_speed_m_s.is_none_or(|v| v < AT_REST_M_S);
                r.acted = fast && held;
                if !fast {
                    r.note = format!(
                        "not at rest within {STOP_REACTION_S} s (at rest after {})",
                        r.reaction_s.map_or("never".into(), |x| format!("{x:.2} s"))
                    );
                } else if !held {
                    r.note = format!(
                        "moved at {:.3} m/s while stopped",
                        r.held_max_speed_m_s.unwrap_or_default()
                    );
                }
            }
            "come" => {
                r.reaction_s = first_after(speed, *tg, |v| v > MOVING_M_S).map(|s| s - tg);
                r.acted = r.reaction_s.is_some_and(|x| x <= COME_REACTION_S);
                if !r.acted {
                    r.note = format!("not moving within {COME_REACTION_S} s");
                }
            }
            "handover_right" => {
                let h = handovers.iter().find(|h| (h.gesture_t - tg).abs() < 1e-9);
                r.reaction_s = h.map(|h| h.commanded_t - tg);
                r.release_distance_m = h.and_then(|h| {
                    releases
                        .iter()
                        .find(|x| x.object == h.object && x.t >= h.commanded_t)
                        .map(|x| x.distance_to_hand_m)
                });
                r.acted = r
                    .release_distance_m
                    .is_some_and(|d| d <= RELEASE_MAX_DISTANCE_M);
                if h.is_none() {
                    r.note = if repeat {
                        "repeat of a handover already acted on".into()
                    } else {
                        "no handover commanded".into()
                    };
                } else if let Some(d) = r.release_distance_m.filter(|_| !r.acted) {
                    r.note = format!("released {d:.3} m from the hand");
                } else if r.release_distance_m.is_none() {
                    r.note = "never released".into();
                }
            }
            _ => r.note = "unknown gesture".into(),
        }
        if r.performed_end_s.is_none() && r.note.is_empty() {
            r.note = "not performed (false recognition)".into();
        }
        out.push(r);
    }
    for (p, _) in performed.iter().zip(&matched).filter(|(_, m)| !**m) {
        out.push(GestureReaction {
            label: p.label.clone(),
            performed_end_s: Some(p.end_s),
            recognised_s: None,
            reaction_s: None,
            held_max_speed_m_s: None,
            release_distance_m: None,
            repeat: false,
            acted: false,
            note: "performed, never recognised".into(),
        });
    }
    out
}

/// Why a trial's gestures were not all acted on (empty when they were): every performed
/// gesture must be recognised and acted on; repeats and false recognitions are reported in
/// the table but only fail the trial when they made the robot do something wrong (a false
/// `stop` that did not hold, a handover nobody asked for).
pub fn failures(reactions: &[GestureReaction]) -> Vec<String> {
    reactions
        .iter()
        .filter(|r| !r.acted && !r.repeat)
        .filter(|r| r.performed_end_s.is_some() || r.label != "come")
        .map(|r| {
            format!(
                "{} {}: {}",
                r.label,
                r.recognised_s
                    .or(r.performed_end_s)
                    .map_or(String::new(), |t| format!("at {t:.1} s")),
                r.note
            )
        })
        .collect()
}

/// Latency in the graph as the runner sees it over loopback DDS, on the simulated clock (at
/// `--rate 1` simulated = wall time; the clock ticks at lwr_sim's 1 kHz, so values carry ±1 ms):
/// depth frame stamp → `/fded/distances` arrival; that arrival → the next
/// `/lwr/joint_velocity_command` (ds_controller runs at 1 kHz and takes the newest distances at
/// its next step, so this is the step plus the command's trip); skeleton frame published →
/// the next `/human/state` arrival → the next joint command.
#[derive(Debug, Clone, Default)]
pub struct Latency {
    /// Depth stamp → distances arrival (s).
    pub depth_to_distances: Vec<f64>,
    /// Distances arrival → next joint command (s).
    pub distances_to_command: Vec<f64>,
    /// Skeleton published → next human state (s).
    pub skeleton_to_state: Vec<f64>,
    /// Human state arrival → next joint command (s).
    pub state_to_command: Vec<f64>,
    pending_distances: Option<f64>,
    pending_skeleton: Option<f64>,
    pending_state: Option<f64>,
}

impl Latency {
    /// `/fded/distances` of depth stamp `stamp` arrived at `now` (s).
    pub fn on_distances(&mut self, stamp: f64, now: f64) {
        if (now - stamp).is_finite() && now >= stamp {
            self.depth_to_distances.push(now - stamp);
        }
        self.pending_distances.get_or_insert(now);
    }
    /// A skeleton frame was published at `now`.
    pub fn on_skeleton(&mut self, now: f64) {
        self.pending_skeleton.get_or_insert(now);
    }
    /// `/human/state` arrived at `now`.
    pub fn on_state(&mut self, now: f64) {
        if let Some(t) = self.pending_skeleton.take() {
            self.skeleton_to_state.push(now - t);
        }
        self.pending_state.get_or_insert(now);
    }
    /// A joint command arrived at `now`.
    pub fn on_command(&mut self, now: f64) {
        if let Some(t) = self.pending_distances.take() {
            self.distances_to_command.push(now - t);
        }
        if let Some(t) = self.pending_state.take() {
            self.state_to_command.push(now - t);
        }
    }
}
