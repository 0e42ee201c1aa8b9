//! [`run`]: the node over DDS. Three threads:
//! - the **DDS input thread** blocks on the subscriptions ([`cowork_ros::DdsSource`], a wait set:
//!   it wakes when a message arrives, it never polls) and forwards each message into one bounded
//!   queue; with `use_sim_time` it also mirrors `/clock` into the real-time loop's clock;
//! - the **real-time loop** ([`rt_loop`]) steps the controller every period and puts each
//!   `Copy` output into the same queue (`try_send`: dropped when full, never blocking);
//! - the **ROS side** (the calling thread) blocks on that queue and runs [`serve`]: the
//!   handlers of [`DsNode`] (pure), then what they ask for — the mailbox of the real-time
//!   loop, the model hand-over, `/lwr/joint_velocity_command`, `/motion/status`, warnings
//!   through one rate limiter.
//!
//! [`serve`] is generic over the [`InputSource`] and the [`Sink`]: `tests/golden.rs` runs the
//! same loop on a scripted source with a mock clock.

use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TryRecvError, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;

use anyhow::{Context, Result, bail};
use cowork_ds::DsController;
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::MotionStatus;
use cowork_msgs::std_msgs::Float64MultiArray;
use cowork_msgs::topics;
use cowork_robot::{DOF, JointVector, RobotModel};
use cowork_ros::{DdsSource, Event, InputSource, Publisher, RosNode, RunOptions, StopCheck, Warning, Warnings};

use crate::learned::Learned;
use crate::node::{DsNode, Input, Outputs};
use crate::params::Params;
use crate::rt::{Clock, FieldChannels, Mailbox, RtInputs, rt_loop};
use crate::scene::SceneObjects;

/// Where the loop's outputs go: the real-time loop's mailbox and model channel and the
/// publishers over DDS ([`run`]), a recorder in tests.
pub trait Sink {
    /// The real-time loop is to read `inputs` from now on.
    fn rt_inputs(&mut self, inputs: &RtInputs);
    /// Hands the model of command `id` to the real-time loop; `Err` says why it cannot take it.
    fn hand_model(&mut self, id: u32, model: Box<Learned>) -> Result<(), &'static str>;
    /// Publishes a joint velocity command (rad/s) at node time `now`.
    fn velocity(&mut self, now: f64, qdot: &JointVector);
    /// Publishes a `/motion/status`.
    fn status(&mut self, now: f64, status: &MotionStatus);
    /// Publishes `/ds_controller/ttc` (weights T¹, T², T³ and the push, N).
    fn ttc(&mut self, _now: f64, _values: &[f64; 4]) {}
    /// A warning the loop logged (`logged`) or held back (its kind was logged within the
    /// warning period).
    fn warning(&mut self, _now: f64, _warning: &Warning, _logged: bool) {}
    /// A note the loop logged at info level.
    fn note(&mut self, _now: f64, _text: &str) {}
}

/// Node-clock seconds between two deadlines of [`serve`] when no input comes; a deadline only
/// lets the source look at its stop condition.
pub const TICK_S: f64 = 0.1;

/// The ROS side's loop: each input of `source` through `node`'s handler at the source's clock,
/// then its outputs to `sink` (model hand-over first, then the mailbox, then publications),
/// warnings logged through `warnings` (at most one per kind per period). Returns when the
/// source ends.
pub fn serve<S: InputSource<Input>, K: Sink>(node: &mut DsNode, source: &mut S, sink: &mut K, warnings: &mut Warnings) {
    let mut out = Outputs::default();
    loop {
        let deadline = source.now_s() + TICK_S;
        match source.next(deadline) {
            Event::Input(input) => {
                let now = source.now_s();
                out.clear();
                node.on_input(input, now, &mut out);
                deliver(node, &mut out, now, sink, warnings);
            }
            Event::Deadline => {}
            Event::End => return,
        }
    }
}

fn deliver<K: Sink>(node: &mut DsNode, out: &mut Outputs, now: f64, sink: &mut K, warnings: &mut Warnings) {
    // The model first: the real-time loop finds it when it sees the command.
    if let Some((id, model)) = out.model.take()
        && let Err(reason) = sink.hand_model(id, model)
    {
        node.on_model_refused(id, reason, now, out);
    }
    if out.rt_changed {
        sink.rt_inputs(node.rt_inputs());
    }
    if let Some(qdot) = &out.velocity {
        sink.velocity(now, qdot);
    }
    for s in &out.statuses {
        sink.status(now, s);
    }
    if let Some(v) = &out.ttc {
        sink.ttc(now, v);
    }
    for w in &out.warnings {
        let logged = warnings.warn(now, w);
        sink.warning(now, w, logged);
    }
    for n in &out.notes {
        tracing::info!("{n}");
        sink.note(now, n);
    }
}

/// Messages from the DDS input thread, and `/clock` (sim time), which goes to the real-time
/// loop's clock instead of the ROS side.
enum Dds {
    In(Input),
    Clock(Time),
}

/// Length of the queue from the DDS thread and the real-time loop to the ROS side.
const QUEUE: usize = 1024;

/// Runs the node: starts the real-time loop and the DDS input thread and serves the ROS side
/// until Ctrl-C, `options.stop` or `options.duration_s`.
pub fn run(node: RosNode, model: RobotModel, params: &Params, options: &RunOptions) -> Result<()> {
    // In an arm's namespace (`--ros-args -r __ns:=/left`) the arm's frames are `left/...`.
    let prefix = node.frame_prefix();
    let base_frame = format!("{prefix}{}", model.link_names().first().cloned().unwrap_or_default());
    let scene = SceneObjects::from_params(&params.scene_objects, &base_frame, &model)?;
    let other_arms = scene.other_arms();
    let mut ds = DsNode::new(&model, params, scene);
    ds.set_frame_prefix(&prefix);
    let ctl = DsController::new(model, params.controller).map_err(|e| anyhow::anyhow!("controller: {e}"))?;

    // The DDS thread stops with the ROS side (its own flag) or on Ctrl-C / the duration.
    let dds_stop = Arc::new(AtomicBool::new(false));
    let dds_check = RunOptions { duration_s: options.duration_s, stop: Some(Arc::clone(&dds_stop)) }.start();
    let mut dds = DdsSource::new(node, dds_check)?;
    let vel_pub = dds.node().advertise(&topics::JOINT_VELOCITY_COMMAND)?;
    let status_pub = dds.node().advertise(&topics::MOTION_STATUS)?;
    let ttc_pub = dds.node().advertise(&topics::TTC_WEIGHTS)?;
    dds.add(&topics::JOINT_STATES, |m| Dds::In(Input::JointState(m)))?;
    // Object poses before the distances they classify (the source takes subscriptions in turn).
    dds.add(&topics::WORLD, |m| Dds::In(Input::World(m)))?;
    // The scene's other arms (their links are known obstacles), before the distances too.
    for (i, arm) in other_arms.iter().enumerate() {
        dds.add_in(&topics::JOINT_STATES, &format!("/{arm}"), move |m| Dds::In(Input::OtherArm(i, m)))?;
    }
    dds.add(&topics::FDED_DISTANCES, |m| Dds::In(Input::Distances(m)))?;
    dds.add(&topics::HUMAN_STATE, |m| Dds::In(Input::Human(m)))?;
    dds.add(&topics::MOTION_COMMAND, |m| Dds::In(Input::Command(m)))?;
    if params.controller.ttc.enabled {
        // Task transition control: the push lwr_sim reports in execute mode (1 kHz while it
        // lasts; best effort, only the newest counts).
        dds.add(&topics::LWR_EXTERNAL_WRENCH, |m| Dds::In(Input::Wrench(m)))?;
    }
    let clock = if params.use_sim_time {
        dds.add(&topics::CLOCK, |m| Dds::Clock(m.clock))?;
        Clock::Sim(Arc::new(AtomicI64::new(-1)))
    } else {
        Clock::Wall
    };

    let (tx, rx) = std::sync::mpsc::sync_channel::<Input>(QUEUE);
    let mailbox = Arc::new(Mailbox::new(RtInputs::default()));
    let (field_tx, field_rx) = std::sync::mpsc::sync_channel::<(u32, Box<Learned>)>(4);
    let (trash_tx, trash_rx) = std::sync::mpsc::sync_channel::<Box<Learned>>(16);
    let rt_stop = Arc::new(AtomicBool::new(false));
    let rt = {
        let (inputs, clock, stop, tx) = (Arc::clone(&mailbox), clock.clone(), Arc::clone(&rt_stop), tx.clone());
        let channels = FieldChannels { fields: field_rx, trash: trash_tx };
        // `try_send` of a `Copy` output: never blocks, never allocates.
        let output = move |o| {
            let _ = tx.try_send(Input::Step(o));
        };
        std::thread::Builder::new()
            .name("ds_controller-rt".into())
            .spawn(move || rt_loop(ctl, inputs, output, clock, stop, channels))
            .context("cannot start the real-time thread")?
    };
    let sim_ns = match &clock {
        Clock::Sim(ns) => Some(Arc::clone(ns)),
        Clock::Wall => None,
    };
    let dds_thread = std::thread::Builder::new()
        .name("ds_controller-dds".into())
        .spawn(move || dds_input(dds, &tx, sim_ns.as_deref()))
        .context("cannot start the DDS input thread")?;

    tracing::info!(
        "ds_controller running at {:.0} Hz ({} time), watchdog {:.3} s",
        1.0 / params.controller.period_s,
        if params.use_sim_time { topics::CLOCK.name } else { "wall" },
        params.controller.stale_after_s
    );
    tracing::info!(
        "link damper: {} scene objects known{} (their points get the scene distances, from {} poses){}",
        ds.scene_objects_known(),
        if params.scene_objects.scene.is_empty() { String::new() } else { format!(" from {}", params.scene_objects.scene) },
        topics::WORLD.name,
        if other_arms.is_empty() {
            String::new()
        } else {
            format!(", and the other arms {} from their joint states", other_arms.iter().map(|a| format!("/{a}")).collect::<Vec<_>>().join(", "))
        }
    );
    if params.scene_objects.keep_off_table {
        tracing::info!("link damper: the links keep off the table top of {} (fDED does not see it)", params.scene_objects.scene);
    }
    let t = &params.controller.ttc;
    if t.enabled {
        tracing::info!(
            "task transition control on: pushes from {}, f_i = {} N, f_s = {} N, c = {} m/(N s)",
            topics::LWR_EXTERNAL_WRENCH.name,
            t.insert_force,
            t.switch_force,
            t.contact_gain
        );
    } else {
        tracing::info!("task transition control off (controller.ttc.enabled: false): pushes are not read");
    }

    let mut source = QueueSource { rx, clock, stop: options.start(), rt: &rt };
    let mut sink = DdsSink {
        mailbox: &mailbox,
        fields: &field_tx,
        trash: &trash_rx,
        velocity: &vel_pub,
        status: &status_pub,
        ttc: &ttc_pub,
        failures: Warnings::new(params.warning_period_s),
    };
    let mut warnings = Warnings::new(params.warning_period_s);
    serve(&mut ds, &mut source, &mut sink, &mut warnings);
    let rt_ended_early = rt.is_finished();
    drop(source);
    dds_stop.store(true, Ordering::SeqCst);
    rt_stop.store(true, Ordering::Relaxed);
    let rt_panicked = rt.join().is_err();
    let dds_panicked = dds_thread.join().is_err();
    // Leave the robot still.
    if let Err(e) = vel_pub.publish(Float64MultiArray::from_vec(vec![0.0; DOF])) {
        tracing::warn!("{}: the final zero command was not published: {e:#}", topics::JOINT_VELOCITY_COMMAND.name);
    }
    tracing::info!("ds_controller stopped");
    if rt_panicked || rt_ended_early {
        bail!("the real-time loop stopped{}", if rt_panicked { " (panicked)" } else { "" });
    }
    if dds_panicked {
        bail!("the DDS input thread panicked");
    }
    Ok(())
}

/// The DDS input thread: blocks on the subscriptions, forwards messages to the ROS side (waits
/// when its queue is full: the subscriptions' own queues then keep the newest), mirrors
/// `/clock` into `sim_ns`. Ends when its source's stop check says so or the ROS side is gone.
fn dds_input(mut source: DdsSource<Dds>, tx: &SyncSender<Input>, sim_ns: Option<&AtomicI64>) {
    loop {
        let deadline = source.now_s() + 1.0;
        match source.next(deadline) {
            Event::Input(Dds::In(input)) => {
                if tx.send(input).is_err() {
                    return;
                }
            }
            Event::Input(Dds::Clock(t)) => {
                if let Some(ns) = sim_ns {
                    ns.store(t.to_nanos(), Ordering::Release);
                }
            }
            Event::Deadline => {}
            Event::End => return,
        }
    }
}

/// The ROS side's [`InputSource`]: the queue fed by the DDS thread and the real-time loop,
/// on the node's clock; ends on a stop request or when the real-time loop has ended.
struct QueueSource<'a> {
    rx: Receiver<Input>,
    clock: Clock,
    stop: StopCheck,
    rt: &'a JoinHandle<()>,
}

impl InputSource<Input> for QueueSource<'_> {
    fn next(&mut self, deadline_s: f64) -> Event<Input> {
        loop {
            if self.stop.requested() || self.rt.is_finished() {
                return Event::End;
            }
            match self.rx.try_recv() {
                Ok(input) => return Event::Input(input),
                Err(TryRecvError::Disconnected) => return Event::End,
                Err(TryRecvError::Empty) => {}
            }
            let now = self.clock.now();
            if now.is_some_and(|t| t >= deadline_s) {
                return Event::Deadline;
            }
            // Node time runs at about wall-clock rate or slower; at most 0.1 s so a stop is seen.
            let wait = now.map_or(TICK_S, |t| (deadline_s - t).min(TICK_S));
            match self.rx.recv_timeout(cowork_ros::duration_s(wait)) {
                Ok(input) => return Event::Input(input),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return Event::End,
            }
        }
    }

    fn now_s(&self) -> f64 {
        self.clock.now().unwrap_or(0.0)
    }
}

/// The DDS side of [`Sink`].
struct DdsSink<'a> {
    mailbox: &'a Mailbox<RtInputs>,
    fields: &'a SyncSender<(u32, Box<Learned>)>,
    trash: &'a Receiver<Box<Learned>>,
    velocity: &'a Publisher<Float64MultiArray>,
    status: &'a Publisher<MotionStatus>,
    ttc: &'a Publisher<Float64MultiArray>,
    /// Publication failures, at most one warning per topic per period.
    failures: Warnings,
}

impl DdsSink<'_> {
    fn failed(&mut self, topic: &str, e: &anyhow::Error) {
        self.failures.warn_text(cowork_ros::monotonic_s(), topic, &format!("{topic}: publishing failed: {e:#}"));
    }
}

impl Sink for DdsSink<'_> {
    fn rt_inputs(&mut self, inputs: &RtInputs) {
        self.mailbox.update(|i| *i = *inputs);
    }

    fn hand_model(&mut self, id: u32, model: Box<Learned>) -> Result<(), &'static str> {
        // Models the loop replaced are freed here, not on the real-time thread.
        while self.trash.try_recv().is_ok() {}
        // Never block: a stalled real-time loop must not stop the ROS side (or Ctrl-C).
        match self.fields.try_send((id, model)) {
            Ok(()) => Ok(()),
            Err(TrySendError::Full(_)) => Err("the real-time loop is not taking models (stalled?)"),
            Err(TrySendError::Disconnected(_)) => Err("the real-time loop stopped"),
        }
    }

    fn velocity(&mut self, _now: f64, qdot: &JointVector) {
        if let Err(e) = self.velocity.publish(Float64MultiArray::from_vec(qdot.as_slice().to_vec())) {
            self.failed(topics::JOINT_VELOCITY_COMMAND.name, &e);
        }
    }

    fn status(&mut self, _now: f64, status: &MotionStatus) {
        if let Err(e) = self.status.publish(status.clone()) {
            self.failed(topics::MOTION_STATUS.name, &e);
        }
    }

    fn ttc(&mut self, _now: f64, values: &[f64; 4]) {
        if let Err(e) = self.ttc.publish(Float64MultiArray::from_vec(values.to_vec())) {
            self.failed(topics::TTC_WEIGHTS.name, &e);
        }
    }
}
