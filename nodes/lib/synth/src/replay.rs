//! Replaying a teaching demonstration (`/external_wrench` + `/speech_command`) into a
//! simulator, with the semantics of the graph: `lwr_sim` applies a wrench expressed in
//! `header.frame_id` at that link's origin (empty or base frame: base-frame wrench at the tool
//! point), and the robot manager turns the speech commands `gripper close` / `gripper open`
//! into `/lwr/gripper_command`. Inputs are applied before the simulator step at their log time,
//! as `lwr_sim` takes its messages before each step.

use std::path::Path;

use cowork_bag::BagReader;
use cowork_msgs::geometry_msgs::WrenchStamped;
use cowork_msgs::std_msgs::String as RosString;
use cowork_sim::{Simulator, Wrench};
use nalgebra::Vector3;

use crate::streams::topics;
use crate::{Result, SynthError};

/// One teaching input.
#[derive(Debug, Clone, PartialEq)]
pub enum TeachingInput {
    /// `/external_wrench`.
    Wrench(WrenchStamped),
    /// `/speech_command`.
    Speech(RosString),
}

/// What happened when an input was applied.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Applied {
    /// The wrench acts until the next one (or `wrench_timeout_s`).
    Wrench,
    /// The gripper closed, on this object if one was within reach.
    GripperClosed(Option<String>),
    /// The gripper opened.
    GripperOpened,
    /// A speech word the simulator does not act on (`teach`, `done`, ...).
    Ignored,
}

/// Applies one input to `sim` as `lwr_sim` (and the robot manager for the gripper words) would.
pub fn apply_input(sim: &mut Simulator, input: &TeachingInput) -> Result<Applied> {
    match input {
        TeachingInput::Wrench(msg) => {
            let f = &msg.wrench.force;
            let t = &msg.wrench.torque;
            let mut force = Vector3::new(f.x, f.y, f.z);
            let mut torque = Vector3::new(t.x, t.y, t.z);
            let frame = msg.header.frame_id.as_str();
            let base = sim.model().link_names()[0].as_str();
            let link = if frame.is_empty() || frame == base {
                None
            } else {
                let i = sim.model().link_index(frame).ok_or_else(|| SynthError::Plan {
                    scenario: "replay",
                    reason: format!("/external_wrench in unknown frame `{frame}`"),
                })?;
                let r = sim.link_poses().get(i).rotation;
                force = r * force;
                torque = r * torque;
                Some(frame.to_owned())
            };
            sim.set_wrench(Wrench { force, torque }, link.as_deref())
                .map_err(|source| SynthError::Command { what: "an external wrench", source })?;
            Ok(Applied::Wrench)
        }
        TeachingInput::Speech(msg) => match msg.data.trim().to_ascii_lowercase().as_str() {
            "gripper close" => Ok(Applied::GripperClosed(sim.command_gripper(true).map(str::to_owned))),
            "gripper open" => {
                sim.command_gripper(false);
                Ok(Applied::GripperOpened)
            }
            _ => Ok(Applied::Ignored),
        },
    }
}

/// What a replay did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReplaySummary {
    /// Wrench messages applied.
    pub wrenches: u64,
    /// Speech messages read.
    pub speech: u64,
    /// Gripper events: (time s, what happened).
    pub gripper_events: Vec<(f64, Applied)>,
    /// Simulated time at the end, s.
    pub end_s: f64,
}

/// Replays the `/external_wrench` and `/speech_command` streams of the bag at `path` into
/// `sim` (a fresh simulator at t = 0), stepping it until `settle_s` after the last input;
/// `observe` sees the simulator after every step.
pub fn replay_teaching(
    path: &Path,
    sim: &mut Simulator,
    settle_s: f64,
    mut observe: impl FnMut(&Simulator),
) -> Result<ReplaySummary> {
    let reader = BagReader::open(path)?;
    let mut inputs = Vec::new();
    for m in reader.messages() {
        let m = m?;
        let input = match &*m.topic {
            topics::EXTERNAL_WRENCH => TeachingInput::Wrench(m.decode()?),
            topics::SPEECH => TeachingInput::Speech(m.decode()?),
            _ => continue,
        };
        inputs.push((i64::try_from(m.log_time_ns).unwrap_or(i64::MAX), input));
    }
    let mut summary = ReplaySummary::default();
    let last = inputs.last().map_or(0, |(t, _)| *t);
    let end_ns = last + (settle_s * 1e9) as i64;
    let mut next = inputs.into_iter().peekable();
    while sim.time_ns() <= end_ns {
        while let Some((_, input)) = next.next_if(|(t, _)| *t <= sim.time_ns()) {
            let applied = apply_input(sim, &input)?;
            match applied {
                Applied::Wrench => summary.wrenches += 1,
                Applied::Ignored => summary.speech += 1,
                other => {
                    summary.speech += 1;
                    summary.gripper_events.push((sim.time_ns() as f64 * 1e-9, other));
                }
            }
        }
        sim.step();
        observe(sim);
    }
    summary.end_s = sim.time_ns() as f64 * 1e-9;
    Ok(summary)
}
