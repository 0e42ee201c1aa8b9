//! Golden-file tests of the ROS side without DDS: a recorded input script goes through
//! `cowork_testkit::ScriptedSource` (mock clock) and the node's own loop `ds_controller::serve`
//! (the loop `run` uses over DDS); every output — statuses, joint velocities, warnings as the
//! rate limiter let them through, notes, model hand-overs, the real-time loop's inputs — is one
//! JSON line, compared with `tests/golden/*.jsonl` (`UPDATE_GOLDEN=1` rewrites them).
//!
//! - `status_paths`: `/motion/status` from scripted real-time outputs: waiting, running, hold
//!   (stale data, speed 0) and resume, the damper's limited link, guidance, converged,
//!   de-duplication and the status rate, aborts (bad command, a model the loop cannot take),
//!   rejected distances (the reason kept while the loop holds), accepted again.
//! - `bad_inputs`: 3 s of rejected 1 kHz `/joint_states` (logged twice, the rest held back),
//!   bad `/human/state`, `/lwr/world`, `/fded/distances`, `/lwr/external_wrench`, peer text
//!   quoted short, pushes the loop did not use.
//! - `closed_loop`: the real controller (`rt_step`, as the real-time thread runs it) stepped
//!   every 1 ms on the inputs the loop hands it, the arm integrated: run, hold on lost
//!   distances and resume, hold on a stopped person and resume, converge, abort.

use std::cell::RefCell;
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::rc::Rc;

use cowork_ds::{ControlOutput, DsController, Fault, HoldReason, Status, Stream, WrenchIgnored};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion, Vector3 as MsgVector3, Wrench, WrenchStamped};
use cowork_msgs::msg::{HumanState, LinkDistance, LinkDistances, MotionCommand, MotionStatus, WorldState};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::Header;
use cowork_robot::{JointVector, RobotModel};
use cowork_ros::{Event, InputSource, Warning, Warnings};
use cowork_testkit::{ScriptedSource, assert_golden};
use ds_controller::learned::Learned;
use ds_controller::scene::SceneObjects;
use ds_controller::{DsNode, Input, Params, RtInputs, RtOutput, Sink, rt_step, serve};
use nalgebra::Vector3;
use serde_json::{Value, json};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn model() -> RobotModel {
    RobotModel::from_urdf_file(root().join("../../config/robot/lwr4plus.urdf")).expect("URDF")
}

fn golden(name: &str) -> PathBuf {
    root().join("tests/golden").join(format!("{name}.jsonl"))
}

fn params() -> Params {
    let mut p = Params::default();
    p.controller.ttc.enabled = true;
    p
}

fn node(model: &RobotModel, params: &Params) -> DsNode {
    let base = model.link_names()[0].clone();
    let scene = SceneObjects::new(Default::default(), params.scene_objects.margin_m, params.scene_objects.max_age_s, &base);
    DsNode::new(model, params, scene)
}

fn q0() -> JointVector {
    JointVector::from_row_slice(&[0.0, 0.5, 0.0, -1.3, 0.0, 0.8, 0.0])
}

fn header(t: f64) -> Header {
    Header { stamp: Time::from_nanos((t * 1e9).round() as i64), frame_id: "lwr_base_link".into() }
}

fn joint_state(model: &RobotModel, t: f64, q: &JointVector) -> JointState {
    JointState {
        header: header(t),
        name: model.joint_names().to_vec(),
        position: q.as_slice().to_vec(),
        velocity: vec![0.0; q.len()],
        ..Default::default()
    }
}

fn distances(model: &RobotModel, t: f64) -> LinkDistances {
    let links = model.link_names().iter().map(|n| LinkDistance { link_name: n.clone(), ..Default::default() }).collect();
    LinkDistances { header: header(t), links, min_index: -1, backend: "test".into(), ..Default::default() }
}

fn human(t: f64, stopped: bool) -> HumanState {
    HumanState { header: header(t), mode: HumanState::MODE_FAR, present: false, stopped, speed_scale: 0.3, ..Default::default() }
}

fn command(id: u32, kind: u8, goal: Vector3<f64>, parameters: Vec<f64>) -> MotionCommand {
    MotionCommand {
        id,
        kind,
        label: format!("test {id}"),
        parameters,
        goal: Pose { position: Point { x: goal.x, y: goal.y, z: goal.z }, orientation: Quaternion { w: 1.0, ..Default::default() } },
        hold_orientation: true,
        ..Default::default()
    }
}

fn wrench(frame: &str, t: f64, f: [f64; 3]) -> WrenchStamped {
    WrenchStamped {
        header: Header { stamp: Time::from_nanos((t * 1e9).round() as i64), frame_id: frame.into() },
        wrench: Wrench { force: MsgVector3 { x: f[0], y: f[1], z: f[2] }, torque: MsgVector3::default() },
    }
}

/// A scripted output of the real-time loop.
fn step(t: f64, id: u32, status: Status) -> RtOutput {
    RtOutput {
        time: t,
        qdot: JointVector::from_element(0.01),
        status,
        command_id: id,
        goal_error: 0.1,
        waiting_for_joints: false,
        approach_limited: None,
        guided: None,
        ttc: ([1.0, 0.0, 0.0], 0.0),
        wrench_ignored: None,
    }
}

fn tip(model: &RobotModel) -> Vector3<f64> {
    model.link_pose(&q0(), model.tip_link()).translation.vector
}

/// `x` rounded to `digits` decimals (null when not finite), so the files do not depend on the
/// last bits of a float.
fn round(x: f64, digits: i32) -> Value {
    let s = 10f64.powi(digits);
    if x.is_finite() { json!((x * s).round() / s) } else { Value::Null }
}

/// Records the loop's outputs as JSON lines.
#[derive(Default)]
struct Recorder {
    lines: Vec<String>,
    /// Record every joint velocity command (otherwise only its largest |q̇| in status lines).
    velocities: bool,
    /// Record the real-time loop's inputs when their summary changes.
    rt: bool,
    last_rt: Option<Value>,
    /// Command ids whose model the "real-time loop" refuses (a full channel).
    refuse_models: BTreeSet<u32>,
    /// Where the closed-loop test's real-time step reads its inputs.
    shared_rt: Option<Rc<RefCell<RtInputs>>>,
    speed: f64,
    velocity_count: u64,
    logged: BTreeMap<String, u64>,
    held_back: BTreeMap<String, u64>,
}

impl Recorder {
    fn push(&mut self, v: Value) {
        self.lines.push(v.to_string());
    }

    fn summary(&mut self) -> Vec<String> {
        let v = json!({"end": {"velocities": self.velocity_count, "warnings_logged": self.logged, "warnings_held_back": self.held_back}});
        self.push(v);
        std::mem::take(&mut self.lines)
    }
}

impl Sink for Recorder {
    fn rt_inputs(&mut self, i: &RtInputs) {
        if let Some(shared) = &self.shared_rt {
            *shared.borrow_mut() = *i;
        }
        if !self.rt {
            return;
        }
        let v = json!({
            "command": i.command.id,
            "primitive": format!("{:?}", i.command.primitive),
            "joints_stamp": i.joints.map(|(_, t)| round(t, 6)),
            "distances_stamp": round(i.distances.stamp, 6),
            "distances_rejected": i.distances_rejected,
            "human": [round(i.human.stamp, 6), i.human.state.present, i.human.state.stopped],
            "wrench": i.wrench.map(|w| json!([w.link, round(w.force.norm(), 3)])),
        });
        if self.last_rt.as_ref() != Some(&v) {
            self.push(json!({"rt": v}));
            self.last_rt = Some(v);
        }
    }

    fn hand_model(&mut self, id: u32, _model: Box<Learned>) -> Result<(), &'static str> {
        if self.refuse_models.contains(&id) {
            self.push(json!({"model_refused": id}));
            return Err("the real-time loop is not taking models (stalled?)");
        }
        self.push(json!({"model": id}));
        Ok(())
    }

    fn velocity(&mut self, now: f64, qdot: &JointVector) {
        self.velocity_count += 1;
        self.speed = qdot.amax();
        if self.velocities {
            let q: Vec<Value> = qdot.iter().map(|v| round(*v, 6)).collect();
            self.push(json!({"t": round(now, 6), "velocity": q}));
        }
    }

    fn status(&mut self, now: f64, s: &MotionStatus) {
        let mut v = json!({"t": round(now, 6), "status": {"command_id": s.command_id, "state": s.state, "reason": s.reason, "goal_error": round(s.goal_error, 4)}});
        assert!((s.header.stamp.to_secs_f64() - now).abs() < 1e-6, "status stamped {:?} at {now}", s.header.stamp);
        if !self.velocities {
            v["speed"] = round(self.speed, 3);
        }
        self.push(v);
    }

    fn warning(&mut self, now: f64, w: &Warning, logged: bool) {
        if logged {
            *self.logged.entry(w.kind.clone()).or_default() += 1;
            self.push(json!({"t": round(now, 6), "warning": w.kind, "message": w.message}));
        } else {
            *self.held_back.entry(w.kind.clone()).or_default() += 1;
        }
    }

    fn note(&mut self, now: f64, text: &str) {
        self.push(json!({"t": round(now, 6), "note": text}));
    }
}

fn run_script(node: &mut DsNode, source: &mut impl InputSource<Input>, rec: &mut Recorder, params: &Params) -> Vec<String> {
    let mut warnings = Warnings::new(params.warning_period_s);
    serve(node, source, rec, &mut warnings);
    rec.summary()
}

/// A learned primitive (a DMP fitted to one demonstration) as a command's JSON.
fn dmp_json() -> String {
    let t: Vec<f64> = (0..51).map(|i| i as f64 * 0.02).collect();
    let pos = t.iter().flat_map(|t| {
        let s = (1.0 - t / 1.0).powi(2);
        [0.05 * s, 0.05 * s, 0.0]
    });
    let demo = cowork_motion::Demonstration::new(3, t.clone(), pos.collect(), None).expect("demo");
    let m = cowork_motion::model::Model::fit(cowork_motion::model::ModelKind::Dmp, &[demo], &Default::default()).expect("fit");
    serde_json::to_string(&m).expect("json")
}

#[test]
fn status_paths() {
    let model = model();
    let params = params();
    let mut node = node(&model, &params);
    let x0 = tip(&model);
    let goal = x0 + Vector3::new(0.05, 0.05, 0.0);
    let link4 = model.link_names()[4].clone();
    let running = Status::Running;
    let mut s: Vec<(f64, Input)> = Vec::new();
    let mut add = |t: f64, i: Input| s.push((t, i));
    // Nothing yet: waiting for joint states (no velocity published), then for a command.
    add(0.000, Input::Step(RtOutput { waiting_for_joints: true, goal_error: f64::NAN, ..step(0.0, 0, Status::Held(HoldReason::Command)) }));
    add(0.001, Input::JointState(joint_state(&model, 0.001, &q0())));
    add(0.002, Input::Distances(distances(&model, 0.002)));
    add(0.003, Input::Human(human(0.003, false)));
    add(0.004, Input::Step(step(0.004, 0, Status::Held(HoldReason::Command))));
    // Command 1 runs; statuses on the change, then at 50 Hz.
    add(0.010, Input::Command(command(1, MotionCommand::KIND_LINEAR, goal, vec![3.0])));
    for k in 0..10 {
        let t = 0.011 + 0.005 * f64::from(k);
        add(t, Input::Step(step(t, 1, running)));
    }
    // Hold on stale distances, the same hold again (not repeated), resume.
    let stale = Fault::Stale { stream: Stream::Distances, age_s: 0.35, bound_s: 0.3 };
    add(0.060, Input::Step(step(0.060, 1, Status::Held(HoldReason::Fault(stale)))));
    add(0.065, Input::Step(step(0.065, 1, Status::Held(HoldReason::Fault(stale)))));
    add(0.070, Input::Step(step(0.070, 1, running)));
    // Hold on a stopped person, resume.
    add(0.075, Input::Step(step(0.075, 1, Status::Held(HoldReason::SpeedZero))));
    add(0.080, Input::Step(step(0.080, 1, running)));
    // The damper limits link 4: shown for 0.2 s after the last limited step.
    add(0.085, Input::Step(RtOutput { approach_limited: Some(4), ..step(0.085, 1, running) }));
    add(0.200, Input::Step(step(0.200, 1, running)));
    add(0.300, Input::Step(step(0.300, 1, running)));
    // Task transition control blending a push in, then released.
    let tip_link = model.tip_link();
    add(0.310, Input::Step(RtOutput { guided: Some((Some(tip_link), 2)), ..step(0.310, 1, running) }));
    add(0.315, Input::Step(RtOutput { guided: Some((None, 0)), ..step(0.315, 1, running) }));
    // Converged: not repeated within the period, then again at the rate.
    add(0.320, Input::Step(RtOutput { goal_error: 0.004, ..step(0.320, 1, Status::Converged) }));
    add(0.325, Input::Step(RtOutput { goal_error: 0.004, ..step(0.325, 1, Status::Converged) }));
    add(0.345, Input::Step(RtOutput { goal_error: 0.004, ..step(0.345, 1, Status::Converged) }));
    // Abort: an unknown kind. The loop then holds command 2; its statuses stay ABORTED.
    add(0.350, Input::Command(command(2, 9, goal, vec![])));
    add(0.351, Input::Step(step(0.351, 2, Status::Held(HoldReason::Command))));
    add(0.375, Input::Step(step(0.375, 2, Status::Held(HoldReason::Command))));
    // A NaN goal, sent twice: answered twice (the second warning held back).
    add(0.380, Input::Command(command(3, MotionCommand::KIND_LINEAR, Vector3::new(f64::NAN, 0.0, 0.5), vec![])));
    add(0.381, Input::Command(command(3, MotionCommand::KIND_LINEAR, Vector3::new(f64::NAN, 0.0, 0.5), vec![])));
    // Rejected distances while command 3 is aborted: its status stays ABORTED.
    let mut bad = distances(&model, 0.385);
    bad.links[4].link_name = "elbow".into();
    add(0.385, Input::Distances(bad.clone()));
    // Command 4 is accepted; the loop holds it on the rejected distances: the reason is the
    // adapter's, kept while the loop holds; the same rejection again is no new status.
    add(0.390, Input::Command(command(4, MotionCommand::KIND_LINEAR, goal, vec![])));
    let rejected = Fault::Rejected { stream: Stream::Distances, reason: "malformed message (see the log)" };
    add(0.391, Input::Step(step(0.391, 4, Status::Held(HoldReason::Fault(rejected)))));
    bad.header = header(0.395);
    add(0.395, Input::Distances(bad));
    add(0.396, Input::Step(step(0.396, 4, Status::Held(HoldReason::Fault(rejected)))));
    // An empty message: another reason, published at once.
    add(0.400, Input::Distances(LinkDistances { header: header(0.4), min_index: -1, ..Default::default() }));
    // Good distances: the rejection ends, the loop resumes.
    add(0.405, Input::Distances(distances(&model, 0.405)));
    add(0.406, Input::Step(step(0.406, 4, running)));
    // Zero-normal distances as the controller reports them: the link is named.
    add(0.407, Input::Step(step(0.407, 4, Status::Held(HoldReason::Fault(Fault::ZeroNormal { link: 4 })))));
    // A learned primitive whose model the real-time loop cannot take: aborted, robot held.
    let json = dmp_json();
    let learned = |id| MotionCommand { parameters_json: json.clone(), ..command(id, MotionCommand::KIND_DMP, goal, vec![]) };
    add(0.410, Input::Command(learned(5)));
    add(0.411, Input::Step(step(0.411, 5, Status::Held(HoldReason::Command))));
    // The next one is handed over and runs.
    add(0.420, Input::Command(learned(6)));
    add(0.421, Input::Step(step(0.421, 6, running)));
    let mut rec = Recorder { velocities: true, rt: true, refuse_models: [5].into(), ..Default::default() };
    let lines = run_script(&mut node, &mut ScriptedSource::new(s, 0.5), &mut rec, &params);
    // Spot checks besides the file: the link names in reasons, every command answered.
    let text = lines.join("\n");
    assert!(text.contains(&format!("approach limited: {link4}")), "no limited link");
    assert!(text.contains(r#"unknown link name \"elbow\" in entry 4"#), "rejection reason not kept");
    let aborted = format!(r#""state":{}"#, MotionStatus::STATE_ABORTED);
    assert_eq!(lines.iter().filter(|l| l.contains(&aborted) && l.contains(r#""goal_error":null"#)).count(), 4, "one ABORTED answer per bad command");
    assert_golden(&golden("status_paths"), &lines);
}

#[test]
fn bad_inputs() {
    let model = model();
    let params = params();
    let mut node = node(&model, &params);
    let names = model.joint_names().to_vec();
    let mut s: Vec<(f64, Input)> = Vec::new();
    // 3 s of rejected joint states at 1 kHz, three kinds of bad in turn.
    for k in 0..3000u32 {
        let t = f64::from(k) * 1e-3;
        let mut m = joint_state(&model, t, &q0());
        match k % 3 {
            0 => m.position[2] = f64::NAN,
            1 => {
                m.name.clear();
                m.position.pop();
            }
            _ => m.name[3] = "elbow".into(),
        }
        s.push((t, Input::JointState(m)));
    }
    let long = "x".repeat(10_000);
    s.push((0.5, Input::Human(HumanState { mode: 7, ..human(0.5, false) })));
    s.push((0.6, Input::Human(HumanState { mode: 7, ..human(0.6, false) })));
    s.push((0.7, Input::World(WorldState { header: Header { stamp: Time::from_nanos(700_000_000), frame_id: long.clone() }, ..Default::default() })));
    s.push((0.75, Input::World(WorldState { header: Header { stamp: Time::from_nanos(750_000_000), frame_id: "camera".into() }, ..Default::default() })));
    let mut d = distances(&model, 0.8);
    d.links[2].link_name = long.clone();
    s.push((0.8, Input::Distances(d)));
    s.push((1.0, Input::Wrench(wrench(&"w".repeat(100), 1.0, [0.0, 0.0, 10.0]))));
    let tool = model.link_names()[model.tip_link()].clone();
    s.push((1.1, Input::Wrench(wrench(&tool, 1.1, [f64::NAN, 0.0, 0.0]))));
    // No joint state was accepted: a good push cannot be turned into the base frame.
    s.push((2.5, Input::Wrench(wrench(&tool, 2.5, [0.0, 0.0, 10.0]))));
    // A good joint state at last, then a good push (used) and one beyond max_force.
    s.push((2.6, Input::JointState(JointState { name: names.clone(), ..joint_state(&model, 2.6, &q0()) })));
    s.push((2.61, Input::Wrench(wrench(&tool, 2.61, [0.0, 0.0, 10.0]))));
    s.push((2.62, Input::Wrench(wrench(&tool, 2.62, [0.0, 0.0, 1000.0]))));
    // An accepted command with a long label: the note quotes a prefix.
    let goal = tip(&model) + Vector3::new(0.0, 0.05, 0.0);
    s.push((2.7, Input::Command(MotionCommand { label: long.clone(), ..command(1, MotionCommand::KIND_LINEAR, goal, vec![]) })));
    // Pushes the loop did not use: ageing after the touch is no news, one from the future is.
    s.push((2.8, Input::Step(RtOutput { wrench_ignored: Some(WrenchIgnored::Stale { age_s: 0.1 }), ..step(2.8, 1, Status::Running) })));
    s.push((2.81, Input::Step(RtOutput { wrench_ignored: Some(WrenchIgnored::Stale { age_s: -0.1 }), ..step(2.81, 1, Status::Running) })));
    s.push((2.82, Input::Step(RtOutput { wrench_ignored: Some(WrenchIgnored::TooLarge { force_n: 400.0 }), ..step(2.82, 1, Status::Running) })));
    let mut rec = Recorder { velocities: false, rt: true, ..Default::default() };
    let lines = run_script(&mut node, &mut ScriptedSource::new(s, 3.0), &mut rec, &params);
    // 3000 rejected /joint_states: logged at 0 s and 2 s only (warning_period_s = 2).
    assert_eq!(rec.logged.get("/joint_states:rejected"), Some(&2), "{:?}", rec.logged);
    assert_eq!(rec.held_back.get("/joint_states:rejected"), Some(&2998), "{:?}", rec.held_back);
    // Peer text is quoted short: no line carries the 10 000 characters.
    assert!(lines.iter().all(|l| l.len() < 1000), "a line quotes too much");
    assert_golden(&golden("bad_inputs"), &lines);
}

/// The real-time thread's part, deterministic: every period of the script's clock, one
/// `rt_step` on the inputs the loop last handed over, its output as `Input::Step`, then the
/// arm's new joint state (q integrated over the period) as the simulator would publish it.
struct Plant {
    script: ScriptedSource<Input>,
    model: RobotModel,
    ctl: DsController,
    out: ControlOutput,
    rt: Rc<RefCell<RtInputs>>,
    q: JointVector,
    k: u64,
    period: f64,
    joint_state_due: Option<f64>,
}

impl InputSource<Input> for Plant {
    fn next(&mut self, deadline_s: f64) -> Event<Input> {
        if let Some(t) = self.joint_state_due.take() {
            return Event::Input(Input::JointState(joint_state(&self.model, t, &self.q)));
        }
        let step_at = self.k as f64 * self.period;
        match self.script.next(deadline_s.min(step_at)) {
            Event::Deadline if self.script.now_s() >= step_at => {
                let inputs = *self.rt.borrow();
                let o = rt_step(&mut self.ctl, &inputs, step_at, None, &mut self.out);
                if !o.waiting_for_joints {
                    self.q += o.qdot * self.period;
                }
                self.k += 1;
                self.joint_state_due = Some(step_at);
                Event::Input(Input::Step(o))
            }
            e => e,
        }
    }

    fn now_s(&self) -> f64 {
        self.script.now_s()
    }
}

#[test]
fn closed_loop() {
    let model = model();
    let params = params();
    let mut node = node(&model, &params);
    let goal = tip(&model) + Vector3::new(0.0, 0.08, 0.0);
    let mut s: Vec<(f64, Input)> = Vec::new();
    // Distances and the person every 10 ms, except distances lost from 0.5 s to 1.0 s and the
    // person saying stop from 1.3 s to 1.5 s.
    for k in 0..300u32 {
        let t = f64::from(k) * 0.01 + 0.0005;
        if !(0.5..1.0).contains(&t) {
            s.push((t, Input::Distances(distances(&model, t))));
        }
        s.push((t, Input::Human(human(t, (1.3..1.5).contains(&t)))));
    }
    s.push((0.1, Input::Command(command(1, MotionCommand::KIND_LINEAR, goal, vec![3.0]))));
    // A bad command at the end: aborted, the robot brakes and holds.
    s.push((2.8, Input::Command(command(2, MotionCommand::KIND_LINEAR, Vector3::new(3.0, 0.0, 0.5), vec![]))));
    let shared = Rc::new(RefCell::new(RtInputs::default()));
    let mut plant = Plant {
        script: ScriptedSource::new(s, 3.0),
        model: model.clone(),
        ctl: DsController::new(model.clone(), params.controller).expect("controller"),
        out: ControlOutput::default(),
        rt: Rc::clone(&shared),
        q: q0(),
        k: 1,
        period: params.controller.period_s,
        joint_state_due: Some(0.0),
    };
    let mut rec = Recorder { velocities: false, rt: false, shared_rt: Some(shared), ..Default::default() };
    let lines = run_script(&mut node, &mut plant, &mut rec, &params);
    let statuses: Vec<Value> = lines.iter().map(|l| serde_json::from_str::<Value>(l).expect("json")).filter(|v| v.get("status").is_some()).collect();
    let state_at = |t: f64| {
        statuses.iter().rev().find(|v| v["t"].as_f64().is_some_and(|x| x <= t)).map(|v| (v["status"]["state"].as_u64(), v["status"]["reason"].as_str().unwrap_or("").to_owned()))
    };
    let (running, held, converged, aborted) =
        (u64::from(MotionStatus::STATE_RUNNING), u64::from(MotionStatus::STATE_HELD), u64::from(MotionStatus::STATE_CONVERGED), u64::from(MotionStatus::STATE_ABORTED));
    assert_eq!(state_at(0.4).map(|s| s.0), Some(Some(running)), "{:?}", state_at(0.4));
    let lost = state_at(0.95).expect("status");
    assert!(lost.0 == Some(held) && lost.1.contains("stale /fded/distances"), "{lost:?}");
    assert_eq!(state_at(1.25).map(|s| s.0), Some(Some(running)), "no resume: {:?}", state_at(1.25));
    let stop = state_at(1.45).expect("status");
    assert!(stop.0 == Some(held) && stop.1.contains("speed scale 0"), "{stop:?}");
    assert!(statuses.iter().any(|v| v["status"]["state"].as_u64() == Some(converged)), "never converged");
    let end = state_at(3.0).expect("status");
    assert!(end.0 == Some(aborted) && end.1.contains("out of reach"), "{end:?}");
    assert!(rec.speed < 1e-6, "still moving after the abort: {}", rec.speed);
    assert_golden(&golden("closed_loop"), &lines);
}
