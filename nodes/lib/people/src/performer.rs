//! A performer (one person with a script of actions) and a timeline of performers.

use nalgebra::{Point2, Point3, Vector3};

use crate::body::BodySize;
use crate::error::{Result, check_range};
use crate::kinematics::BodyConfig;
use crate::motion::{Action, Clip, Span, Stance, Sway, validate_stance};
use crate::pose::{SEGMENT_COUNT, SkeletonPose};

/// Floor height in the robot base frame: the table top is z = 0 and 0.75 m above the floor (m).
pub const DEFAULT_FLOOR_Z: f64 = -0.75;

/// Step of the central differences that give the velocities (s).
const VELOCITY_STEP_S: f64 = 5e-4;

/// One person performing a script: a sequence of [`Action`]s, each starting where the previous
/// one ended. The pose is a deterministic function of time and of the seed (which draws the
/// postural sway).
#[derive(Clone, Debug)]
pub struct Performer {
    person_id: u32,
    body: BodySize,
    floor_z: f64,
    seed: u64,
    start: Stance,
    clips: Vec<Clip>,
    sway: Sway,
}

impl Performer {
    /// A person of size `body` standing at `start`, floor at [`DEFAULT_FLOOR_Z`].
    pub fn new(person_id: u32, body: BodySize, start: Stance, seed: u64) -> Result<Self> {
        BodySize::new(body.height)?;
        validate_stance(&start)?;
        Ok(Self { person_id, body, floor_z: DEFAULT_FLOOR_Z, seed, start, clips: Vec::new(), sway: Sway::new(seed) })
    }

    /// Sets the floor height (m, base frame z, −3 to 1).
    pub fn with_floor_z(mut self, floor_z: f64) -> Result<Self> {
        check_range("floor z (m)", floor_z, -3.0, 1.0, "-3 to 1 m")?;
        self.floor_z = floor_z;
        Ok(self)
    }

    /// Appends an action; returns its span.
    pub fn push(&mut self, action: Action) -> Result<Span> {
        let (start, from) = match self.clips.last() {
            Some(c) => (c.start + c.duration, c.to),
            None => (0.0, self.start),
        };
        let clip = Clip::compile(&action, start, from, &self.body, self.floor_z)?;
        self.clips.push(clip);
        Ok(Span { kind: clip.span_kind(), start, end: start + clip.duration })
    }

    /// Builder form of [`Self::push`].
    pub fn then(mut self, action: Action) -> Result<Self> {
        self.push(action)?;
        Ok(self)
    }

    /// Tracker id.
    pub fn person_id(&self) -> u32 {
        self.person_id
    }

    /// Body size.
    pub fn body(&self) -> BodySize {
        self.body
    }

    /// Floor height (m, base frame z).
    pub fn floor_z(&self) -> f64 {
        self.floor_z
    }

    /// Seed of the sway.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Stance at the start.
    pub fn start_stance(&self) -> Stance {
        self.start
    }

    /// Stance at the end of the script.
    pub fn end_stance(&self) -> Stance {
        self.clips.last().map_or(self.start, |c| c.to)
    }

    /// Length of the script (s).
    pub fn duration(&self) -> f64 {
        self.clips.last().map_or(0.0, |c| c.start + c.duration)
    }

    /// The labelled spans of the script, in order.
    pub fn spans(&self) -> Vec<Span> {
        self.clips.iter().map(|c| Span { kind: c.span_kind(), start: c.start, end: c.start + c.duration }).collect()
    }

    fn config(&self, t: f64) -> BodyConfig {
        let idx = self.clips.partition_point(|c| c.start + c.duration < t);
        match self.clips.get(idx).or(self.clips.last()) {
            Some(c) => c.eval(&self.body, self.floor_z, t - c.start, &self.sway, t),
            None => {
                let mut c = BodyConfig::standing(&self.body, self.floor_z, self.start.position.coords, self.start.yaw);
                self.sway.apply(&mut c, t);
                c
            }
        }
    }

    /// Noise-free pose at time `t` (s; before 0 and after [`Self::duration`] the person holds
    /// the first and last posture, still swaying). Velocities are central differences over
    /// ±0.5 ms of the pose function, i.e. its time derivative to within ~1e-6 relative.
    pub fn pose(&self, t: f64) -> SkeletonPose {
        let mut pose = self.config(t).pose(&self.body, self.floor_z, t);
        let h = VELOCITY_STEP_S;
        let before = self.config(t - h).forward_kinematics(&self.body, self.floor_z);
        let after = self.config(t + h).forward_kinematics(&self.body, self.floor_z);
        for i in 0..SEGMENT_COUNT {
            let s = &mut pose.segments[i];
            s.linear_velocity = (after[i].position - before[i].position) / (2.0 * h);
            s.angular_velocity = (after[i].orientation * before[i].orientation.inverse()).scaled_axis() / (2.0 * h);
        }
        pose
    }
}

/// Several performers placed on one clock: performer `i` starts at `offset` s and is present
/// (tracked) from then until its script ends.
#[derive(Clone, Debug, Default)]
pub struct Timeline {
    entries: Vec<TimelineEntry>,
}

/// A performer and the time its script starts (s, timeline time).
#[derive(Clone, Debug)]
pub struct TimelineEntry {
    /// Start of the performer's script on the timeline (s).
    pub offset: f64,
    /// The performer.
    pub performer: Performer,
}

/// A span of one performer in timeline time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimelineSpan {
    /// Which person.
    pub person_id: u32,
    /// The span, with start and end in timeline time (s).
    pub span: Span,
}

impl Timeline {
    /// Empty timeline.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `performer` starting at `offset` s (finite, ≥ 0).
    pub fn add(&mut self, offset: f64, performer: Performer) -> Result<()> {
        check_range("timeline offset (s)", offset, 0.0, 1e7, "0 to 1e7 s")?;
        self.entries.push(TimelineEntry { offset, performer });
        Ok(())
    }

    /// The entries in insertion order.
    pub fn entries(&self) -> &[TimelineEntry] {
        &self.entries
    }

    /// End of the last script (s).
    pub fn duration(&self) -> f64 {
        self.entries.iter().map(|e| e.offset + e.performer.duration()).fold(0.0, f64::max)
    }

    /// Noise-free poses of the performers present at `t` (s), as (person id, pose); the pose's
    /// `time` is timeline time.
    pub fn poses_at(&self, t: f64) -> Vec<(u32, SkeletonPose)> {
        self.entries
            .iter()
            .filter(|e| t >= e.offset && t <= e.offset + e.performer.duration())
            .map(|e| {
                let mut p = e.performer.pose(t - e.offset);
                p.time = t;
                (e.performer.person_id(), p)
            })
            .collect()
    }

    /// Every labelled span of every performer, in timeline time, sorted by start.
    pub fn spans(&self) -> Vec<TimelineSpan> {
        let mut out: Vec<TimelineSpan> = self
            .entries
            .iter()
            .flat_map(|e| {
                e.performer.spans().into_iter().map(move |s| TimelineSpan {
                    person_id: e.performer.person_id(),
                    span: Span { start: s.start + e.offset, end: s.end + e.offset, ..s },
                })
            })
            .collect();
        out.sort_by(|a, b| a.span.start.total_cmp(&b.span.start));
        out
    }
}

/// The room around the robot table (base frame: table top z = 0, robot base at the origin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Room {
    /// Floor height (m).
    pub floor_z: f64,
    /// Depth camera position (m), for facing ("viewing") angles.
    pub camera: Point3<f64>,
    /// Where a person stands to work beside the robot (m).
    pub standing_spot: Point2<f64>,
    /// Far point a person walks in from and out to, outside the camera's view (m).
    pub entry: Point2<f64>,
    /// Point a standing person faces (m): the middle of the robot's workspace.
    pub workspace_centre: Point3<f64>,
}

impl Default for Room {
    /// The stacking / kitchen scenes of `config/scenes`: table 1.4 × 1.8 m centred at
    /// (0.45, 0), camera at (1.9, 0, 0.9) looking at (0.45, 0, 0.2); the person stands beside
    /// the table's −y edge near the robot, where the camera's 62° horizontal field of view still
    /// sees the whole body (further towards the camera, x ≳ 0.2, the body leaves the image).
    fn default() -> Self {
        Self {
            floor_z: DEFAULT_FLOOR_Z,
            camera: Point3::new(1.9, 0.0, 0.9),
            standing_spot: Point2::new(0.0, -1.02),
            entry: Point2::new(0.6, -3.5),
            workspace_centre: Point3::new(0.45, -0.3, 0.0),
        }
    }
}

impl Room {
    /// Yaw (rad) that makes a person at `at` face the camera turned by `view_angle` rad
    /// (0 = facing the camera, positive = turned to the person's left).
    pub fn yaw_for_view_angle(&self, at: &Point2<f64>, view_angle: f64) -> f64 {
        (self.camera.y - at.y).atan2(self.camera.x - at.x) + view_angle
    }

    /// Viewing angle (rad) of a person at `at` facing `yaw`: the facing direction relative to
    /// the direction towards the camera, wrapped to (−π, π].
    pub fn view_angle(&self, at: &Point2<f64>, yaw: f64) -> f64 {
        let d = Vector3::new(self.camera.x - at.x, self.camera.y - at.y, 0.0);
        let f = Vector3::new(yaw.cos(), yaw.sin(), 0.0);
        d.cross(&f).z.atan2(d.dot(&f))
    }

    /// A visit of the stacking scenario (thesis Sec. 5.1.3): walk in from [`Self::entry`] to
    /// the standing spot facing the workspace, stand, reach with the right hand towards
    /// `reach_target` (e.g. a point on the robot arm), stand, sweep the right hand along
    /// `sweep` (e.g. across the robot's path), stand, walk out.
    pub fn visit(
        &self,
        person_id: u32,
        body: BodySize,
        seed: u64,
        reach_target: Point3<f64>,
        sweep: (Point3<f64>, Point3<f64>),
    ) -> Result<Performer> {
        let facing = |p: &Point2<f64>| (self.workspace_centre.y - p.y).atan2(self.workspace_centre.x - p.x);
        let start = Stance { position: self.entry, yaw: facing(&self.entry) };
        Performer::new(person_id, body, start, seed)?
            .with_floor_z(self.floor_z)?
            .then(Action::Walk { to: self.standing_spot, speed: 1.1, face_yaw: Some(facing(&self.standing_spot)) })?
            .then(Action::Stand { duration: 1.5 })?
            .then(Action::Reach { side: crate::Side::Right, target: reach_target, duration: 1.2, hold: 1.0 })?
            .then(Action::Stand { duration: 1.0 })?
            .then(Action::Sweep { side: crate::Side::Right, from: sweep.0, to: sweep.1, duration: 1.5 })?
            .then(Action::Stand { duration: 1.0 })?
            .then(Action::Walk { to: self.entry, speed: 1.2, face_yaw: None })
    }
}
