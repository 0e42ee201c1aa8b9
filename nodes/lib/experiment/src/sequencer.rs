//! Executes a task script step by step against `/motion/status` and `/lwr/world`: what to
//! publish next, when a step is done, and why the task failed. No I/O: the runner feeds it
//! messages and publishes what it returns.

use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::{MotionCommand, MotionStatus, WorldState};
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
        }
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
            };
            if !done {
                return Progress::Running;
            }
            self.finished.push((self.index, label, start, t));
            self.index += 1;
            self.started = None;
        }
    }
}
