//! `lwr_sim` + `ds_controller` over DDS on loopback (a private domain per test), on `/clock`
//! time; a client node in the same process plays fDED and the human observer and sends
//! commands. The graphs run one at a time (a lock), as each is two 1 kHz loops.
//!
//! `cargo test -p ds_controller --test over_dds -- --nocapture` prints the timings.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion, Vector3};
use cowork_msgs::msg::{HumanState, LinkDistance, LinkDistances, MotionCommand, MotionStatus};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::Header;
use cowork_robot::{JointVector, RobotModel};
use cowork_ros::{NodeConfig, Publisher, RosNode, Subscription, qos};
use cowork_sim::{Scene, Simulator};
use ds_controller::{Params, RunOptions};
use lwr_sim::{LwrSim, LwrSimConfig, Pacing};

static ONE_GRAPH: Mutex<()> = Mutex::new(());

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn model() -> RobotModel {
    RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("URDF")
}

fn private_domain() -> u16 {
    cowork_ros::domain::test_domain("ds_controller test")
}

struct Graph {
    _lock: MutexGuard<'static, ()>,
    stop: Arc<AtomicBool>,
    controller: Option<JoinHandle<anyhow::Result<()>>>,
    sim: Option<JoinHandle<anyhow::Result<()>>>,
    client: Client,
    model: RobotModel,
}

struct Client {
    node: RosNode,
    distances: Publisher<LinkDistances>,
    human: Publisher<HumanState>,
    command: Publisher<MotionCommand>,
    status: Subscription<MotionStatus>,
    joints: Subscription<JointState>,
    /// Latest joint state: (sim time s, q, q̇).
    last: Option<(f64, JointVector, JointVector)>,
    last_status: Option<MotionStatus>,
    statuses: Vec<(f64, MotionStatus)>,
    /// URDF link names: fDED sends one entry per link, in this order.
    link_names: Vec<String>,
}

impl Graph {
    /// Starts lwr_sim (kitchen scene, real-time pacing, `sim_s` simulated seconds at most) and
    /// ds_controller on `/clock`, and a client that has discovered both.
    fn start(sim_s: f64) -> Self {
        let lock = ONE_GRAPH.lock().unwrap_or_else(|p| p.into_inner());
        let domain = private_domain();
        let model = model();
        let mut sim_config: LwrSimConfig =
            cowork_ros::params::load(&root().join("config/lwr_sim.yaml"), "lwr_sim").expect("lwr_sim params");
        // No camera: distances come from the test client, and rendering would load the CPU.
        sim_config.depth.enabled = false;
        let scene = Scene::from_file(&root().join("config/scenes/kitchen.yaml")).expect("scene");
        let sim = Simulator::new(model.clone(), scene, sim_config.simulation.clone()).expect("simulator");
        let sim_node = RosNode::new("lwr_sim", &NodeConfig { domain_id: Some(domain), ..Default::default() })
            .expect("sim node");
        let lwr = LwrSim::new(sim, sim_config);
        let sim = std::thread::spawn(move || lwr_sim::run(sim_node, lwr, Pacing::Rate(1.0), Some(sim_s)));

        let mut params: Params =
            cowork_ros::params::load(&root().join("config/ds_controller.yaml"), "ds_controller").expect("params");
        params.use_sim_time = true;
        // The scene file is relative to the repository root (the test runs in the crate's).
        params.scene_objects.scene = root().join(&params.scene_objects.scene).display().to_string();
        params.validate("ds_controller.yaml").expect("valid params");
        let stop = Arc::new(AtomicBool::new(false));
        let ctl_node = RosNode::new(
            "ds_controller",
            &NodeConfig { domain_id: Some(domain), use_sim_time: true, ..Default::default() },
        )
        .expect("controller node");
        let options = RunOptions { duration_s: Some(120.0), stop: Some(Arc::clone(&stop)) };
        let ctl_model = model.clone();
        let controller = std::thread::spawn(move || ds_controller::run(ctl_node, ctl_model, &params, &options));

        let mut node =
            RosNode::new("test_client", &NodeConfig { domain_id: Some(domain), ..Default::default() }).expect("client");
        let distances = node.publisher::<LinkDistances>("/fded/distances", &qos::reliable()).expect("pub");
        let human = node.publisher::<HumanState>("/human/state", &qos::reliable()).expect("pub");
        let command = node.publisher::<MotionCommand>("/motion/command", &qos::reliable_depth(10)).expect("pub");
        let status = node.subscription::<MotionStatus>("/motion/status", &qos::reliable_depth(10)).expect("sub");
        let joints = node.subscription::<JointState>("/joint_states", &qos::reliable()).expect("sub");
        let mut client =
            Client {
            node,
            distances,
            human,
            command,
            status,
            joints,
            last: None,
            last_status: None,
            statuses: Vec::new(),
            link_names: model.link_names().to_vec(),
        };
        let deadline = Instant::now() + Duration::from_secs(20);
        while !(client.distances.subscription_count(&client.node) > 0
            && client.command.subscription_count(&client.node) > 0
            && client.human.subscription_count(&client.node) > 0
            && client.status.publisher_count(&client.node) > 0
            && client.last.is_some())
        {
            assert!(Instant::now() < deadline, "graph not discovered within 20 s");
            client.pump();
            std::thread::sleep(Duration::from_millis(5));
        }
        Graph { _lock: lock, stop, controller: Some(controller), sim: Some(sim), client, model }
    }

    fn tcp(&self) -> nalgebra::Vector3<f64> {
        let q = self.client.last.as_ref().expect("joint states").1;
        self.model.link_pose(&q, self.model.tip_link()).translation.vector
    }
}

impl Drop for Graph {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(h) = self.controller.take() {
            let r = h.join();
            if !std::thread::panicking() {
                match r {
                    Ok(r) => r.expect("ds_controller run"),
                    Err(_) => panic!("ds_controller thread panicked"),
                }
            }
        }
        // lwr_sim stops at its simulated duration; it is not waited for (the test's checks are
        // done, and joining cost each test the rest of its 60 s of real time). Its domain is
        // its own, so it cannot disturb the next test.
        self.sim = None;
    }
}

impl Client {
    fn pump(&mut self) {
        while let Some(js) = self.joints.take() {
            let q = JointVector::from_column_slice(&js.position);
            let qd = JointVector::from_column_slice(&js.velocity);
            self.last = Some((js.header.stamp.to_secs_f64(), q, qd));
        }
        while let Some(s) = self.status.take() {
            let t = self.sim_time();
            self.statuses.push((t, s.clone()));
            self.last_status = Some(s);
        }
    }

    fn sim_time(&self) -> f64 {
        self.last.as_ref().map_or(0.0, |l| l.0)
    }

    fn max_speed(&self) -> f64 {
        self.last.as_ref().map_or(f64::INFINITY, |l| l.2.amax())
    }

    /// A header stamped now (the newest simulated time seen) plus `offset_s`.
    fn header(&self, offset_s: f64) -> Header {
        Header { stamp: Time::from_nanos(((self.sim_time() + offset_s) * 1e9) as i64), frame_id: "lwr_base_link".into() }
    }

    /// Distances as fDED sends them, one entry per link (no obstacle in range), with `entry`
    /// replacing the entry of its link; stamped `offset_s` from now.
    fn distances_msg(&self, entry: Option<&LinkDistance>, offset_s: f64) -> LinkDistances {
        let mut links: Vec<LinkDistance> =
            self.link_names.iter().map(|n| LinkDistance { link_name: n.clone(), ..Default::default() }).collect();
        if let Some(e) = entry {
            let i = self.link_names.iter().position(|n| *n == e.link_name).unwrap_or(0);
            links[i] = e.clone();
        }
        LinkDistances { header: self.header(offset_s), links, min_index: -1, backend: "test".into(), ..Default::default() }
    }

    fn clear_distances(&self) {
        self.distances.publish(self.distances_msg(None, 0.0)).expect("pub");
    }

    fn human_far(&self) {
        self.human
            .publish(HumanState {
                header: self.header(0.0),
                mode: HumanState::MODE_FAR,
                present: false,
                speed_scale: 0.3,
                ..Default::default()
            })
            .expect("pub");
    }

    fn send(&self, id: u32, kind: u8, goal: nalgebra::Vector3<f64>, parameters: Vec<f64>) {
        self.command
            .publish(MotionCommand {
                id,
                kind,
                label: format!("test {id}"),
                parameters,
                goal: Pose {
                    position: Point { x: goal.x, y: goal.y, z: goal.z },
                    orientation: Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 },
                },
                nominal_speed: 0.0,
                hold_orientation: true,
                ..Default::default()
            })
            .expect("pub");
    }

    /// Pumps for `wall_s` seconds, feeding distances and human state every 10 ms when `feed`.
    fn run_for(&mut self, wall_s: f64, feed: bool, mut until: impl FnMut(&Client) -> bool) -> bool {
        let end = Instant::now() + Duration::from_secs_f64(wall_s);
        let mut next_feed = Instant::now();
        while Instant::now() < end {
            if feed && Instant::now() >= next_feed {
                self.clear_distances();
                self.human_far();
                next_feed += Duration::from_millis(10);
            }
            self.pump();
            if until(self) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        false
    }
}

fn held_still(c: &Client) -> bool {
    c.max_speed() < 1e-6
}

fn status_is(c: &Client, id: u32, state: u8) -> bool {
    c.last_status.as_ref().is_some_and(|s| s.command_id == id && s.state == state)
}

#[test]
fn lwr_sim_and_ds_controller_reach_a_goal() {
    let mut g = Graph::start(60.0);
    let x0 = g.tcp();
    let goal = x0 + nalgebra::Vector3::new(0.05, 0.12, -0.04);
    // Without fresh distances and human data the robot is held.
    assert!(g.client.run_for(3.0, false, |c| c.last_status.as_ref().is_some_and(|s| s.state == MotionStatus::STATE_HELD)));
    g.client.send(1, MotionCommand::KIND_LINEAR, goal, vec![3.0]);
    let t0 = g.client.sim_time();
    let ok = g.client.run_for(20.0, true, |c| status_is(c, 1, MotionStatus::STATE_CONVERGED));
    let t1 = g.client.sim_time();
    let err = (g.tcp() - goal).norm();
    eprintln!("reach: converged {ok} after {:.2} s of sim time, TCP error {err:.4} m", t1 - t0);
    assert!(ok, "no CONVERGED status; last {:?}", g.client.last_status);
    assert!(err < 0.01, "TCP {err} m from the goal");
    let s = g.client.last_status.as_ref().expect("status");
    assert!(s.goal_error < 0.01 && s.reason.is_empty(), "{s:?}");

    // A learned primitive (C-GMR fitted here, sent as JSON in parameters_json) to a new goal.
    let goal2 = goal + nalgebra::Vector3::new(-0.06, -0.10, 0.05);
    let demos: Vec<cowork_motion::Demonstration> = (0..3)
        .map(|i| {
            let t: Vec<f64> = (0..101).map(|k| k as f64 * 0.02).collect();
            let a = 0.04 + 0.01 * i as f64;
            let pos = t.iter().flat_map(|t| {
                let s = (1.0 - t / 2.0).powi(2);
                [a * s, 0.10 * s, -0.05 * s]
            });
            cowork_motion::Demonstration::new(3, t.clone(), pos.collect(), None).expect("demo")
        })
        .collect();
    let opts = cowork_motion::model::FitOptions {
        components: cowork_motion::Components::Fixed(2),
        ..Default::default()
    };
    let cgmr = cowork_motion::model::Model::fit(cowork_motion::model::ModelKind::Cgmr, &demos, &opts).expect("fit");
    g.client
        .command
        .publish(MotionCommand {
            id: 2,
            kind: MotionCommand::KIND_CGMR,
            label: "test cgmr".into(),
            parameters_json: serde_json::to_string(&cgmr).expect("json"),
            goal: Pose {
                position: Point { x: goal2.x, y: goal2.y, z: goal2.z },
                orientation: Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 },
            },
            hold_orientation: true,
            ..Default::default()
        })
        .expect("pub");
    let ok = g.client.run_for(30.0, true, |c| status_is(c, 2, MotionStatus::STATE_CONVERGED));
    let err = (g.tcp() - goal2).norm();
    eprintln!("C-GMR over DDS: converged {ok}, TCP error {err:.4} m");
    assert!(ok, "C-GMR command did not converge; last {:?}", g.client.last_status);
    assert!(err < 0.01, "TCP {err} m from the C-GMR goal");
}

#[test]
fn watchdog_stops_on_lost_distances_and_resumes() {
    let mut g = Graph::start(80.0);
    let x0 = g.tcp();
    let goal = x0 + nalgebra::Vector3::new(0.0, 0.30, 0.0);
    // A constant-speed motion at 0.1 m/s: 3 s over 30 cm, long enough to cut the data mid-way.
    g.client.command
        .publish(MotionCommand {
            id: 7,
            kind: MotionCommand::KIND_CONSTANT_SPEED,
            goal: Pose {
                position: Point { x: goal.x, y: goal.y, z: goal.z },
                orientation: Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 },
            },
            nominal_speed: 0.1,
            hold_orientation: true,
            ..Default::default()
        })
        .expect("pub");
    let moving = g.client.run_for(10.0, true, |c| status_is(c, 7, MotionStatus::STATE_RUNNING) && c.max_speed() > 0.05);
    assert!(moving, "never moving: {:?}", g.client.last_status);
    g.client.run_for(0.3, true, |_| false);
    // Kill the distance stream (the human state keeps coming).
    let lost_at = g.client.sim_time();
    let speed_at_loss = g.client.max_speed();
    let params: Params =
        cowork_ros::params::load(&root().join("config/ds_controller.yaml"), "ds_controller").expect("params");
    let bound = params.controller.stale_after_s;
    let mut held_at = None;
    let mut stopped_at = None;
    let end = Instant::now() + Duration::from_secs(5);
    let mut next = Instant::now();
    while Instant::now() < end && stopped_at.is_none() {
        if Instant::now() >= next {
            g.client.human_far();
            next += Duration::from_millis(10);
        }
        g.client.pump();
        if held_at.is_none()
            && g.client.last_status.as_ref().is_some_and(|s| s.state == MotionStatus::STATE_HELD && s.reason.contains("/fded/distances"))
        {
            held_at = Some(g.client.sim_time());
        }
        if held_at.is_some() && g.client.max_speed() < 1e-6 {
            stopped_at = Some(g.client.sim_time());
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    let reason = g.client.last_status.as_ref().map(|s| s.reason.clone()).unwrap_or_default();
    let (Some(held), Some(stopped)) = (held_at, stopped_at) else {
        panic!("not held/stopped after losing distances: held {held_at:?}, stopped {stopped_at:?}, {reason}");
    };
    // Bound + braking time from the joint speed at the loss (|q̇| / 10 rad/s², the configured
    // deceleration) + slack for DDS delivery of the last distances, the command and the joint
    // states on a loaded machine (all in simulated time, which runs at most at wall rate).
    let braking = speed_at_loss / 10.0;
    let slack = 0.25;
    eprintln!(
        "watchdog: joint speed {speed_at_loss:.3} rad/s at the loss; held {:.3} s and stopped {:.3} s (sim) after the \
         last distances (bound {bound} s + braking {braking:.3} s + slack {slack} s); reason {reason:?}",
        held - lost_at,
        stopped - lost_at
    );
    assert!(reason.contains("stale /fded/distances"), "{reason}");
    assert!(
        stopped - lost_at <= bound + braking + slack,
        "stopped {} s after the loss",
        stopped - lost_at
    );
    // Data returns: the motion resumes and converges.
    let resumed = g.client.run_for(10.0, true, |c| status_is(c, 7, MotionStatus::STATE_RUNNING) && c.max_speed() > 0.01);
    assert!(resumed, "did not resume: {:?}", g.client.last_status);
    let done = g.client.run_for(20.0, true, |c| status_is(c, 7, MotionStatus::STATE_CONVERGED));
    assert!(done, "did not converge after resuming: {:?}", g.client.last_status);
}

#[test]
fn bad_input_is_rejected_with_a_reason_and_the_robot_held() {
    let mut g = Graph::start(80.0);
    let x0 = g.tcp();

    // Unknown primitive kind.
    g.client.send(1, 9, x0, vec![]);
    assert!(g.client.run_for(5.0, true, |c| status_is(c, 1, MotionStatus::STATE_ABORTED)));
    let s = g.client.last_status.clone().expect("status");
    assert!(s.reason.contains("unknown primitive kind 9"), "{s:?}");
    assert!(g.client.run_for(2.0, true, held_still), "robot moves after an aborted command");

    // Goal out of reach.
    g.client.send(2, MotionCommand::KIND_LINEAR, nalgebra::Vector3::new(3.0, 0.0, 0.5), vec![]);
    assert!(g.client.run_for(5.0, true, |c| status_is(c, 2, MotionStatus::STATE_ABORTED)));
    let s = g.client.last_status.clone().expect("status");
    assert!(s.reason.contains("out of reach"), "{s:?}");

    // NaN goal.
    g.client.send(3, MotionCommand::KIND_LINEAR, nalgebra::Vector3::new(f64::NAN, 0.0, 0.5), vec![]);
    assert!(g.client.run_for(5.0, true, |c| status_is(c, 3, MotionStatus::STATE_ABORTED)));
    assert!(g.client.last_status.as_ref().is_some_and(|s| s.reason.contains("not finite")));

    // A valid motion, then NaN / zero-normal distances mid-motion: held with the link named.
    let goal = x0 + nalgebra::Vector3::new(0.0, 0.25, 0.0);
    g.client.send(4, MotionCommand::KIND_LINEAR, goal, vec![1.0]);
    assert!(g.client.run_for(10.0, true, |c| status_is(c, 4, MotionStatus::STATE_RUNNING) && c.max_speed() > 0.02));
    for (what, entry) in [
        ("distance", LinkDistance { link_name: "lwr_link_4".into(), distance: f64::NAN, normal: Vector3 { x: 1.0, y: 0.0, z: 0.0 }, valid: true, ..Default::default() }),
        ("normal", LinkDistance { link_name: "lwr_link_4".into(), distance: 0.2, normal: Vector3 { x: f64::INFINITY, y: 0.0, z: 0.0 }, valid: true, ..Default::default() }),
        ("zero", LinkDistance { link_name: "lwr_link_4".into(), distance: 0.2, normal: Vector3::default(), valid: true, ..Default::default() }),
    ] {
        let reason = if what == "zero" { "zero obstacle normal" } else { what };
        let seen = held_while(&mut g.client, 4, |c| c.distances_msg(Some(&entry), 0.0), &["lwr_link_4", reason]);
        assert!(seen, "{what}: no HELD status naming lwr_link_4; last {:?}", g.client.last_status);
        assert!(held_still(&g.client), "{what}: robot not held");
        // Valid data again: the motion resumes.
        assert!(g.client.run_for(10.0, true, |c| status_is(c, 4, MotionStatus::STATE_RUNNING) && c.max_speed() > 0.005), "{what}: no resume");
    }

    // An unknown link name is rejected by the adapter.
    let mut bad = g.client.distances_msg(None, 0.0);
    bad.links[4] = LinkDistance { link_name: "elbow".into(), distance: 0.2, normal: Vector3 { x: 1.0, y: 0.0, z: 0.0 }, valid: true, ..Default::default() };
    g.client.distances.publish(bad).expect("pub");
    assert!(
        g.client.run_for(5.0, false, |c| c.statuses.iter().any(|(_, s)| s.reason.contains("unknown link name \"elbow\""))),
        "no status naming the unknown link; last {:?}",
        g.client.last_status
    );
    assert!(g.client.run_for(5.0, false, held_still), "robot not held after a malformed distances message");
    assert!(g.client.run_for(10.0, true, |c| status_is(c, 4, MotionStatus::STATE_RUNNING) && c.max_speed() > 0.005), "no resume");

    // Fail closed on what used to read as "no obstacle" or as fresh: an empty distances
    // message, a link named twice (another one missing), distances measured 0.5 s ago (delivered now), distances stamped 1 s in the
    // future (a clock that went back).
    type Case = (&'static str, fn(&Client) -> LinkDistances, &'static str);
    let cases: [Case; 4] = [
        ("empty", |c| LinkDistances { header: c.header(0.0), min_index: -1, ..Default::default() }, "one entry per link"),
        // Link 0 twice, link 1 missing: a fake all-clear for link 1.
        ("duplicate", |c| {
            let mut m = c.distances_msg(None, 0.0);
            m.links[1].link_name = m.links[0].link_name.clone();
            m
        }, "second entry"),
        ("late", |c| c.distances_msg(None, -0.5), "exceeds"),
        ("future", |c| c.distances_msg(None, 1.0), "negative"),
    ];
    for (what, make, reason) in cases {
        let seen = held_while(&mut g.client, 4, make, &[reason]);
        assert!(seen, "{what}: no HELD status with {reason:?}; last {:?}", g.client.last_status);
        assert!(held_still(&g.client), "{what}: robot not held");
        assert!(g.client.run_for(10.0, true, |c| status_is(c, 4, MotionStatus::STATE_RUNNING) && c.max_speed() > 0.005), "{what}: no resume");
    }
}

/// Publishes `make(client)` as the distances (and a far, absent person) every 10 ms for up to
/// 5 s, until command `id` is HELD with a reason containing every one of `reason_has` and the
/// robot is still; whether that HELD status was seen.
fn held_while(c: &mut Client, id: u32, make: impl Fn(&Client) -> LinkDistances, reason_has: &[&str]) -> bool {
    let mut next = Instant::now();
    let end = Instant::now() + Duration::from_secs(5);
    let mut seen = false;
    let mut checked = c.statuses.len();
    while Instant::now() < end && !(seen && held_still(c)) {
        if Instant::now() >= next {
            c.distances.publish(make(c)).expect("pub");
            c.human_far();
            next += Duration::from_millis(10);
        }
        c.pump();
        seen |= c.statuses[checked..].iter().any(|(_, s)| {
            s.command_id == id && s.state == MotionStatus::STATE_HELD && reason_has.iter().all(|r| s.reason.contains(r))
        });
        checked = c.statuses.len();
        std::thread::sleep(Duration::from_millis(1));
    }
    seen
}
