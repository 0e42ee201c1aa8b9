//! Executes a task script step by step against `/motion/status` and `/lwr/world`: what to
//! publish next, when a step is done, and why the task failed. No I/O: the runner feeds it
//! messages and publishes what it returns.

use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::{Gesture, MotionCommand, MotionStatus, WorldState};
use cowork_msgs::std_msgs::Header;

use crate::plan::Step;

/// A command for the graph.
#[derive(Debug, Clone, PartialEq)]
pub enum Output {
    /// Publish on `/motion/command`.
    Motion(MotionCommand),
    /// Publish on `/lwr/gripper_command` (`open` / `close`).
    Gripper(&'static str),
}

/// Where the task stands.
#[derive(Debug, Clone, PartialEq)]
pub enum Progress {
    /// Steps remain.
    Running,
    /// Every step finished.
    Done,
    /// A step failed; the reason names it.
    Failed(String),
}

/// A motion command without a status for this long (s, simulated) is sent again (a lost
/// first message while DDS discovery completes).
const RESEND_AFTER_S: f64 = 1.0;
/// A gripper step whose effect is not seen in `/lwr/world` within this time fails (s).
const GRIP_TIMEOUT_S: f64 = 1.0;
/// A handover goal is re-sent when the observed hand has moved more than this from the hand
/// position of the goal in force (m).
pub const HANDOVER_RETARGET_M: f64 = 0.02;
/// The hand is aimed at only while it moves slower than this (m/s, the observer's filtered
/// hand velocity): a hand held out, not one on its way.
pub const HANDOVER_HAND_STILL_M_S: f64 = 0.15;
/// A hand position older than this (s, simulated) is not used for a handover goal: the step
/// waits for a fresh `/human/state` (fail closed: never aim at where a hand used to be).
pub const HANDOVER_HAND_MAX_AGE_S: f64 = 0.3;

/// How one [`Step::Handover`] went: when it was commanded, and where the hand was.
#[derive(Debug, Clone, PartialEq)]
pub struct HandoverLog {
    /// The object handed over.
    pub object: String,
    /// Time of the `handover_right` gesture it acted on (s, simulated).
    pub gesture_t: f64,
    /// Time the first motion towards the hand was sent (s).
    pub commanded_t: f64,
    /// Goals sent (hand + offset, base frame, m), with their times: the first and every
    /// re-target.
    pub goals: Vec<(f64, [f64; 3])>,
}

/// Step-by-step executor of a task script.
#[derive(Debug, Clone)]
pub struct Sequencer {
    steps: Vec<Step>,
    index: usize,
    /// Simulated time the current step started, `None` before it is issued.
    started: Option<f64>,
    /// Last time the current command was sent.
    sent: f64,
    /// Id of the current motion command.
    id: u32,
    /// Whether a status of the current id arrived.
    acknowledged: bool,
    /// (step index, label, start s, end s) of every finished step.
    finished: Vec<(usize, String, f64, f64)>,
    /// Recognised gestures (time s, label), in order of arrival.
    gestures: Vec<(f64, String)>,
    /// Gestures before this index have been used by a wait or a handover.
    gestures_used: usize,
    /// Newest observed right hand (time s, position m and velocity m/s, base frame).
    hand: Option<(f64, [f64; 3], [f64; 3])>,
    /// Goal end-effector avoidance is off for (the running handover's hand + offset).
    handover_goal: Option<[f64; 3]>,
    /// Every handover so far.
    handovers: Vec<HandoverLog>,
}

impl Sequencer {
    /// A sequencer at the first step.
    pub fn new(steps: Vec<Step>) -> Self {
        Self {
            steps,
            index: 0,
            started: None,
            sent: 0.0,
            id: 0,
            acknowledged: false,
            finished: Vec::new(),
            gestures: Vec::new(),
            gestures_used: 0,
            hand: None,
            handover_goal: None,
            handovers: Vec::new(),
        }
    }

    /// A gesture recognised at `t` (s, simulated; `/human/gesture`).
    pub fn on_gesture(&mut self, t: f64, label: &str) {
        self.gestures.push((t, label.to_owned()));
    }

    /// The observed right hand at `t` (s; `/human/state` hand position, m, and velocity, m/s,
    /// base frame). Non-finite values are ignored.
    pub fn on_hand(&mut self, t: f64, position: [f64; 3], velocity: [f64; 3]) {
        if position.iter().chain(&velocity).all(|v| v.is_finite()) {
            self.hand = Some((t, position, velocity));
        }
    }

    /// The goal a handover may aim at now: a fresh, still hand + `offset` within `radius` of
    /// `centre`.
    fn hand_goal(&self, t: f64, offset: &[f64; 3], centre: &[f64; 3], radius: f64) -> Option<[f64; 3]> {
        let (s, p, v) = self.hand?;
        let goal = add(p, *offset);
        (t - s <= HANDOVER_HAND_MAX_AGE_S
            && dist(&v, &[0.0; 3]) < HANDOVER_HAND_STILL_M_S
            && dist(&goal, centre) <= radius)
            .then_some(goal)
    }

    /// The handovers done or running, in order.
    pub fn handovers(&self) -> &[HandoverLog] {
        &self.handovers
    }

    /// Takes the first unused gesture `label`: its time.
    fn take_gesture(&mut self, label: &str) -> Option<f64> {
        let k = self.gestures[self.gestures_used..]
            .iter()
            .position(|g| g.1 == label)?;
        let t = self.gestures[self.gestures_used + k].0;
        self.gestures_used += k + 1;
        Some(t)
    }

    /// Label of step `i`.
    pub fn label(step: &Step) -> String {
        match step {
            Step::Move { label, .. } => label.clone(),
            Step::Grip {
                close: true,
                object,
            } => format!("grasp {object}"),
            Step::Grip {
                close: false,
                object,
            } => format!("release {object}"),
            Step::AwaitGesture { label } => format!("wait for {label}"),
            Step::Handover { object, .. } => format!("hand {object} over"),
        }
    }

    /// The step running now, if any.
    pub fn current(&self) -> Option<&Step> {
        self.steps.get(self.index)
    }

    /// Steps done so far: (index, label, start s, end s).
    pub fn finished(&self) -> &[(usize, String, f64, f64)] {
        &self.finished
    }

    /// Number of steps.
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// Whether the script is empty.
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    fn motion(&self, t: f64, goal: &[f64; 3], speed: f64, label: &str) -> MotionCommand {
        let end_effector_avoidance_off = self.handover_goal.is_some_and(|g| g == *goal);
        MotionCommand {
            header: Header {
                stamp: cowork_msgs::builtin_interfaces::Time::from_secs_f64(t),
                frame_id: "lwr_base_link".into(),
            },
            id: self.id,
            kind: MotionCommand::KIND_CONSTANT_SPEED,
            label: label.to_owned(),
            parameters_json: String::new(),
            parameters: Vec::new(),
            goal: Pose {
                position: Point {
                    x: goal[0],
                    y: goal[1],
                    z: goal[2],
                },
                orientation: Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                    w: 1.0,
                },
            },
            nominal_speed: speed,
            hold_orientation: true,
            end_effector_avoidance_off,
        }
    }

    /// Advances at simulated time `t` (s) with the newest `/motion/status` and `/lwr/world`;
    /// pushes what must be published into `out`.
    pub fn update(
        &mut self,
        t: f64,
        status: Option<&MotionStatus>,
        world: Option<&WorldState>,
        out: &mut Vec<Output>,
    ) -> Progress {
        loop {
            let Some(step) = self.steps.get(self.index).cloned() else {
                return Progress::Done;
            };
            let label = Self::label(&step);
            let Some(start) = self.started else {
                self.started = Some(t);
                self.sent = t;
                self.acknowledged = false;
                match &step {
                    Step::Move { goal, speed, label } => {
                        self.id += 1;
                        out.push(Output::Motion(self.motion(t, goal, *speed, label)));
                    }
                    Step::Grip { close, .. } => {
                        out.push(Output::Gripper(if *close { "close" } else { "open" }))
                    }
                    // Issued below, once the gesture and a fresh hand are there.
                    Step::AwaitGesture { .. } | Step::Handover { .. } => {
                        self.handover_goal = None;
                        continue;
                    }
                }
                return Progress::Running;
            };
            let done = match &step {
                Step::Move { goal, speed, label } => {
                    let mine = status.filter(|s| s.command_id == self.id);
                    if let Some(s) = mine {
                        self.acknowledged = true;
                        if s.state == MotionStatus::STATE_ABORTED {
                            return Progress::Failed(format!(
                                "step {} ({label}): ds_controller aborted the motion: {}",
                                self.index + 1,
                                s.reason
                            ));
                        }
                    }
                    if !self.acknowledged && t - self.sent >= RESEND_AFTER_S {
                        self.sent = t;
                        out.push(Output::Motion(self.motion(t, goal, *speed, label)));
                    }
                    mine.is_some_and(|s| s.state == MotionStatus::STATE_CONVERGED)
                }
                Step::Grip { close, object } => {
                    let seen = world.is_some_and(|w| {
                        if *close {
                            w.gripper_state == WorldState::GRIPPER_CLOSED
                                && w.held_object == *object
                        } else {
                            w.gripper_state == WorldState::GRIPPER_OPEN && w.held_object.is_empty()
                        }
                    });
                    if !seen && t - start >= GRIP_TIMEOUT_S {
                        let holding = world.map_or("no /lwr/world".to_owned(), |w| {
                            format!("holding {:?}", w.held_object)
                        });
                        return Progress::Failed(format!(
                            "step {} ({label}): not seen in /lwr/world after {GRIP_TIMEOUT_S} s ({holding})",
                            self.index + 1
                        ));
                    }
                    seen
                }
                Step::AwaitGesture { label } => self.take_gesture(label).is_some(),
                Step::Handover {
                    object,
                    offset,
                    speed,
                    reach_centre,
                    reach_radius,
                } => {
                    if let Some(w) = world
                        && w.held_object != *object
                    {
                        return Progress::Failed(format!(
                            "step {} ({label}): {object} is not held (holding {:?})",
                            self.index + 1,
                            w.held_object
                        ));
                    }
                    let running = self
                        .handovers
                        .last()
                        .is_some_and(|h| h.commanded_t >= start && h.object == *object);
                    if !running {
                        // Not commanded yet: a handover gesture (already seen or new) and a
                        // fresh hand.
                        let target = self.hand_goal(t, offset, reach_centre, *reach_radius);
                        let gesture_t = self.gestures[self.gestures_used..]
                            .iter()
                            .find(|g| g.1 == Gesture::LABEL_HANDOVER_RIGHT)
                            .map(|g| g.0);
                        if let (Some(gt), Some(goal)) = (gesture_t, target) {
                            self.take_gesture(Gesture::LABEL_HANDOVER_RIGHT);
                            self.handovers.push(HandoverLog {
                                object: object.clone(),
                                gesture_t: gt,
                                commanded_t: t,
                                goals: vec![(t, goal)],
                            });
                            self.send_handover(t, goal, *speed, &label, out);
                        }
                        false
                    } else {
                        let mine = status.filter(|s| s.command_id == self.id);
                        if let Some(s) = mine {
                            self.acknowledged = true;
                            if s.state == MotionStatus::STATE_ABORTED {
                                return Progress::Failed(format!(
                                    "step {} ({label}): ds_controller aborted the motion: {}",
                                    self.index + 1,
                                    s.reason
                                ));
                            }
                        }
                        let goal = self.handover_goal.unwrap_or_default();
                        // Follow the hand (goal adaptation, eq. 5.2) while it moves.
                        let target = self.hand_goal(t, offset, reach_centre, *reach_radius);
                        if let Some(g) = target.filter(|g| dist(g, &goal) > HANDOVER_RETARGET_M) {
                            if let Some(h) = self.handovers.last_mut() {
                                h.goals.push((t, g));
                            }
                            self.send_handover(t, g, *speed, &label, out);
                            false
                        } else {
                            if !self.acknowledged && t - self.sent >= RESEND_AFTER_S {
                                self.sent = t;
                                out.push(Output::Motion(self.motion(t, &goal, *speed, &label)));
                            }
                            // Arrived, and the hand is still under the block (a fresh
                            // observation near the goal): never release into thin air.
                            let hand_there = self.hand.is_some_and(|h| {
                                t - h.0 <= HANDOVER_HAND_MAX_AGE_S
                                    && dist(&add(h.1, *offset), &goal) <= 2.0 * HANDOVER_RETARGET_M
                            });
                            mine.is_some_and(|s| s.state == MotionStatus::STATE_CONVERGED)
                                && hand_there
                        }
                    }
                }
            };
            if !done {
                return Progress::Running;
            }
            self.finished.push((self.index, label, start, t));
            self.index += 1;
            self.started = None;
            self.handover_goal = None;
        }
    }

    /// A new handover command towards `goal` (end-effector avoidance off).
    fn send_handover(&mut self, t: f64, goal: [f64; 3], speed: f64, label: &str, out: &mut Vec<Output>) {
        self.id += 1;
        self.sent = t;
        self.acknowledged = false;
        self.handover_goal = Some(goal);
        out.push(Output::Motion(self.motion(t, &goal, speed, label)));
    }
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}
