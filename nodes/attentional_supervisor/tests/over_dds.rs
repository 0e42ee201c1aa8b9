//! The node's real `run` loop over DDS on loopback (a private domain), driven by a client node
//! in the same process that plays the robot manager and the person: pouring taught through
//! `/robot_stream` segments and `/speech_command` (LTM saved by `--save-ltm`), then executed on
//! `/clock` time; cooperative coffee on the wall clock, where the person takes the bottle and
//! the robot switches to add(coffee); the dual-arm pizza with two robot managers on
//! `/left/...` and `/right/...` and the arm bases on `/tf_static`. Stimulus →
//! `/supervisor/action` latencies are printed
//! (`cargo test -p attentional_supervisor --test over_dds -- --nocapture`).

mod common;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use attentional_supervisor::{Params, RunOptions, SupervisorNode};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::{
    ActionCommand, ActionEvent, ActionSegment, ObjectState, ObjectStream, RobotStream, WmNode, WorkingMemory,
};
use cowork_msgs::rosgraph_msgs::Clock;
use cowork_msgs::std_msgs::String as RosString;
use cowork_msgs::topics;
use cowork_ros::{NodeConfig, Publisher, RosNode, Subscription};
use cowork_supervisor::{Ltm, RunConfig, Supervisor, SupervisorConfig, parse_jsonl, runner};

const TICK_S: f64 = 0.01;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn private_domain() -> u16 {
    cowork_ros::domain::test_domain("attentional_supervisor test")
}

fn kitchen() -> Ltm {
    Ltm::load(&root().join("config/tasks/kitchen.schema")).expect("kitchen LTM")
}

struct Running {
    stop: Arc<AtomicBool>,
    handle: JoinHandle<anyhow::Result<Supervisor>>,
}

impl Running {
    fn finish(self) -> Supervisor {
        self.stop.store(true, Ordering::SeqCst);
        self.handle.join().expect("node thread").expect("run")
    }
}

fn start(domain: u16, ltm: Ltm, task: &str, use_sim_time: bool, save_ltm: Option<&Path>) -> Running {
    let params = Params { use_sim_time, ..Params::default() };
    let sup = Supervisor::new(ltm, task, params.attention.clone()).expect("task");
    let node = RosNode::new(
        "attentional_supervisor",
        &NodeConfig { domain_id: Some(domain), use_sim_time, ..Default::default() },
    )
    .expect("node");
    let stop = Arc::new(AtomicBool::new(false));
    let options = RunOptions { duration_s: Some(60.0), stop: Some(Arc::clone(&stop)) };
    let save_ltm = save_ltm.map(Path::to_owned);
    let sn = SupervisorNode::new(sup, &params);
    let handle = std::thread::spawn(move || attentional_supervisor::run(node, sn, save_ltm.as_deref(), &options));
    Running { stop, handle }
}

#[derive(Debug, Clone, Copy)]
struct Latency {
    /// Stimulus published → command received (ms).
    total_ms: f64,
    /// Stimulus published → the tick that decided (command stamp), same clock (ms).
    to_tick_ms: f64,
}

/// The robot manager and the person, on the client side.
struct Client {
    node: RosNode,
    objects_pub: Publisher<ObjectStream>,
    robot_pub: Publisher<RobotStream>,
    speech_pub: Publisher<RosString>,
    clock_pub: Option<(Publisher<Clock>, f64)>,
    actions: Subscription<ActionCommand>,
    wm: Subscription<WorkingMemory>,
    started: Instant,
    objects: Vec<ObjectState>,
    held: Option<String>,
    auto_complete: bool,
    action_s: f64,
    due: Option<(Instant, String)>,
    stimulus: Option<(Instant, f64)>,
    latencies: Vec<Latency>,
    commands: Vec<ActionCommand>,
    last_wm: Option<WorkingMemory>,
    wm_count: usize,
    last_periodic: Instant,
}

impl Client {
    /// `sim_clock_s`: publish `/clock` from this time on, advancing with the wall clock.
    fn new(domain: u16, sim_clock_s: Option<f64>) -> Self {
        let mut node =
            RosNode::new("test_robot_manager", &NodeConfig { domain_id: Some(domain), ..Default::default() })
                .expect("client node");
        let objects_pub = node.advertise(&topics::OBJECT_STREAM).expect("pub");
        let robot_pub = node.advertise(&topics::ROBOT_STREAM).expect("pub");
        let speech_pub = node.advertise(&topics::SPEECH_COMMAND).expect("pub");
        let clock_pub = sim_clock_s.map(|t0| (node.advertise(&topics::CLOCK).expect("pub"), t0));
        let actions = node.subscribe(&topics::SUPERVISOR_ACTION).expect("sub");
        let wm = node.subscribe(&topics::WORKING_MEMORY).expect("sub");
        let mut c = Self {
            node,
            objects_pub,
            robot_pub,
            speech_pub,
            clock_pub,
            actions,
            wm,
            started: Instant::now(),
            objects: Vec::new(),
            held: None,
            auto_complete: true,
            action_s: 0.025,
            due: None,
            stimulus: None,
            latencies: Vec::new(),
            commands: Vec::new(),
            last_wm: None,
            wm_count: 0,
            last_periodic: Instant::now(),
        };
        let deadline = Instant::now() + Duration::from_secs(15);
        while !(c.objects_pub.subscription_count(&c.node) > 0
            && c.robot_pub.subscription_count(&c.node) > 0
            && c.speech_pub.subscription_count(&c.node) > 0
            && c.actions.publisher_count(&c.node) > 0)
        {
            assert!(Instant::now() < deadline, "the supervisor node was not discovered within 15 s");
            c.pump();
        }
        // Let the node's side of the matching settle before one-shot messages.
        c.pump_for(0.3);
        c
    }

    /// Time on the node's clock (s): `/clock` time when simulated, else the wall clock.
    fn now_s(&self) -> f64 {
        match &self.clock_pub {
            Some((_, t0)) => t0 + self.started.elapsed().as_secs_f64(),
            None => SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_secs_f64()).unwrap_or(0.0),
        }
    }

    fn robot_state(&self, done: Option<&str>, segments: &[(&str, u8)]) -> RobotStream {
        RobotStream {
            gripper_state: if self.held.is_some() { RobotStream::GRIPPER_CLOSED } else { RobotStream::GRIPPER_OPEN },
            held_object: self.held.clone().unwrap_or_default(),
            events: done
                .map(|l| ActionEvent { label: l.into(), kind: 0, command_id: 0, done: true, ..Default::default() })
                .into_iter()
                .collect(),
            segments: segments
                .iter()
                .map(|(l, k)| ActionSegment { label: (*l).into(), kind: *k, ..Default::default() })
                .collect(),
            ..Default::default()
        }
    }

    fn set_objects(&mut self, list: &[(&str, f64, bool)]) {
        for (n, d, v) in list {
            let o = ObjectState { name: (*n).into(), robot_distance: *d, visible: *v, ..Default::default() };
            match self.objects.iter_mut().find(|x| x.name == *n) {
                Some(x) => *x = o,
                None => self.objects.push(o),
            }
        }
    }

    fn publish_objects(&self) {
        self.objects_pub
            .publish(ObjectStream { objects: self.objects.clone(), ..Default::default() })
            .expect("publish objects");
    }

    /// Marks the moment a stimulus went out; the next action command measures from it.
    fn mark_stimulus(&mut self) {
        self.stimulus = Some((Instant::now(), self.now_s()));
    }

    fn say(&self, text: &str) {
        self.speech_pub.publish(RosString { data: text.into() }).expect("publish speech");
    }

    fn segment(&self, label: &str, kind: u8) {
        self.robot_pub.publish(self.robot_state(None, &[(label, kind)])).expect("publish segment");
    }

    /// One client step: `/clock`, periodic state (every 30 ms), completing due actions,
    /// receiving commands and snapshots.
    fn pump(&mut self) {
        if let Some((clock, _)) = &self.clock_pub {
            clock.publish(Clock { clock: Time::from_secs_f64(self.now_s()) }).expect("publish clock");
        }
        if self.last_periodic.elapsed() >= Duration::from_millis(30) {
            self.last_periodic = Instant::now();
            // Nothing perceived yet: no stream (the node waits for the first one).
            if !self.objects.is_empty() {
                self.publish_objects();
            }
            self.robot_pub.publish(self.robot_state(None, &[])).expect("publish robot state");
        }
        if let Some((at, label)) = self.due.clone()
            && Instant::now() >= at
        {
            self.due = None;
            if label.starts_with("close") {
                self.held = label.split(['(', ')']).nth(1).map(str::to_owned);
            } else if label.starts_with("open") {
                self.held = None;
            }
            self.robot_pub.publish(self.robot_state(Some(&label), &[])).expect("publish done");
            self.mark_stimulus();
        }
        while let Some(cmd) = self.actions.take() {
            if !cmd.stop
                && let Some((at, at_s)) = self.stimulus.take()
            {
                self.latencies.push(Latency {
                    total_ms: at.elapsed().as_secs_f64() * 1e3,
                    to_tick_ms: (cmd.header.stamp.to_secs_f64() - at_s) * 1e3,
                });
            }
            if !cmd.stop && self.auto_complete {
                // 25..34 ms, so done events fall at every phase of the node's tick grid.
                let jitter_s = f64::from((self.commands.len() as u32 * 7) % 10) * 1e-3;
                let at = Instant::now() + Duration::from_secs_f64(self.action_s + jitter_s);
                self.due = Some((at, cmd.label.clone()));
            }
            if cmd.stop && self.due.as_ref().is_some_and(|(_, l)| *l == cmd.label) {
                self.due = None;
            }
            self.commands.push(cmd);
        }
        while let Some(w) = self.wm.take() {
            self.wm_count += 1;
            self.last_wm = Some(w);
        }
        std::thread::sleep(Duration::from_millis(1));
    }

    fn pump_for(&mut self, s: f64) {
        let end = Instant::now() + Duration::from_secs_f64(s);
        while Instant::now() < end {
            self.pump();
        }
    }

    fn pump_until(&mut self, what: &str, timeout_s: f64, mut f: impl FnMut(&Self) -> bool) {
        let end = Instant::now() + Duration::from_secs_f64(timeout_s);
        while !f(self) {
            assert!(Instant::now() < end, "timed out waiting for {what}; commands so far: {:?}", self.labels());
            self.pump();
        }
    }

    fn labels(&self) -> Vec<String> {
        self.commands.iter().map(|c| if c.stop { format!("stop {}", c.label) } else { c.label.clone() }).collect()
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn report(case: &str, lat: &[Latency]) -> (f64, f64) {
    let mut total: Vec<f64> = lat.iter().map(|l| l.total_ms).collect();
    let mut tick: Vec<f64> = lat.iter().map(|l| l.to_tick_ms).collect();
    let (mt, mx) = (median(&mut total), total.iter().copied().fold(0.0, f64::max));
    let (mk, mxk) = (median(&mut tick), tick.iter().copied().fold(f64::MIN, f64::max));
    println!(
        "{case}: {} stimuli; stimulus -> /supervisor/action received: median {mt:.2} ms, max {mx:.2} ms; \
         stimulus -> deciding tick (command stamp): median {mk:.2} ms, max {mxk:.2} ms (tick period {:.0} ms)",
        lat.len(),
        TICK_S * 1e3
    );
    (mt, mx)
}

/// Latency bounds: the supervisor answers in the tick after the stimulus arrives, so a
/// stimulus waits at most one period for its tick; DDS adds a millisecond or so each way on
/// loopback. The max bound is loose because the test machine is shared.
fn check_latencies(case: &str, lat: &[Latency]) {
    assert!(!lat.is_empty());
    let (median_total, max_total) = report(case, lat);
    assert!(median_total <= TICK_S * 1e3 + 10.0, "{case}: median latency {median_total:.2} ms > one tick + 10 ms");
    assert!(max_total <= 250.0, "{case}: max latency {max_total:.2} ms");
}

#[test]
fn pouring_taught_then_executed_over_dds() {
    let dir = tempfile::tempdir().expect("tmp");
    let saved = dir.path().join("learned.schema");

    // Teaching: segments from the robot manager, speech from the person.
    let domain = private_domain();
    let node = start(domain, kitchen(), "pourDrink", false, Some(&saved));
    let mut c = Client::new(domain, None);
    c.set_objects(&[("water", 0.6, true), ("cup", 0.9, true)]);
    c.publish_objects();
    c.pump_for(0.1);
    c.say("teach");
    c.pump_for(0.2);
    c.set_objects(&[("water", 0.1, true)]);
    c.publish_objects();
    c.segment("foa1(water)", ActionSegment::KIND_FOA);
    c.pump_for(0.05);
    c.segment("noa2(water)", ActionSegment::KIND_NOA);
    c.pump_for(0.05);
    c.say("gripper close");
    c.segment("close3(water)", ActionSegment::KIND_GRIPPER);
    c.held = Some("water".into());
    c.robot_pub.publish(c.robot_state(None, &[])).expect("gripper closed");
    c.pump_for(0.05);
    for (l, k) in [("foa4(cup)", 1), ("noa5(cup)", 0), ("foa6(world)", 1), ("noa7(world)", 0)] {
        c.segment(l, k);
        c.pump_for(0.05);
    }
    c.say("gripper open");
    c.segment("open8(world)", ActionSegment::KIND_GRIPPER);
    c.held = None;
    c.robot_pub.publish(c.robot_state(None, &[])).expect("gripper open");
    c.pump_for(0.2);
    c.say("done");
    c.pump_for(0.3);
    assert!(c.commands.is_empty(), "nothing commanded while the task is untaught: {:?}", c.labels());
    assert!(c.wm_count >= 3, "working memory snapshots at 10 Hz: got {}", c.wm_count);
    let learned = node.finish();
    drop(c);
    let text = std::fs::read_to_string(&saved).expect("--save-ltm file written");
    assert_eq!(text, learned.ltm().to_text());
    let mut reference = Supervisor::new(kitchen(), "pourDrink", SupervisorConfig::default()).expect("task");
    let script =
        std::fs::read_to_string(root().join("nodes/lib/supervisor/tests/data/pour_teach.jsonl")).expect("script");
    runner::run(&mut reference, &parse_jsonl(&script).expect("script"), &RunConfig::default(), |_, _, _, _| {});
    assert_eq!(text, reference.ltm().to_text(), "learned over DDS = learned from the script");

    // Execution of the saved LTM, on /clock time starting at 1000 s.
    let domain = private_domain();
    let node = start(domain, Ltm::load(&saved).expect("reload"), "pourDrink", true, None);
    let mut c = Client::new(domain, Some(1000.0));
    c.set_objects(&[("water", 0.6, true), ("cup", 0.9, true)]);
    c.publish_objects();
    c.mark_stimulus();
    c.pump_until("the whole pouring", 10.0, |c| c.commands.iter().any(|x| x.label == "open8(world)"));
    c.pump_for(0.3);
    let labels = c.labels();
    assert_eq!(
        labels,
        [
            "foa1(water)",
            "noa2(water)",
            "close3(water)",
            "foa4(cup)",
            "noa5(cup)",
            "foa6(world)",
            "noa7(world)",
            "open8(world)"
        ]
    );
    assert_eq!(c.commands.iter().map(|x| x.id).collect::<Vec<_>>(), (1..=8).collect::<Vec<_>>());
    for cmd in &c.commands {
        let s = cmd.header.stamp.to_secs_f64();
        assert!((1000.0..1100.0).contains(&s), "stamp {s} is not /clock time");
    }
    let wm = c.last_wm.clone().expect("snapshots");
    assert!(wm.header.stamp.to_secs_f64() >= 1000.0);
    assert!(wm.nodes.iter().any(|n| n.name == "pourDrink" && n.done), "pourDrink done in the last snapshot");
    let lat = c.latencies.clone();
    let sup = node.finish();
    assert!(sup.task_accomplished());
    check_latencies("pouring (sim time)", &lat);
}

#[test]
fn cooperative_coffee_replans_within_a_tick_over_dds() {
    let mut teacher = Supervisor::new(kitchen(), "prepareCoffee", SupervisorConfig::default()).expect("task");
    let script =
        std::fs::read_to_string(root().join("nodes/lib/supervisor/tests/data/coffee_teach.jsonl")).expect("script");
    runner::run(&mut teacher, &parse_jsonl(&script).expect("script"), &RunConfig::default(), |_, _, _, _| {});

    let domain = private_domain();
    let node = start(domain, teacher.ltm().clone(), "prepareCoffee", false, None);
    let mut c = Client::new(domain, None);
    c.auto_complete = false;
    c.set_objects(&[("water", 0.4, true), ("coffee", 0.8, true), ("spoon", 1.2, true), ("cup", 0.8, true)]);
    c.publish_objects();
    c.pump_until("the first command", 5.0, |c| !c.commands.is_empty());
    assert_eq!(c.labels(), ["foa1(water)"]);
    c.latencies.clear(); // node start-up, not a replanning

    // Bad input on the way: the node warns and keeps going.
    c.say("make me a sandwich");
    c.set_objects(&[("teapot", 0.2, true)]);
    c.pump_for(0.1);

    // The person takes the bottle: water is no longer visible.
    c.set_objects(&[("water", f64::NAN, false)]);
    c.publish_objects();
    c.mark_stimulus();
    c.pump_until("the switch to coffee", 2.0, |c| c.commands.len() >= 2);
    let switch = c.latencies[0];
    assert_eq!(c.labels(), ["foa1(water)", "foa9(coffee)"]);
    c.say("human add(water)");
    c.auto_complete = true;
    c.due = Some((Instant::now() + Duration::from_secs_f64(c.action_s), "foa9(coffee)".into()));
    c.pump_until("add(coffee)", 10.0, |c| c.commands.iter().any(|x| x.label == "open16(world)"));
    c.pump_for(0.4);
    assert_eq!(
        c.labels(),
        [
            "foa1(water)",
            "foa9(coffee)",
            "noa10(coffee)",
            "close11(coffee)",
            "foa12(cup)",
            "noa13(cup)",
            "foa14(world)",
            "noa15(world)",
            "open16(world)"
        ],
        "use(spoon) must wait for water.added (the person's part)"
    );
    let wm = c.last_wm.clone().expect("snapshots");
    let water = wm.nodes.iter().find(|n| n.name == "add(water)").expect("add(water) in the snapshot");
    assert_eq!(water.assigned_to, WmNode::ASSIGNED_HUMAN);
    assert!(
        wm.nodes.iter().any(|n| n.name == "add(coffee)" && n.done) || !wm.nodes.iter().any(|n| n.name == "add(coffee)")
    );
    let lat = c.latencies.clone();
    let sup = node.finish();
    assert!(!sup.task_accomplished());
    println!(
        "cooperative switch (water taken by the person -> foa9(coffee)): {:.2} ms received, {:.2} ms to the deciding tick",
        switch.total_ms, switch.to_tick_ms
    );
    // One period plus the inbound DDS hop; 15 ms of slack for a loaded, shared test machine.
    assert!(switch.to_tick_ms <= TICK_S * 1e3 + 15.0, "switch decided {:.2} ms after the stimulus", switch.to_tick_ms);
    check_latencies("cooperative coffee (wall clock)", &lat);
}

/// Two arms over DDS: the node reads `/tf_static`, `/left/object_stream`,
/// `/right/object_stream`, `/left/robot_stream` and `/right/robot_stream` (a client plays both
/// robot managers, each answering only its arm's commands on its own robot stream) and
/// commands each arm by name until the pizza is done, never both arms on the pizza.
#[test]
fn two_arms_make_the_pizza_over_dds() {
    use common::{BASES, object_stream, taught_pizza, tf_static};

    let domain = private_domain();
    let node = start(domain, taught_pizza(), "pizza", false, None);
    let mut client =
        RosNode::new("test_robot_managers", &NodeConfig { domain_id: Some(domain), ..Default::default() }).expect("client node");
    let tf = client.advertise(&topics::TF_STATIC).expect("pub");
    let mut objects = Vec::new();
    let mut robots = Vec::new();
    for b in &BASES {
        let ns = format!("/{}", b.arm);
        objects.push(client.advertise_in(&topics::OBJECT_STREAM, &ns).expect("pub"));
        robots.push(client.advertise_in(&topics::ROBOT_STREAM, &ns).expect("pub"));
    }
    let actions = client.subscribe(&topics::SUPERVISOR_ACTION).expect("sub");
    let deadline = Instant::now() + Duration::from_secs(15);
    while !(tf.subscription_count(&client) > 0
        && objects.iter().all(|p| p.subscription_count(&client) > 0)
        && robots.iter().all(|p| p.subscription_count(&client) > 0)
        && actions.publisher_count(&client) > 0)
    {
        assert!(Instant::now() < deadline, "the supervisor's per-arm readers were not discovered within 15 s");
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(300));
    tf.publish(tf_static(&BASES)).expect("publish /tf_static");

    let robot_state = |held: &Option<String>, done: Option<&str>| RobotStream {
        gripper_state: if held.is_some() { RobotStream::GRIPPER_CLOSED } else { RobotStream::GRIPPER_OPEN },
        held_object: held.clone().unwrap_or_default(),
        events: done.map(|l| ActionEvent { label: l.into(), done: true, ..Default::default() }).into_iter().collect(),
        ..Default::default()
    };
    // Per arm: held object, running (label, due).
    let mut held: [Option<String>; 2] = [None, None];
    let mut running: [Option<(String, Instant)>; 2] = [None, None];
    let mut commands: Vec<ActionCommand> = Vec::new();
    let mut last_periodic = Instant::now() - Duration::from_secs(1);
    let end = Instant::now() + Duration::from_secs(20);
    // Until the last action (the second pour's `open32(world)`) was commanded and done.
    while !(commands.iter().any(|c| c.label.ends_with("open32(world)")) && running.iter().all(Option::is_none)) {
        assert!(Instant::now() < end, "the pizza was not done within 20 s: {:?}", commands.iter().map(|c| (&c.arm, &c.label)).collect::<Vec<_>>());
        if last_periodic.elapsed() >= Duration::from_millis(30) {
            last_periodic = Instant::now();
            for (i, b) in BASES.iter().enumerate() {
                objects[i].publish(object_stream(b, &common::OBJECTS)).expect("publish objects");
                robots[i].publish(robot_state(&held[i], None)).expect("publish robot state");
            }
        }
        for i in 0..2 {
            if let Some((label, due)) = running[i].clone()
                && Instant::now() >= due
            {
                if label.contains("close") {
                    held[i] = label.split(['(', ')']).nth(1).map(str::to_owned);
                } else if label.contains("open") {
                    held[i] = None;
                }
                running[i] = None;
                robots[i].publish(robot_state(&held[i], Some(&label))).expect("publish done");
            }
        }
        while let Some(c) = actions.take() {
            let i = BASES.iter().position(|b| b.arm == c.arm).unwrap_or_else(|| panic!("a command for an undeclared arm: {c:?}"));
            assert_eq!(c.label.chars().next(), c.arm.chars().next(), "{c:?}: taught on that arm");
            if c.stop {
                if running[i].as_ref().is_some_and(|(l, _)| *l == c.label) {
                    running[i] = None;
                }
            } else {
                running[i] = Some((c.label.clone(), Instant::now() + Duration::from_millis(25)));
            }
            commands.push(c);
        }
        let on_pizza = |r: &Option<(String, Instant)>| r.as_ref().is_some_and(|(l, _)| l.contains("(pizza)"));
        assert!(!(on_pizza(&running[0]) && on_pizza(&running[1])), "both arms on the pizza");
        std::thread::sleep(Duration::from_millis(1));
    }
    std::thread::sleep(Duration::from_millis(200));
    let sup = node.finish();
    assert!(sup.task_accomplished());
    for arm in ["left", "right"] {
        assert!(commands.iter().any(|c| c.arm == arm && !c.stop && c.label.contains("(pizza)")), "{arm} poured: {commands:?}");
    }
    assert_eq!(commands.first().map(|c| (c.arm.as_str(), c.label.as_str())), Some(("left", "lfoa1(tomato)")));
}
