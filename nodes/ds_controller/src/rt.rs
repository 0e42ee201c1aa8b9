//! The real-time side: [`rt_loop`] steps the controller once per period (1 ms of wall time, or
//! of `/clock` time with `use_sim_time`) on the newest inputs, read from a latest-value
//! [`Mailbox`] of `Copy` data, and hands out `Copy` [`RtOutput`]s. The loop never allocates,
//! frees, logs, serialises or publishes; learned models come in and go out through bounded
//! channels ([`FieldChannels`]) so that even a replaced model is freed on the ROS side.

use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use cowork_ds::{
    ControlInput, ControlOutput, Distances, DsController, ExternalWrench, Fault, HoldReason, HumanInput, HumanState,
    LearnedField, MotionCommand, Primitive, Status, Stream, WrenchIgnored,
};
use cowork_robot::JointVector;
use nalgebra::Vector3;

use crate::learned::Learned;

/// A latest-value mailbox of `Copy` data between the ROS side and the real-time loop. The lock
/// is held only for a copy (no allocation, no I/O under it).
#[derive(Debug, Default)]
pub struct Mailbox<T: Copy>(Mutex<T>);

impl<T: Copy> Mailbox<T> {
    /// A mailbox holding `value`.
    pub fn new(value: T) -> Self {
        Self(Mutex::new(value))
    }

    /// A copy of the current value.
    pub fn read(&self) -> T {
        // A panic while holding the lock cannot leave a `Copy` value half-written.
        *self.0.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Changes the value in place.
    pub fn update(&self, f: impl FnOnce(&mut T)) {
        f(&mut self.0.lock().unwrap_or_else(|p| p.into_inner()));
    }
}

/// Everything the real-time loop reads, `Copy`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RtInputs {
    /// Latest joint positions (rad) and their arrival time (s); `None` before the first.
    pub joints: Option<(JointVector, f64)>,
    /// The motion to run.
    pub command: MotionCommand,
    /// Latest distances (stamp = arrival time).
    pub distances: Distances,
    /// Latest human state (stamp = arrival time).
    pub human: HumanInput,
    /// The newest distances message was rejected by the adapter (with this reason).
    pub distances_rejected: Option<&'static str>,
    /// The newest accepted `/lwr/external_wrench` (a person's push, base frame); `None` before
    /// the first and after a rejected one. It acts while younger than `ttc.max_wrench_age_s`.
    pub wrench: Option<ExternalWrench>,
}

impl Default for RtInputs {
    fn default() -> Self {
        Self {
            joints: None,
            command: MotionCommand {
                id: 0,
                primitive: Primitive::Hold,
                goal: Vector3::zeros(),
                orientation: None,
                end_effector_avoidance: true,
            },
            distances: Distances::NEVER,
            human: HumanInput { stamp: f64::NEG_INFINITY, state: HumanState::default() },
            distances_rejected: None,
            wrench: None,
        }
    }
}

/// One result of the real-time loop, `Copy`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RtOutput {
    /// Time of the step (s, node clock).
    pub time: f64,
    /// Joint velocity command (rad/s).
    pub qdot: JointVector,
    /// Motion status.
    pub status: Status,
    /// Command the step ran.
    pub command_id: u32,
    /// ‖x − g‖ (m); NaN when held without a joint reading.
    pub goal_error: f64,
    /// No `/joint_states` yet: nothing was computed.
    pub waiting_for_joints: bool,
    /// The link whose approach the link-distance damper limited this step (model index).
    pub approach_limited: Option<usize>,
    /// Task transition control is blending a push in: the contact link (model index, `None`
    /// once the touch is over) and the stack with the largest weight (0 T_ee, 1 [T_ee, T_ic],
    /// 2 [T_ic, T_ee]).
    pub guided: Option<(Option<usize>, u8)>,
    /// Task transition control's barycentric weights (T¹, T², T³) after the step and the push's
    /// norm (N); `[1, 0, 0]` and 0 without a push.
    pub ttc: ([f64; 3], f64),
    /// The step did not use the newest push, and why (a push that ended ages into
    /// [`WrenchIgnored::Stale`] with a positive age: the normal end of a touch).
    pub wrench_ignored: Option<WrenchIgnored>,
}

/// The node's clock, shared by both threads: wall time (s since the epoch) or `/clock` time
/// mirrored by the ROS side into an atomic.
#[derive(Debug, Clone)]
pub enum Clock {
    /// Wall clock.
    Wall,
    /// `/clock` time in ns (negative before the first tick).
    Sim(Arc<AtomicI64>),
}

impl Clock {
    /// Now (s); `None` while simulated time has not started.
    pub fn now(&self) -> Option<f64> {
        match self {
            Clock::Wall => Some(
                SystemTime::now()
                    .duration_since(UNIX_EPOCH)
                    .map(|d| d.as_secs_f64())
                    .unwrap_or(0.0),
            ),
            Clock::Sim(ns) => {
                let v = ns.load(Ordering::Acquire);
                (v >= 0).then_some(v as f64 * 1e-9)
            }
        }
    }
}

/// One control step on the latest inputs at time `t` (s); `field` is the learned primitive of
/// a [`Primitive::Learned`] command. Allocation-free (when the field is).
pub fn rt_step(
    ctl: &mut DsController,
    inputs: &RtInputs,
    t: f64,
    field: Option<&mut dyn LearnedField>,
    out: &mut ControlOutput,
) -> RtOutput {
    let stale_after = ctl.config().stale_after_s;
    let Some((q, q_stamp)) = inputs.joints else {
        return RtOutput {
            time: t,
            qdot: JointVector::zeros(),
            status: Status::Held(HoldReason::Command),
            command_id: inputs.command.id,
            goal_error: f64::NAN,
            waiting_for_joints: true,
            approach_limited: None,
            guided: None,
            ttc: ([1.0, 0.0, 0.0], 0.0),
            wrench_ignored: None,
        };
    };
    let age = t - q_stamp;
    // A stamp from the future (clock stepped back, looped /clock) is as unusable as an old one.
    if !(age <= stale_after && age >= -ctl.config().future_tolerance_s) {
        let f = Fault::Stale { stream: Stream::JointStates, age_s: age, bound_s: stale_after };
        ctl.hold(&q, out, HoldReason::Fault(f));
    } else if let Some(reason) = inputs.distances_rejected {
        let f = Fault::Rejected { stream: Stream::Distances, reason };
        ctl.hold(&q, out, HoldReason::Fault(f));
    } else {
        let input = ControlInput {
            time: t,
            q,
            command: inputs.command,
            distances: inputs.distances,
            human: inputs.human,
        };
        // A fault is reported through `out.status` (Held with the fault).
        let _ = ctl.step_with_contact(&input, field, inputs.wrench.as_ref(), out);
    }
    let c = &out.diagnostics.contact;
    let guided = (c.weights[0] < 1.0 && !matches!(out.status, Status::Held(_))).then(|| {
        let top = if c.weights[2] >= c.weights[1] && c.weights[2] >= c.weights[0] {
            2
        } else if c.weights[1] >= c.weights[0] {
            1
        } else {
            0
        };
        (c.link, top)
    });
    RtOutput {
        time: t,
        qdot: out.qdot,
        status: out.status,
        command_id: inputs.command.id,
        goal_error: out.diagnostics.goal_error_m,
        waiting_for_joints: false,
        approach_limited: if out.diagnostics.safety.active { out.diagnostics.safety.link } else { None },
        guided,
        ttc: (c.weights, c.force_n),
        wrench_ignored: out.diagnostics.contact.ignored,
    }
}

/// Learned primitives handed between the ROS side and the real-time loop: the model of
/// command `id` goes in through `fields`; the loop returns replaced ones through `trash`, so
/// that it never frees memory either.
#[derive(Debug)]
pub struct FieldChannels {
    /// (command id, decoded model), ROS side → loop.
    pub fields: Receiver<(u32, Box<Learned>)>,
    /// Replaced models, loop → ROS side (dropped there).
    pub trash: SyncSender<Box<Learned>>,
}

/// The real-time loop: one [`rt_step`] per period of `clock` until `stop`. With the wall clock
/// it sleeps to absolute deadlines; with `/clock` it steps once per period of simulated time.
/// Each output goes to `output`, which must neither block nor allocate (run.rs: a `try_send`
/// on a bounded channel; an output that does not fit is dropped, the ROS side only needs the
/// newest).
pub fn rt_loop(
    mut ctl: DsController,
    inputs: Arc<Mailbox<RtInputs>>,
    mut output: impl FnMut(RtOutput),
    clock: Clock,
    stop: Arc<AtomicBool>,
    channels: FieldChannels,
) {
    let mut field: Option<(u32, Box<Learned>)> = None;
    let period = ctl.config().period_s;
    let mut out = ControlOutput::default();
    let start = Instant::now();
    let mut k: u64 = 0;
    let mut last_t = f64::NEG_INFINITY;
    while !stop.load(Ordering::Relaxed) {
        match clock {
            Clock::Wall => {
                k += 1;
                let deadline = start + cowork_ros::duration_s(k as f64 * period);
                let now = Instant::now();
                if deadline > now {
                    std::thread::sleep(deadline - now);
                } else if now - deadline > cowork_ros::duration_s(10.0 * period) {
                    // Overrun (suspended process): resynchronise instead of bursting.
                    k = ((now - start).as_secs_f64() / period) as u64;
                }
            }
            Clock::Sim(_) => {
                // Time going back (lwr_sim restarted, a bag looped) is stepped at once: the
                // step then finds every input stamped in its future and holds the robot.
                let due = clock.now().is_some_and(|t| t < last_t || t - last_t >= period * (1.0 - 1e-6));
                if !due {
                    std::thread::sleep(Duration::from_micros(100));
                    continue;
                }
            }
        }
        let Some(t) = clock.now() else { continue };
        last_t = t;
        while let Ok(new) = channels.fields.try_recv() {
            if let Some((_, old)) = field.replace(new) {
                // Full trash (cannot happen: the ROS side drains it): keep the old one alive.
                if let Err(std::sync::mpsc::TrySendError::Full(old)) = channels.trash.try_send(old) {
                    std::mem::forget(old);
                }
            }
        }
        let snapshot = inputs.read();
        let f = match &mut field {
            Some((id, m)) if *id == snapshot.command.id => Some(&mut **m as &mut dyn LearnedField),
            _ => None,
        };
        output(rt_step(&mut ctl, &snapshot, t, f, &mut out));
    }
}

