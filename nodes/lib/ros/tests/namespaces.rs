//! Per-arm namespaces over DDS: a node in `/left` writes its per-arm topics under `/left`
//! (`/left/joint_states`), not on the root name; a node serving several arms writes an arm's
//! topic in that arm's namespace with `advertise_in`; graph topics keep their one name.

use std::time::{Duration, Instant};

use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::topics::{CLOCK, JOINT_STATES};
use cowork_ros::{NodeConfig, RosNode, Subscription, qos};

/// 230..=232: above the 100..220 of the other DDS tests and the 200..230 of
/// `cowork`'s graph_introspection test.
fn domain() -> u16 {
    230 + (std::process::id() % 3) as u16
}

fn arm_state(arm: &str) -> JointState {
    JointState { name: vec![arm.to_owned()], position: vec![0.5], ..Default::default() }
}

/// Arms named in the messages `sub` has received so far, appended to `seen`.
fn drain(sub: &Subscription<JointState>, seen: &mut Vec<String>) {
    while let Some(m) = sub.take() {
        seen.extend(m.name);
    }
}

#[test]
fn per_arm_topics_live_in_the_nodes_namespace() -> anyhow::Result<()> {
    let d = domain();
    let config = |namespace: &str| NodeConfig { namespace: namespace.into(), domain_id: Some(d), ..NodeConfig::default() };
    let mut left = RosNode::new("ds_controller", &config("/left"))?;
    let mut sim = RosNode::new("lwr_sim", &config("/"))?;
    let mut observer = RosNode::new("observer", &config("/"))?;
    assert_eq!((left.namespace(), left.frame_prefix().as_str()), ("/left", "left/"));
    assert_eq!(left.fully_qualified_name(), "/left/ds_controller");
    assert_eq!((sim.namespace(), sim.frame_prefix().as_str()), ("/", ""));

    let left_pub = left.advertise(&JOINT_STATES)?;
    let right_pub = sim.advertise_in(&JOINT_STATES, "/right")?;
    assert_eq!((left_pub.topic(), right_pub.topic()), ("/left/joint_states", "/right/joint_states"));
    assert_eq!(left.advertise(&CLOCK)?.topic(), "/clock", "a graph topic is the same in every namespace");
    assert!(sim.advertise_in(&JOINT_STATES, "right").is_err(), "a relative namespace");

    // Reliable readers, so a message that should arrive does.
    let on_left = observer.subscription::<JointState>("/left/joint_states", &qos::reliable())?;
    let on_root = observer.subscription::<JointState>("/joint_states", &qos::reliable())?;
    let on_right = observer.subscribe_in(&JOINT_STATES, "/right")?;
    assert_eq!(on_right.topic(), "/right/joint_states");

    let (mut left_seen, mut root_seen, mut right_seen) = (Vec::new(), Vec::new(), Vec::new());
    let deadline = Instant::now() + Duration::from_secs(15);
    let mut both_since = None;
    // Publish until both arrived, then 0.5 s more, in which nothing may reach `/joint_states`.
    while Instant::now() < deadline && both_since.is_none_or(|t: Instant| t.elapsed() < Duration::from_millis(500)) {
        left_pub.publish(arm_state("left"))?;
        right_pub.publish(arm_state("right"))?;
        std::thread::sleep(Duration::from_millis(20));
        drain(&on_left, &mut left_seen);
        drain(&on_root, &mut root_seen);
        drain(&on_right, &mut right_seen);
        if both_since.is_none() && !left_seen.is_empty() && !right_seen.is_empty() {
            both_since = Some(Instant::now());
        }
    }
    assert!(!left_seen.is_empty() && left_seen.iter().all(|a| a == "left"), "/left/joint_states got {left_seen:?}");
    assert!(!right_seen.is_empty() && right_seen.iter().all(|a| a == "right"), "/right/joint_states got {right_seen:?}");
    assert!(root_seen.is_empty(), "/joint_states got {root_seen:?}");
    assert_eq!(on_root.publisher_count(&observer), 0, "a namespaced writer matched /joint_states");
    Ok(())
}
