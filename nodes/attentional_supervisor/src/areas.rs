//! [`Areas`]: the objects of a dual-arm robot, merged from its arms' `/<arm>/object_stream`s
//! into one library `objects` event, with each arm's distance and each object's workspace area
//! (thesis Sec. 5.2.4).
//!
//! An object's area comes from its pose in the reporting arm's base frame, turned into the world
//! frame by that arm's base on `/tf_static` ([`ArmBases`]) and classified by the `areas:`
//! parameters ([`AreaParams::classify`]): the central area (the library's
//! `attention.central_area`, shared, one arm at a time), or `areas.left_arm` / `areas.right_arm`
//! (that arm's own). Only reports that *see* the object (`visible`) decide its area; when the
//! arms that see it disagree (an object on a boundary) it is central, the area that needs the
//! grant.
//!
//! Fail closed: the library treats an object with no area as reachable by every arm and outside
//! the central area (`State::accessible`, `Supervisor::needs_central`), so a seen object whose
//! area cannot be decided (every arm that sees it still lacks its base on `/tf_static`, or its
//! side's arm is not declared by the LTM) is reported as **not seen**: no arm is given an
//! action on it (an arm already holding it may go on) until the area is known. When it is,
//! the object is seen again; should the person have taken over a subtask on it meanwhile
//! (`human ...`), the library takes that return as the person's part done, as for an object
//! brought back (a start-up window of one `/tf_static` message; none is expected).

use std::collections::BTreeMap;

use cowork_msgs::msg::ObjectStream;
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_msgs::topics;
use cowork_ros::Warning;
use cowork_supervisor::{Event, ObjectObs};

use crate::bases::ArmBases;
use crate::params::{AreaParams, Side};

/// One arm's side of the merge.
#[derive(Debug, Clone)]
struct ArmObjects {
    name: String,
    /// `/left/object_stream`, for warnings.
    topic: String,
    latest: Option<ObjectStream>,
}

/// The per-arm object streams of a dual-arm robot and the arm bases; see the module docs.
#[derive(Debug, Clone)]
pub struct Areas {
    params: AreaParams,
    central: String,
    /// `areas.left_arm` / `right_arm` when the LTM declares it, else `None` (no area: fail closed).
    left: Option<String>,
    right: Option<String>,
    bases: ArmBases,
    arms: Vec<ArmObjects>,
}

impl Areas {
    /// For the arms `arms` (as the LTM declares them), the `areas:` parameters and the name of
    /// the central area (`attention.central_area`).
    pub fn new(arms: &[String], params: &AreaParams, central_area: &str) -> Self {
        let declared = |name: &str| arms.iter().any(|a| a == name).then(|| name.to_owned());
        Self {
            params: params.clone(),
            central: central_area.to_owned(),
            left: declared(&params.left_arm),
            right: declared(&params.right_arm),
            bases: ArmBases::new(&params.frame, arms.iter().map(|a| params.base_frame(a))),
            arms: arms
                .iter()
                .map(|a| ArmObjects {
                    name: a.clone(),
                    topic: topics::OBJECT_STREAM.name_in(&format!("/{a}")).into_owned(),
                    latest: None,
                })
                .collect(),
        }
    }

    /// The arm bases known so far.
    pub fn bases(&self) -> &ArmBases {
        &self.bases
    }

    /// Whether every arm's object stream has arrived at least once.
    pub fn all_seen(&self) -> bool {
        self.arms.iter().all(|a| a.latest.is_some())
    }

    /// `/tf_static`: takes the arm bases in it; a non-finite one is a warning.
    pub fn on_tf_static(&mut self, msg: &TFMessage, problems: &mut Vec<Warning>) {
        let mut bad = Vec::new();
        self.bases.on_tf_static(msg, &mut bad);
        for frame in bad {
            problems.push(Warning::new(
                format!("{}:transform", topics::TF_STATIC.name),
                format!(
                    "{}: transform {} -> {frame} is not finite or has a zero rotation; ignored",
                    topics::TF_STATIC.name,
                    self.bases.parent()
                ),
            ));
        }
    }

    /// Keeps arm `i`'s newest `/<arm>/object_stream` (the merge uses each arm's newest).
    pub fn on_object_stream(&mut self, i: usize, msg: &ObjectStream) {
        if let Some(a) = self.arms.get_mut(i) {
            a.latest = Some(msg.clone());
        }
    }

    /// The library `objects` event of the newest report of every arm (names in the order the
    /// arms first list them): `arm_distances` holds each arm's finite `robot_distance` (m) and
    /// `distance` is `None` (the library would give an arm without its own value this common
    /// one; better none, λ_max, than the other arm's); `visible` when any arm sees it; `area`
    /// as the module docs say. What was wrong is appended to `problems`.
    pub fn event(&self, problems: &mut Vec<Warning>) -> Event {
        let mut names: Vec<&str> = Vec::new();
        for o in self.arms.iter().filter_map(|a| a.latest.as_ref()).flat_map(|m| &m.objects) {
            if !names.contains(&o.name.as_str()) {
                names.push(&o.name);
            }
        }
        let mut unplaced: Vec<&str> = Vec::new();
        let mut waiting_for: Vec<&str> = Vec::new();
        // Why areas stayed unknown: [a base missing, a side arm undeclared, a pose not finite].
        let mut why = [false; 3];
        let mut objects = Vec::with_capacity(names.len());
        for name in names {
            let mut arm_distances = BTreeMap::new();
            let mut visible = false;
            let mut sides: Vec<Side> = Vec::new();
            let mut base_missing = false;
            for (i, arm) in self.arms.iter().enumerate() {
                let Some(o) = arm.latest.as_ref().and_then(|m| m.objects.iter().find(|o| o.name == name)) else { continue };
                if o.robot_distance.is_finite() {
                    arm_distances.insert(arm.name.clone(), o.robot_distance);
                } else if o.visible {
                    problems.push(Warning::new(
                        format!("{}:robot_distance", arm.topic),
                        format!(
                            "{}: object '{}' is visible with robot_distance {}; left out of the arm distances",
                            arm.topic,
                            cowork_ros::quote(name),
                            o.robot_distance
                        ),
                    ));
                }
                if !o.visible {
                    continue;
                }
                visible = true;
                let Some(base) = self.bases.get(i) else {
                    base_missing = true;
                    if !waiting_for.contains(&self.bases.frame(i)) {
                        waiting_for.push(self.bases.frame(i));
                    }
                    continue;
                };
                let p = base.apply(&o.pose.position);
                match self.params.classify(p[0], p[1]) {
                    Some(s) => sides.push(s),
                    None => problems.push(Warning::new(
                        format!("{}:pose", arm.topic),
                        format!("{}: object '{}' has a non-finite pose; not used for its area", arm.topic, cowork_ros::quote(name)),
                    )),
                }
            }
            let side = match sides.split_first() {
                None => None,
                Some((first, rest)) if rest.iter().all(|s| s == first) => Some(*first),
                Some(_) => Some(Side::Central),
            };
            if side == Some(Side::BetweenOutsideBox) {
                problems.push(Warning::new(
                    "supervisor:area_outside_box",
                    format!(
                        "object '{}' lies between the arms (|y| within areas.central.y) but outside areas.central.x: counted as {}",
                        cowork_ros::quote(name),
                        self.central
                    ),
                ));
            }
            let area = side.and_then(|s| match s {
                Side::Central | Side::BetweenOutsideBox => Some(self.central.clone()),
                Side::Left => self.left.clone(),
                Side::Right => self.right.clone(),
            });
            if visible && area.is_none() {
                visible = false;
                unplaced.push(name);
                let reason = if side.is_some() { 1 } else if base_missing { 0 } else { 2 };
                why[reason] = true;
            }
            objects.push(ObjectObs { name: name.to_owned(), distance: None, arm_distances, visible, area });
        }
        if !unplaced.is_empty() {
            let mut reasons = Vec::new();
            if why[0] {
                reasons.push(format!("no transform {} -> {} on {} yet", self.bases.parent(), waiting_for.join(", "), topics::TF_STATIC.name));
            }
            if why[1] {
                reasons.push(format!(
                    "its side's arm (areas.left_arm `{}`, areas.right_arm `{}`) is not an arm of the LTM",
                    self.params.left_arm, self.params.right_arm
                ));
            }
            if why[2] {
                reasons.push("its pose is not finite".to_owned());
            }
            let list: Vec<String> = unplaced.iter().take(8).map(|n| format!("'{}'", cowork_ros::quote(n))).collect();
            problems.push(Warning::new(
                "supervisor:area_unknown",
                format!("area of {} unknown ({}): reported as not seen, so no arm acts on it", list.join(", "), reasons.join("; ")),
            ));
        }
        Event::Objects { objects }
    }
}
