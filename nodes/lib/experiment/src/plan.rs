//! Experiment descriptions: the scene, the task script (motions and gripper commands), the
//! scripted people and the success test. Plain data; the runner executes them.

use std::path::PathBuf;

use cowork_people::{Action, BodySize, GestureKind, GestureStyle, Performer, Room, Side, Timeline};
use cowork_sim::{Scene, Shape};
use nalgebra::{Point2, Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Experiments the runner knows.
pub const NAMES: [&str; 2] = ["stacking-hri", "gestures-hri"];

/// Where the DS controller's robot–obstacle distances come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DistanceMethod {
    /// fDED on the rendered depth image (thesis Sec. 5.1.2).
    Fded,
    /// Flacco et al.'s sphere method on the same image, at its real cost (Sec. 5.1.3 baseline).
    Flacco,
}

impl DistanceMethod {
    /// `fded` or `flacco`.
    pub fn as_str(self) -> &'static str {
        match self {
            DistanceMethod::Fded => "fded",
            DistanceMethod::Flacco => "flacco",
        }
    }

    /// Parses `fded` / `flacco`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "fded" => Some(DistanceMethod::Fded),
            "flacco" => Some(DistanceMethod::Flacco),
            _ => None,
        }
    }
}

/// One step of the task script.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Step {
    /// Constant-speed point-to-point motion of the tool point to `goal` (base frame, m) at
    /// `speed` m/s nominal, orientation held (`/motion/command` KIND_CONSTANT_SPEED).
    Move {
        /// For logs and the report.
        label: String,
        /// Goal of the tool point, base frame (m).
        goal: [f64; 3],
        /// Nominal speed (m/s) before the human scaling.
        speed: f64,
    },
    /// Close the gripper on `object` (it must then be held) or open it (`object` released).
    Grip {
        /// Close (grasp) or open (release).
        close: bool,
        /// The object grasped or released.
        object: String,
    },
    /// Wait until the person's gesture `label` (`cowork_msgs::msg::Gesture::LABEL_*`) has been
    /// recognised on `/human/gesture` since the previous wait (the robot holds meanwhile);
    /// `come` starts the cooperative task (Sec. 5.1.3).
    AwaitGesture {
        /// Gesture label, e.g. `come`.
        label: String,
    },
    /// Sec. 5.1.3 *handover right*: once a `handover_right` gesture has been recognised (before
    /// or after this step is reached), bring the held `object` to the person's right hand +
    /// `offset` (base frame, m; the thesis: 5 cm up) at `speed` m/s nominal, following the
    /// hand the human observer tracks (`/human/state` hand position: the goal is re-sent when
    /// the hand has moved more than [`crate::sequencer::HANDOVER_RETARGET_M`]), with the
    /// end effector's avoidance off (it has to reach the hand) and null-space (link)
    /// avoidance on. Done when ds_controller reports the motion converged and the hand is
    /// still there (observed within 4 cm of where the goal expects it); a `Grip` open releases
    /// the object next. A hand that went away is waited for (the time limit fails the trial).
    Handover {
        /// The held object handed over.
        object: String,
        /// Goal = right hand + this (base frame, m).
        offset: [f64; 3],
        /// Nominal speed (m/s) before the human scaling.
        speed: f64,
        /// Hand goals farther than `reach_radius` from this point (base frame, m: the robot's
        /// shoulder) are not aimed at: the hand is not held out yet.
        reach_centre: [f64; 3],
        /// m.
        reach_radius: f64,
    },
}

/// What an object's final centre is measured against.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Anchor {
    /// Its own initial centre (it must stay put).
    Initial,
    /// Another object's final centre.
    Object(String),
    /// A fixed point (base frame, m).
    Point([f64; 3]),
}

/// Where an object must end up: within `tolerance_m` of `anchor` + `offset`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Placement {
    /// The object judged.
    pub object: String,
    /// What its final centre is measured against.
    pub anchor: Anchor,
    /// Offset from the anchor (m, base frame).
    pub offset: [f64; 3],
    /// Tolerance on the centre distance (m).
    pub tolerance_m: f64,
    /// The subtask this placement finishes (its time is taken when its release step ends).
    pub subtask: Option<String>,
}

/// What varies with the seed (written into the JSON of each trial).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Variant {
    /// Person's standing height (m).
    pub body_height_m: f64,
    /// Side of the table the person works at: `-y` or `+y`.
    pub side: String,
    /// Simulated time the person starts walking in (s).
    pub enter_s: f64,
    /// Peak hand speed of each reach (m/s).
    pub reach_speeds_m_s: Vec<f64>,
    /// Target of each reach (base frame, m).
    pub reach_targets: Vec<[f64; 3]>,
}

/// A whole experiment trial, ready to run.
#[derive(Debug, Clone)]
pub struct Experiment {
    /// Experiment name (`stacking-hri`).
    pub name: String,
    /// Seed of this trial.
    pub seed: u64,
    /// Scene file (relative to the repository root unless absolute).
    pub scene_path: PathBuf,
    /// The scene.
    pub scene: Scene,
    /// Distance source.
    pub distance: DistanceMethod,
    /// Task script, executed in order.
    pub steps: Vec<Step>,
    /// Scripted people on the simulated clock (t = 0 when the trial starts).
    pub people: Timeline,
    /// Rate at which their skeletons are published (Hz of simulated time).
    pub people_rate_hz: f64,
    /// Success test.
    pub placements: Vec<Placement>,
    /// A trial still running at this simulated time fails (s).
    pub time_limit_s: f64,
    /// After the last step the trial still runs this long, e.g. until the person has left (s).
    pub settle_s: f64,
    /// What the seed chose.
    pub variant: Variant,
}

/// Options common to every experiment.
#[derive(Debug, Clone)]
pub struct Options {
    /// Seed of the trial.
    pub seed: u64,
    /// Scene file, `None` for the experiment's own.
    pub scene: Option<PathBuf>,
    /// Distance source.
    pub distance: DistanceMethod,
    /// Simulated-time limit override (s).
    pub time_limit_s: Option<f64>,
}

/// Builds experiment `name` for one trial. `root` is the repository root (scene files are
/// relative to it).
pub fn build(name: &str, root: &std::path::Path, options: &Options) -> Result<Experiment> {
    match name {
        "stacking-hri" => stacking_hri(root, options),
        "gestures-hri" => gestures_hri(root, options),
        _ => Err(Error::UnknownExperiment {
            name: name.to_owned(),
            known: NAMES.join(", "),
        }),
    }
}

/// Travel height of the tool between picks and places (m above the table top).
const TRAVEL_Z: f64 = 0.25;
/// Clearance of a placed block above its support (m): it drops the rest.
const PLACE_CLEARANCE: f64 = 0.005;

fn box_size(scene: &Scene, place: &str, name: &str) -> Result<(Point3<f64>, Vector3<f64>)> {
    let o = scene
        .objects
        .iter()
        .find(|o| o.name == name)
        .ok_or_else(|| Error::Scene {
            place: place.to_owned(),
            message: format!("object `{name}` missing (stacking-hri needs block1 and block2)"),
        })?;
    let Shape::Box { size } = o.shape else {
        return Err(Error::Scene {
            place: place.to_owned(),
            message: format!("object `{name}` must be a box"),
        });
    };
    let p = o.pose.isometry().translation.vector;
    Ok((Point3::from(p), Vector3::from(size)))
}

/// Every object must rest on the table: its footprint centre over the table top and its
/// bottom within 5 mm of the top (or of another object it stands on).
pub fn check_scene(scene: &Scene, place: &str) -> Result<()> {
    let top = scene.table_top_z();
    let t = scene.table.pose.isometry();
    let half = [0.5 * scene.table.size[0], 0.5 * scene.table.size[1]];
    for o in &scene.objects {
        let c = o.pose.isometry().translation.vector;
        let local = t.inverse() * Point3::from(c);
        if local.x.abs() > half[0] || local.y.abs() > half[1] {
            return Err(Error::Scene {
                place: place.to_owned(),
                message: format!(
                    "object `{}` at ({:.3}, {:.3}) is off the table ({:.2} x {:.2} m around ({:.3}, {:.3}))",
                    o.name,
                    c.x,
                    c.y,
                    scene.table.size[0],
                    scene.table.size[1],
                    t.translation.vector.x,
                    t.translation.vector.y
                ),
            });
        }
        let half_h = match o.shape {
            Shape::Box { size } => 0.5 * size[2],
            Shape::Cylinder { height, .. } => 0.5 * height,
            Shape::Sphere { radius } => radius,
        };
        if c.z - half_h < top - 0.005 {
            return Err(Error::Scene {
                place: place.to_owned(),
                message: format!(
                    "object `{}` reaches {:.3} m below the table top",
                    o.name,
                    top - (c.z - half_h)
                ),
            });
        }
    }
    Ok(())
}

/// Nominal tool speed of the stacking motions (m/s, thesis Sec. 5.1.3).
const STACK_SPEED: f64 = 0.3;

/// The scene of `o` (or `default`), loaded and checked: (path as given, scene, name for errors).
fn load_scene_or(
    root: &std::path::Path,
    o: &Options,
    default: &str,
) -> Result<(PathBuf, Scene, String)> {
    let scene_path = o.scene.clone().unwrap_or_else(|| PathBuf::from(default));
    let full = if scene_path.is_absolute() {
        scene_path.clone()
    } else {
        root.join(&scene_path)
    };
    let place = scene_path.display().to_string();
    let scene = Scene::from_file(&full).map_err(|e| Error::Scene {
        place: place.clone(),
        message: e.to_string(),
    })?;
    check_scene(&scene, &place)?;
    Ok((scene_path, scene, place))
}

fn load_scene(root: &std::path::Path, o: &Options) -> Result<(PathBuf, Scene, String)> {
    load_scene_or(root, o, "config/scenes/stacking-hri.yaml")
}

/// g3 of Sec. 5.1.3 (mirrored into this base frame), the first stacking position on the table:
/// the centre of a block of height `h` standing there (m).
fn g3(scene: &Scene, h: f64) -> Point3<f64> {
    Point3::new(0.55, -0.30, scene.table_top_z() + 0.5 * h)
}

/// The stacking script of `picks`, the first at g3 on the table and each next one on the
/// previous: per block above it at the travel height, down, grasp, lift, above the stack, down
/// to 5 mm above its support, release (lwr_sim drops it the rest), up — constant-speed motions
/// at `speed` m/s, orientation held — and the placements that judge it (1 cm).
fn stack_steps(
    scene: &Scene,
    place: &str,
    picks: &[&str],
    speed: f64,
) -> Result<(Vec<Step>, Vec<Placement>)> {
    let mut steps = Vec::new();
    let mut placements = Vec::new();
    let mv = |label: String, p: Point3<f64>| Step::Move {
        label,
        goal: [p.x, p.y, p.z],
        speed,
    };
    let Some(first) = picks.first() else {
        return Ok((steps, placements));
    };
    let (_, s1) = box_size(scene, place, first)?;
    let g3 = g3(scene, s1.z);
    let travel = scene.table_top_z() + TRAVEL_Z;
    let mut below = (
        g3 - Vector3::new(0.0, 0.0, 0.5 * s1.z),
        Anchor::Point([g3.x, g3.y, g3.z]),
        s1.z,
    );
    for pick in picks {
        let (p, ps) = box_size(scene, place, pick)?;
        // Released just above its support: it drops the rest.
        let support_top = below.0;
        let place_at = Point3::new(
            support_top.x,
            support_top.y,
            support_top.z + 0.5 * ps.z + PLACE_CLEARANCE,
        );
        steps.push(mv(format!("above {pick}"), Point3::new(p.x, p.y, travel)));
        steps.push(mv(format!("down to {pick}"), p));
        steps.push(Step::Grip {
            close: true,
            object: (*pick).into(),
        });
        steps.push(mv(format!("lift {pick}"), Point3::new(p.x, p.y, travel)));
        steps.push(mv(
            format!("{pick} above the stack"),
            Point3::new(place_at.x, place_at.y, travel),
        ));
        steps.push(mv(format!("{pick} onto the stack"), place_at));
        steps.push(Step::Grip {
            close: false,
            object: (*pick).into(),
        });
        steps.push(mv(
            format!("up from {pick}"),
            Point3::new(place_at.x, place_at.y, travel),
        ));
        let offset = match below.1 {
            Anchor::Point(_) => [0.0; 3],
            _ => [0.0, 0.0, 0.5 * (ps.z + below.2)],
        };
        placements.push(Placement {
            object: (*pick).into(),
            anchor: below.1.clone(),
            offset,
            tolerance_m: 0.01,
            subtask: Some(format!("stack {pick}")),
        });
        below = (
            Point3::new(support_top.x, support_top.y, support_top.z + ps.z),
            Anchor::Object((*pick).into()),
            ps.z,
        );
    }
    Ok((steps, placements))
}

/// How a scripted person visits the table (one experiment's choice): when they walk in, how
/// many times they reach, and where each reach goes.
#[derive(Debug, Clone, Copy)]
pub struct Visit {
    /// Simulated time of walking in, drawn uniformly in [from, to) (s after the trial's t = 0).
    pub enter_s: (f64, f64),
    /// Number of reaches, drawn uniformly in [from, to].
    pub reaches: (usize, usize),
    /// A reach's target (base frame, m) for the person's side `sign` (±1 along y) and the
    /// table top `top` (m).
    pub target: fn(&mut ChaCha8Rng, f64, f64) -> Point3<f64>,
}

/// A person drawn from `seed` (thesis Sec. 5.1.3): height 1.55–1.90 m, on the −y or +y side,
/// walks in from the room's entry to the standing spot, stands, reaches with the right hand
/// into the robot's workspace as `visit` says (minimum-jerk, peak hand speed 0.5–1.5 m/s, held
/// 0.5–1.5 s, 1–4 s standing after each), then walks out again.
pub fn visitor(seed: u64, top: f64, visit: &Visit) -> Result<(Timeline, Variant)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let height = rng.random_range(1.55..=1.90);
    let body = BodySize::new(height)?;
    let sign = if rng.random_bool(0.5) { -1.0 } else { 1.0 };
    let room = Room::default();
    let spot = Point2::new(room.standing_spot.x, sign * room.standing_spot.y.abs());
    let entry = Point2::new(room.entry.x, sign * room.entry.y.abs());
    let centre = Point3::new(room.workspace_centre.x, sign * room.workspace_centre.y.abs(), 0.0);
    let facing = |p: &Point2<f64>| (centre.y - p.y).atan2(centre.x - p.x);
    let enter = rng.random_range(visit.enter_s.0..visit.enter_s.1);
    let reaches = rng.random_range(visit.reaches.0..=visit.reaches.1);
    let mut performer = Performer::new(1, body, cowork_people::Stance { position: entry, yaw: facing(&entry) }, seed)?
        .with_floor_z(room.floor_z)?
        .then(Action::Walk { to: spot, speed: 1.1, face_yaw: Some(facing(&spot)) })?
        .then(Action::Stand { duration: rng.random_range(0.5..2.0) })?;
    let shoulder_z = room.floor_z + body.lengths().hip_height + body.lengths().pelvis_to_shoulder;
    let (mut speeds, mut targets) = (Vec::new(), Vec::new());
    for _ in 0..reaches {
        let target = (visit.target)(&mut rng, sign, top);
        let shoulder = Point3::new(spot.x, spot.y - sign * 0.2, shoulder_z);
        let peak = rng.random_range(0.5..1.5);
        // Minimum-jerk reach: peak speed 1.875 x the mean speed.
        let duration = (1.875 * (target - shoulder).norm() / peak).clamp(0.25, 3.0);
        performer = performer
            .then(Action::Reach { side: Side::Right, target, duration, hold: rng.random_range(0.5..1.5) })?
            .then(Action::Stand { duration: rng.random_range(1.0..4.0) })?;
        speeds.push(peak);
        targets.push([target.x, target.y, target.z]);
    }
    performer = performer.then(Action::Walk { to: entry, speed: 1.2, face_yaw: None })?;
    let mut people = Timeline::new();
    people.add(enter, performer)?;
    let variant = Variant {
        body_height_m: height,
        side: if sign < 0.0 { "-y".into() } else { "+y".into() },
        enter_s: enter,
        reach_speeds_m_s: speeds,
        reach_targets: targets,
    };
    Ok((people, variant))
}

/// Sec. 5.1.3: the robot stacks block1 at g3 and block2 on top of it (g4); each block: above
/// it, down (g1 / g2), grasp, up, above the stack, down (g3 / g4), release, up — constant-speed
/// motions ẋ = α_h (g − x)/‖g − x‖ at 0.3 m/s nominal, orientation held —
/// while a scripted person walks up to the table, reaches across the arm's path one to three
/// times and leaves. Varied by the seed: body height 1.55–1.90 m, side of the table, when the
/// person comes, peak hand speed of each reach 0.5–1.5 m/s and its target on the path.
fn stacking_hri(root: &std::path::Path, o: &Options) -> Result<Experiment> {
    let (scene_path, scene, place) = load_scene(root, o)?;
    let top = scene.table_top_z();
    let (steps, placements) = stack_steps(&scene, &place, &["block1", "block2"], STACK_SPEED)?;
    // Targets on the arm's path on the person's side: the travel segment between the two
    // columns and the descent above the base blocks.
    let visit = Visit {
        enter_s: (1.0, 4.0),
        reaches: (1, 3),
        target: |rng, sign, top| {
            let base_y = sign * 0.3;
            Point3::new(rng.random_range(0.45..0.62), base_y - sign * rng.random_range(0.0..0.35), top + rng.random_range(0.12..0.30))
        },
    };
    let (people, variant) = visitor(o.seed, top, &visit)?;
    let time_limit_s = o.time_limit_s.unwrap_or(150.0);
    if !(time_limit_s.is_finite() && time_limit_s > 0.0) {
        return Err(Error::BadOption {
            experiment: "stacking-hri".into(),
            message: format!("time limit {time_limit_s} s must be > 0"),
        });
    }
    Ok(Experiment {
        name: "stacking-hri".into(),
        seed: o.seed,
        scene_path,
        scene,
        distance: o.distance,
        steps,
        people,
        people_rate_hz: 120.0,
        placements,
        time_limit_s,
        settle_s: 0.5,
        variant,
    })
}

/// Where the person holds out the right hand for the handover (base frame, m, z above the
/// table top), before the seed's variation: in front of the standing spot beside the −y edge,
/// clear of g3.
const HANDOVER_SPOT: [f64; 3] = [0.34, -0.58, 0.18];
/// The LWR's shoulder (joint 2 axis) in the base frame, m.
const LWR_SHOULDER: [f64; 3] = [0.0, 0.0, 0.31];
/// Handover goals within this distance of the shoulder are aimed at (m): comfortably inside
/// the arm's reach with the tool pointing down (ds_controller refuses goals beyond ~1.17 m).
const HANDOVER_REACH_M: f64 = 0.9;
/// The handover goal is the hand + this (Sec. 5.1.3: 5 cm along the vertical), m.
pub const HANDOVER_OFFSET: [f64; 3] = [0.0, 0.0, 0.05];

/// Sec. 5.1.3 *cooperative task execution via human gestures*: a scripted person walks to the
/// table and commands the stacking robot with gestures the human observer recognises from the
/// skeleton — `come` starts the task, `stop` suspends it (α_h = 0 from the observer, the
/// controller holds), `come` resumes it, `handover right` makes the robot give the item it
/// holds (block1) to the person's right hand + 5 cm with end-effector avoidance off and
/// null-space avoidance on; the person holds the hand out, the robot releases the block and
/// continues with the next item (block2 onto g3). Varied by the seed: body height
/// 1.55–1.90 m, when the person comes, how long they wait between gestures, the gestures'
/// speed, amplitude and arm height, where the hand is held out.
fn gestures_hri(root: &std::path::Path, o: &Options) -> Result<Experiment> {
    if o.distance != DistanceMethod::Fded {
        return Err(Error::BadOption {
            experiment: "gestures-hri".into(),
            message: "--distance flacco applies to stacking-hri only".into(),
        });
    }
    let (scene_path, scene, place) = load_scene(root, o)?;
    let top = scene.table_top_z();
    let (first, _) = stack_steps(&scene, &place, &["block1"], STACK_SPEED)?;
    let (second, placements) = stack_steps(&scene, &place, &["block2"], STACK_SPEED)?;
    let mut steps = vec![Step::AwaitGesture {
        label: cowork_msgs::msg::Gesture::LABEL_COME.into(),
    }];
    // block1: above, down, grasp, lift; then to the person's hand instead of the stack.
    steps.extend(first.into_iter().take(4));
    steps.push(Step::Handover {
        object: "block1".into(),
        offset: HANDOVER_OFFSET,
        speed: STACK_SPEED,
        reach_centre: LWR_SHOULDER,
        reach_radius: HANDOVER_REACH_M,
    });
    steps.push(Step::Grip {
        close: false,
        object: "block1".into(),
    });
    steps.extend(second);

    let mut rng = ChaCha8Rng::seed_from_u64(o.seed);
    let height = rng.random_range(1.55..=1.90);
    let body = BodySize::new(height)?;
    let room = Room::default();
    let spot = room.standing_spot;
    let entry = room.entry;
    let centre = Point2::new(room.workspace_centre.x, room.workspace_centre.y);
    let facing = |p: &Point2<f64>| (centre.y - p.y).atan2(centre.x - p.x);
    let enter = rng.random_range(0.5..2.0);
    let mut style = || GestureStyle {
        duration_scale: rng.random_range(0.85..1.15),
        amplitude: rng.random_range(0.9..1.1),
        repetitions: 3,
        tilt: rng.random_range(-0.1..0.1),
    };
    let (come, stop, again, handover) = (style(), style(), style(), style());
    let waits = [
        rng.random_range(1.0..1.5),
        rng.random_range(4.0..6.0),
        rng.random_range(3.0..4.0),
        rng.random_range(7.0..9.0),
    ];
    let hand = Point3::new(
        HANDOVER_SPOT[0] + rng.random_range(-0.04..0.04),
        HANDOVER_SPOT[1] + rng.random_range(-0.04..0.04),
        top + HANDOVER_SPOT[2] + rng.random_range(-0.03..0.03),
    );
    let gesture = |kind, style| Action::Gesture { kind, style };
    let performer = Performer::new(
        1,
        body,
        cowork_people::Stance {
            position: entry,
            yaw: facing(&entry),
        },
        o.seed,
    )?
    .with_floor_z(room.floor_z)?
    .then(Action::Walk {
        to: spot,
        speed: 1.1,
        face_yaw: Some(facing(&spot)),
    })?
    .then(Action::Stand { duration: waits[0] })?
    .then(gesture(GestureKind::Come, come))?
    .then(Action::Stand { duration: waits[1] })?
    .then(gesture(GestureKind::Stop, stop))?
    .then(Action::Stand { duration: waits[2] })?
    .then(gesture(GestureKind::Come, again))?
    .then(Action::Stand { duration: waits[3] })?
    .then(gesture(GestureKind::HandoverRight, handover))?
    // The hand held out for the block (long enough for the robot to come at 0.1 m/s).
    .then(Action::Reach {
        side: Side::Right,
        target: hand,
        duration: 1.0,
        hold: 20.0,
    })?
    .then(Action::Stand { duration: 1.0 })?
    .then(Action::Walk {
        to: entry,
        speed: 1.2,
        face_yaw: None,
    })?;
    let mut people = Timeline::new();
    people.add(enter, performer)?;
    let time_limit_s = o.time_limit_s.unwrap_or(150.0);
    if !(time_limit_s.is_finite() && time_limit_s > 0.0) {
        return Err(Error::BadOption {
            experiment: "gestures-hri".into(),
            message: format!("time limit {time_limit_s} s must be > 0"),
        });
    }
    Ok(Experiment {
        name: "gestures-hri".into(),
        seed: o.seed,
        scene_path,
        scene,
        distance: o.distance,
        steps,
        people,
        people_rate_hz: 120.0,
        placements,
        time_limit_s,
        settle_s: 0.5,
        variant: Variant {
            body_height_m: height,
            side: "-y".into(),
            enter_s: enter,
            reach_speeds_m_s: Vec::new(),
            reach_targets: vec![[hand.x, hand.y, hand.z]],
        },
    })
}
