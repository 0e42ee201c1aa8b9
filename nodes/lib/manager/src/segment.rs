//! Online segmentation of a kinesthetic demonstration (thesis Sec. 4.3.1): a new segment when
//! the tool point enters or leaves an object's proximity sphere (radius r, Table 5.3) and at
//! every gripper command.
//!
//! * Entering the sphere of O closes a far-object action `foaN(O)`; leaving it closes a
//!   near-object action `noaN(O)`; a gripper command closes the running segment (a NOA when
//!   inside a sphere, else a FOA towards the world frame) and adds `closeN(O)` / `openN(O)`.
//! * The held object has no sphere (it moves with the tool); objects not seen cannot be entered.
//! * Failure cases of the thesis, each logged in a [`Note`]: two spheres at once (the nearest
//!   surface wins), a segment without motion (dropped, no primitive), the object of the
//!   running segment hidden (its last seen pose is kept as the frame).
//!
//! Distances are from the tool point to the object's surface (m), as the simulator reports
//! them: r = 0.12 m around a 0.22 m bottle is then a sphere-like zone around its surface.

use nalgebra::Isometry3;

use crate::config::{ManagerConfig, WORLD};
use crate::world::World;

/// Kind of a segmented action.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ActionKind {
    /// Near-object action (DMP).
    Noa,
    /// Far-object action (linear DS to the end pose).
    Foa,
    /// Gripper command.
    Gripper,
}

impl ActionKind {
    /// Label prefix of motion kinds.
    pub fn prefix(self) -> &'static str {
        match self {
            Self::Noa => "noa",
            Self::Foa => "foa",
            Self::Gripper => "gripper",
        }
    }
}

/// A gripper command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GripperCommand {
    /// Close (grasp).
    Close,
    /// Open (release).
    Open,
}

impl GripperCommand {
    /// `close` / `open`.
    pub fn word(self) -> &'static str {
        match self {
            Self::Close => "close",
            Self::Open => "open",
        }
    }
}

/// A segmented action.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// Sequence number N of the label (unique in the database).
    pub index: u32,
    /// Label, e.g. `noa2(water)`.
    pub label: String,
    /// Functor of the label, the database key (e.g. `noa2`).
    pub id: String,
    /// Kind.
    pub kind: ActionKind,
    /// Object whose frame holds the goal (`world` = base frame).
    pub object: String,
    /// Start and end, s.
    pub t_start: f64,
    /// End, s.
    pub t_end: f64,
    /// Tool poses (t s, base frame) from start to end; empty for gripper segments.
    pub samples: Vec<(f64, Isometry3<f64>)>,
    /// Pose of `object` at the end (identity for the world).
    pub frame: Isometry3<f64>,
    /// The command of a gripper segment.
    pub gripper: Option<GripperCommand>,
    /// A FOA towards the world that ends where the teacher let go of this object, which was
    /// grasped in the same demonstration: putting it back. `frame` is where the object stood
    /// when it was grasped, so the goal is learned relative to that spot (executed: where the
    /// object stood when this execution grasped it).
    pub home: Option<String>,
}

impl Segment {
    /// Last tool pose (the goal), base frame; the frame origin for gripper segments.
    pub fn end_pose(&self) -> Isometry3<f64> {
        self.samples.last().map_or(self.frame, |s| s.1)
    }
}

/// Something the segmenter decided that a person should know.
#[derive(Debug, Clone, PartialEq)]
pub struct Note {
    /// Time, s.
    pub t: f64,
    /// What happened and what was done about it.
    pub text: String,
}

/// An object let go within this distance (horizontal, m) of where it stood when grasped was
/// put back: the FOA that carried it there is learned relative to that spot ([`Segment::home`]).
pub const HOME_RADIUS_M: f64 = 0.05;

/// The online segmenter.
#[derive(Debug, Clone)]
pub struct Segmenter {
    /// Put before every label (`ManagerConfig::label_prefix`).
    label_prefix: String,
    radius: f64,
    min_motion: f64,
    min_rotation: f64,
    next_index: u32,
    samples: Vec<(f64, Isometry3<f64>)>,
    inside: Option<String>,
    /// Last seen pose of every object (task name).
    last_pose: Vec<(String, Isometry3<f64>)>,
    both_noted: Option<(String, String)>,
    hidden_noted: bool,
    /// The object the last `gripper close` took and where it stood then (task name, pose).
    grasped: Option<(String, Isometry3<f64>)>,
    /// A gripper command whose effect the world has not reported yet (command, time s).
    pending_gripper: Option<(GripperCommand, f64)>,
}

/// How long a gripper command may take to show in the world report before the spheres are
/// re-read anyway, s.
const GRIPPER_REPORT_S: f64 = 0.5;

impl Segmenter {
    /// A segmenter numbering its labels from `next_index`.
    pub fn new(cfg: &ManagerConfig, next_index: u32) -> Self {
        Self {
            label_prefix: cfg.label_prefix.clone(),
            radius: cfg.proximity_radius_m,
            min_motion: cfg.min_segment_motion_m,
            min_rotation: cfg.min_segment_rotation_rad,
            next_index: next_index.max(1),
            samples: Vec::new(),
            inside: None,
            last_pose: Vec::new(),
            both_noted: None,
            hidden_noted: false,
            grasped: None,
            pending_gripper: None,
        }
    }

    /// Next label number.
    pub fn next_index(&self) -> u32 {
        self.next_index
    }

    /// Whether [`start`](Self::start) has seen a first sample.
    pub fn started(&self) -> bool {
        !self.samples.is_empty()
    }

    /// Object whose sphere holds the tool now, if any.
    pub fn inside(&self) -> Option<&str> {
        self.inside.as_deref()
    }

    /// Starts a demonstration at `world`: the first sample, spheres already around the tool.
    pub fn start(&mut self, world: &World) {
        self.samples.clear();
        self.inside = None;
        self.both_noted = None;
        self.hidden_noted = false;
        self.pending_gripper = None;
        self.grasped = None;
        self.remember(world);
        let mut notes = Vec::new();
        self.inside = self.sphere(world, &mut notes);
        self.samples.push((world.t, world.tool));
    }

    fn remember(&mut self, world: &World) {
        for o in world.objects.iter().filter(|o| o.visible) {
            match self.last_pose.iter_mut().find(|(n, _)| *n == o.name) {
                Some(e) => e.1 = o.pose,
                None => self.last_pose.push((o.name.clone(), o.pose)),
            }
        }
    }

    fn frame_of(&self, object: &str) -> Isometry3<f64> {
        self.last_pose.iter().find(|(n, _)| n == object).map_or(Isometry3::identity(), |e| e.1)
    }

    /// The sphere the tool is in: visible, not held, within r; the nearest when several.
    fn sphere(&mut self, world: &World, notes: &mut Vec<Note>) -> Option<String> {
        let mut within: Vec<(&str, f64)> = world
            .objects
            .iter()
            .filter(|o| o.visible && !o.held && o.distance <= self.radius)
            .map(|o| (o.name.as_str(), o.distance))
            .collect();
        within.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(b.0)));
        if within.len() > 1 {
            let pair = (within[0].0.to_owned(), within[1].0.to_owned());
            if self.both_noted.as_ref() != Some(&pair) {
                notes.push(Note {
                    t: world.t,
                    text: format!(
                        "the tool is inside the proximity spheres of {} objects at once ({}); the segment is attributed to the nearest, {} ({:.3} m vs {:.3} m) — a smaller proximity_radius_m separates them",
                        within.len(),
                        within.iter().map(|w| w.0).collect::<Vec<_>>().join(", "),
                        within[0].0,
                        within[0].1,
                        within[1].1
                    ),
                });
                self.both_noted = Some(pair);
            }
        } else {
            self.both_noted = None;
        }
        // A hidden object keeps its sphere while the tool is in it (its last pose is the frame).
        if let Some(cur) = &self.inside
            && let Some(o) = world.object(cur)
            && !o.visible
            && !o.held
        {
            if !self.hidden_noted {
                notes.push(Note {
                    t: world.t,
                    text: format!(
                        "{cur} is hidden while the tool is in its proximity sphere; its last seen pose is kept as the segment's frame and the sphere is left only when it is seen again"
                    ),
                });
                self.hidden_noted = true;
            }
            return Some(cur.clone());
        }
        self.hidden_noted = false;
        within.first().map(|w| w.0.to_owned())
    }

    /// One world sample while teaching; appends the segments it closes.
    pub fn observe(&mut self, world: &World, out: &mut Vec<Segment>, notes: &mut Vec<Note>) {
        if self.samples.last().is_some_and(|s| world.t <= s.0) {
            return; // not newer: a repeated or reordered report
        }
        self.remember(world);
        self.samples.push((world.t, world.tool));
        let now = self.sphere(world, notes);
        // After a gripper command the segment boundary is the command itself: once the world
        // shows its effect, the sphere the tool is in is adopted without a new boundary (a
        // grasped object's sphere vanishes, a released one's reappears around the tool).
        if let Some((cmd, t)) = self.pending_gripper {
            let shown = world.gripper_closed == (cmd == GripperCommand::Close);
            if shown || world.t - t > GRIPPER_REPORT_S {
                self.pending_gripper = None;
                self.inside = now;
            }
            return;
        }
        // The object of a near-object segment was grasped: its sphere moves with the tool.
        if let Some(cur) = &self.inside
            && world.object(cur).is_some_and(|o| o.held)
        {
            self.inside = now;
            return;
        }
        if now == self.inside {
            return;
        }
        match (self.inside.take(), now.clone()) {
            (None, Some(entered)) => self.close(ActionKind::Foa, &entered, world.t, out, notes),
            (Some(left), _) => self.close(ActionKind::Noa, &left, world.t, out, notes),
            (None, None) => {}
        }
        self.inside = now;
    }

    /// A gripper command at `world`: closes the running segment and adds the gripper segment.
    /// `object` is what it acts on (the grasped / released object; `None`: the sphere the tool
    /// is in for a close, the world otherwise).
    pub fn gripper(&mut self, world: &World, cmd: GripperCommand, object: Option<&str>, out: &mut Vec<Segment>, notes: &mut Vec<Note>) {
        if self.samples.last().is_none_or(|s| world.t > s.0) {
            self.remember(world);
            self.samples.push((world.t, world.tool));
        }
        let object = match (object, cmd) {
            (Some(o), _) => o.to_owned(),
            (None, GripperCommand::Close) => self.inside.clone().unwrap_or_else(|| WORLD.to_owned()),
            (None, GripperCommand::Open) => world.held.clone().unwrap_or_else(|| WORLD.to_owned()),
        };
        let n = out.len();
        match self.inside.clone() {
            Some(o) => self.close(ActionKind::Noa, &o, world.t, out, notes),
            None => self.close(ActionKind::Foa, WORLD, world.t, out, notes),
        }
        // Letting go, in free space, of the object grasped last within HOME_RADIUS_M of where
        // it stood: the FOA just closed puts it back there, relative to that spot.
        let released_at = world.object(&object).map(|o| o.pose.translation.vector);
        if cmd == GripperCommand::Open
            && let Some((home, pose)) = self.grasped.take().filter(|(h, _)| *h == object)
            && released_at.is_some_and(|r| (r.xy() - pose.translation.vector.xy()).norm() <= HOME_RADIUS_M)
            && let Some(seg) = out[n..].iter_mut().find(|s| s.kind == ActionKind::Foa && s.object == WORLD)
        {
            seg.frame = pose;
            seg.home = Some(home);
        }
        if cmd == GripperCommand::Close && object != WORLD {
            self.grasped = Some((object.clone(), self.frame_of(&object)));
        }
        self.pending_gripper = Some((cmd, world.t));
        let index = self.take_index();
        let id = format!("{}{}{index}", self.label_prefix, cmd.word());
        out.push(Segment {
            index,
            label: format!("{id}({object})"),
            id,
            kind: ActionKind::Gripper,
            frame: if object == WORLD { Isometry3::identity() } else { self.frame_of(&object) },
            object,
            t_start: world.t,
            t_end: world.t,
            samples: Vec::new(),
            gripper: Some(cmd),
            home: None,
        });
    }

    /// Ends the demonstration (`done`): closes the running segment.
    pub fn finish(&mut self, world: &World, out: &mut Vec<Segment>, notes: &mut Vec<Note>) {
        if self.samples.last().is_none_or(|s| world.t > s.0) {
            self.samples.push((world.t, world.tool));
        }
        match self.inside.take() {
            Some(o) => self.close(ActionKind::Noa, &o, world.t, out, notes),
            None => self.close(ActionKind::Foa, WORLD, world.t, out, notes),
        }
        self.samples.clear();
    }

    fn take_index(&mut self) -> u32 {
        let i = self.next_index;
        self.next_index += 1;
        i
    }

    fn close(&mut self, kind: ActionKind, object: &str, t: f64, out: &mut Vec<Segment>, notes: &mut Vec<Note>) {
        let samples = std::mem::take(&mut self.samples);
        // The boundary sample starts the next segment.
        if let Some(last) = samples.last() {
            self.samples.push(*last);
        }
        let (Some(first), Some(last)) = (samples.first(), samples.last()) else { return };
        let path: f64 = samples.windows(2).map(|w| (w[1].1.translation.vector - w[0].1.translation.vector).norm()).sum();
        let rotation = first.1.rotation.angle_to(&last.1.rotation);
        if samples.len() < 3 || (path < self.min_motion && rotation < self.min_rotation) {
            if samples.len() >= 2 {
                notes.push(Note {
                    t,
                    text: format!(
                        "a {} segment towards {object} from {:.2} s to {:.2} s has no motion (path {:.1} mm, rotation {:.1} deg, {} samples): dropped, no primitive",
                        kind.prefix(),
                        first.0,
                        last.0,
                        path * 1e3,
                        rotation.to_degrees(),
                        samples.len()
                    ),
                });
            }
            return;
        }
        let index = self.take_index();
        let id = format!("{}{}{index}", self.label_prefix, kind.prefix());
        out.push(Segment {
            index,
            label: format!("{id}({object})"),
            id,
            kind,
            frame: if object == WORLD { Isometry3::identity() } else { self.frame_of(object) },
            object: object.to_owned(),
            t_start: first.0,
            t_end: last.0,
            samples,
            gripper: None,
            home: None,
        });
    }
}
