//! Motions as deterministic functions of time: actions, their compiled clips and evaluation.

use cowork_msgs::msg::Gesture;
use nalgebra::{Point2, Point3, Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::body::BodySize;
use crate::error::{Result, check_finite, check_range};
use crate::kinematics::{ArmAngles, ArmConfig, BodyConfig, REST_ARM, arm_ik};
use crate::pose::{Segment, Side};

/// Where a person stands: floor point below the hips and facing direction.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stance {
    /// Floor position (m, base frame x, y).
    pub position: Point2<f64>,
    /// Facing direction (rad about base z; 0 faces +x).
    pub yaw: f64,
}

impl Stance {
    /// Standing at `(x, y)` facing `yaw`.
    pub fn new(x: f64, y: f64, yaw: f64) -> Self {
        Self { position: Point2::new(x, y), yaw }
    }

    /// Standing at `(x, y)` facing the point `target` (base frame, only x and y count).
    pub fn facing(x: f64, y: f64, target: &Point3<f64>) -> Self {
        Self::new(x, y, (target.y - y).atan2(target.x - x))
    }

    fn validate(&self, what: &str) -> Result<()> {
        check_finite(&format!("{what} x (m)"), self.position.x)?;
        check_finite(&format!("{what} y (m)"), self.position.y)?;
        check_finite(&format!("{what} yaw (rad)"), self.yaw)
    }
}

/// The three command gestures of thesis Sec. 5.1.3.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GestureKind {
    /// Beckoning with the right hand, palm towards oneself, repeated elbow and wrist flexion.
    Come,
    /// Right arm raised forward, palm out, fingers up, held.
    Stop,
    /// Right hand held out forward, palm up, as if to receive an object.
    HandoverRight,
}

impl GestureKind {
    /// All gestures.
    pub const ALL: [GestureKind; 3] = [GestureKind::Come, GestureKind::Stop, GestureKind::HandoverRight];

    /// The `cowork_msgs/Gesture` label (`LABEL_*`).
    pub fn label(self) -> &'static str {
        match self {
            GestureKind::Come => Gesture::LABEL_COME,
            GestureKind::Stop => Gesture::LABEL_STOP,
            GestureKind::HandoverRight => Gesture::LABEL_HANDOVER_RIGHT,
        }
    }

    /// The gesture with label `label`, if any.
    pub fn from_label(label: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|g| g.label() == label)
    }

    /// Nominal (ramp in, body, ramp out) durations at `style` (s).
    fn phases(self, style: &GestureStyle) -> (f64, f64, f64) {
        let k = style.duration_scale;
        match self {
            GestureKind::Come => (0.6 * k, f64::from(style.repetitions) / COME_FREQUENCY_HZ * k, 0.6 * k),
            GestureKind::Stop => (0.7 * k, 1.2 * k, 0.7 * k),
            GestureKind::HandoverRight => (0.9 * k, 1.6 * k, 0.8 * k),
        }
    }

    /// Right-arm angles `tau` s into the gesture body.
    fn arm_angles(self, style: &GestureStyle, tau: f64) -> ArmAngles {
        let a = match self {
            GestureKind::Come => {
                let phase = std::f64::consts::TAU * COME_FREQUENCY_HZ * tau / style.duration_scale;
                let osc = 0.5 * (1.0 - phase.cos());
                ArmAngles {
                    flex: 0.5,
                    abd: 0.15,
                    rot: 0.0,
                    elbow: 1.3 + 0.65 * osc,
                    pronation: 0.15,
                    wrist_flex: 0.15 + 0.6 * osc,
                    wrist_dev: 0.0,
                }
            }
            GestureKind::Stop => {
                // A slight push forward while held.
                let push = 0.04 * (std::f64::consts::PI * tau / (1.2 * style.duration_scale)).sin();
                ArmAngles {
                    flex: 1.45 + push,
                    abd: 0.12,
                    rot: 0.0,
                    elbow: 0.2 - push,
                    pronation: 2.9,
                    wrist_flex: -1.2,
                    wrist_dev: 0.0,
                }
            }
            GestureKind::HandoverRight => ArmAngles {
                flex: 0.8,
                abd: 0.15,
                rot: -0.1,
                elbow: 0.75,
                pronation: 0.1,
                wrist_flex: -0.15,
                wrist_dev: 0.0,
            },
        };
        let mut a = a.scaled_from(&REST_ARM, style.amplitude);
        a.flex += style.tilt;
        a.abd += 0.5 * style.tilt;
        a
    }
}

/// Beckoning frequency of `come` at duration scale 1 (Hz).
const COME_FREQUENCY_HZ: f64 = 1.3;

/// How a gesture is performed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GestureStyle {
    /// Multiplies every duration (1 = nominal; 2 = twice as slow). Range 0.3 to 3.
    pub duration_scale: f64,
    /// Scales the joint excursions from the rest posture (1 = nominal). Range 0.5 to 1.5.
    pub amplitude: f64,
    /// Beckoning repetitions of `come` (1 to 8; ignored by the others).
    pub repetitions: u32,
    /// Added to the shoulder flexion, half of it to the abduction (rad, −0.4 to 0.4): personal
    /// variation of the arm height.
    pub tilt: f64,
}

impl Default for GestureStyle {
    fn default() -> Self {
        Self { duration_scale: 1.0, amplitude: 1.0, repetitions: 3, tilt: 0.0 }
    }
}

impl GestureStyle {
    fn validate(&self) -> Result<()> {
        check_range("gesture duration_scale", self.duration_scale, 0.3, 3.0, "0.3 to 3")?;
        check_range("gesture amplitude", self.amplitude, 0.5, 1.5, "0.5 to 1.5")?;
        check_range("gesture repetitions", f64::from(self.repetitions), 1.0, 8.0, "1 to 8")?;
        check_range("gesture tilt (rad)", self.tilt, -0.4, 0.4, "-0.4 to 0.4 rad")
    }
}

/// One step of a performer's script. Positions are in the robot base frame (m).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Action {
    /// Idle standing with small postural sway for `duration` s.
    Stand {
        /// s, > 0.
        duration: f64,
    },
    /// Turn in place to face `yaw` (rad).
    Turn {
        /// Final facing (rad about base z).
        yaw: f64,
    },
    /// Turn towards `to`, walk there (minimum-jerk progress with peak speed `speed` m/s, legs
    /// and arms swinging), then turn to `face_yaw` if given.
    Walk {
        /// Destination floor point (m).
        to: Point2<f64>,
        /// Peak walking speed (m/s, 0.2 to 2.5).
        speed: f64,
        /// Facing at the end (rad); the walking direction if `None`.
        face_yaw: Option<f64>,
    },
    /// Reach with one hand towards `target` in `duration` s (leaning forward if needed), hold
    /// `hold` s, return in `duration` s.
    Reach {
        /// Which hand.
        side: Side,
        /// Point the hand (the `*_hand` segment point) goes to (m).
        target: Point3<f64>,
        /// Reach time (s), also the return time.
        duration: f64,
        /// Holding time at the target (s, ≥ 0).
        hold: f64,
    },
    /// Bring one hand to `from` (0.8 s), sweep it along the straight line to `to` in `duration`
    /// s, palm down, and bring it back (0.8 s).
    Sweep {
        /// Which hand.
        side: Side,
        /// Start of the line (m).
        from: Point3<f64>,
        /// End of the line (m).
        to: Point3<f64>,
        /// Sweep time (s).
        duration: f64,
    },
    /// One of the command gestures (right arm).
    Gesture {
        /// Which gesture.
        kind: GestureKind,
        /// Speed, amplitude and repetitions.
        style: GestureStyle,
    },
}

/// What a span of a performer's timeline is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpanKind {
    /// [`Action::Stand`].
    Stand,
    /// [`Action::Turn`].
    Turn,
    /// [`Action::Walk`].
    Walk,
    /// [`Action::Reach`].
    Reach,
    /// [`Action::Sweep`].
    Sweep,
    /// [`Action::Gesture`].
    Gesture(GestureKind),
}

/// A labelled time span of a performer (s, performer time).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Span {
    /// What happens.
    pub kind: SpanKind,
    /// Start (s).
    pub start: f64,
    /// End (s).
    pub end: f64,
}

/// Sweep ramp time in and out (s).
const SWEEP_RAMP_S: f64 = 0.8;
/// Turning rate of in-place turns (rad/s).
const TURN_RATE: f64 = 2.0;
/// Largest forward lean used to extend a reach (rad).
const MAX_LEAN: f64 = 0.6;

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum ClipKind {
    Stand,
    Turn { yaw: f64 },
    Walk { turn1: f64, walk: f64, turn2: f64, heading: f64, dir: Vector2<f64>, dist: f64, stride: f64, end_yaw: f64 },
    Reach { side: Side, target: Point3<f64>, ramp: f64, hold: f64, lean: f64 },
    Sweep { side: Side, from: Point3<f64>, to: Point3<f64>, ramp: f64, sweep: f64, lean: f64 },
    Gesture { kind: GestureKind, style: GestureStyle, ramp_in: f64, body: f64, ramp_out: f64 },
}

/// An action compiled against the stance it starts from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Clip {
    pub start: f64,
    pub duration: f64,
    pub from: Stance,
    pub to: Stance,
    pub kind: ClipKind,
}

/// Minimum-jerk progress 0 → 1 for `u` in [0, 1] (clamped outside).
pub(crate) fn min_jerk(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * u * (10.0 + u * (-15.0 + 6.0 * u))
}

/// Angle difference `b − a` wrapped to (−π, π].
fn wrap_diff(a: f64, b: f64) -> f64 {
    let mut d = (b - a) % std::f64::consts::TAU;
    if d > std::f64::consts::PI {
        d -= std::f64::consts::TAU;
    } else if d <= -std::f64::consts::PI {
        d += std::f64::consts::TAU;
    }
    d
}

fn turn_time(from: f64, to: f64) -> f64 {
    let d = wrap_diff(from, to).abs();
    if d < 1e-6 { 0.0 } else { 0.4 + d / TURN_RATE }
}

impl Clip {
    /// Compiles `action` to start at `start` s from `from`.
    pub fn compile(action: &Action, start: f64, from: Stance, body: &BodySize, floor_z: f64) -> Result<Clip> {
        let positive = |what: &str, v: f64| check_range(what, v, 1e-3, 600.0, "1 ms to 600 s");
        let point = |what: &str, p: &Point3<f64>| -> Result<()> {
            for (c, v) in ["x", "y", "z"].iter().zip(p.iter()) {
                check_finite(&format!("{what} {c} (m)"), *v)?;
            }
            Ok(())
        };
        let (kind, duration, to) = match *action {
            Action::Stand { duration } => {
                positive("stand duration (s)", duration)?;
                (ClipKind::Stand, duration, from)
            }
            Action::Turn { yaw } => {
                check_finite("turn yaw (rad)", yaw)?;
                let d = turn_time(from.yaw, yaw).max(0.2);
                (ClipKind::Turn { yaw }, d, Stance { yaw, ..from })
            }
            Action::Walk { to, speed, face_yaw } => {
                check_finite("walk target x (m)", to.x)?;
                check_finite("walk target y (m)", to.y)?;
                check_range("walk speed (m/s)", speed, 0.2, 2.5, "0.2 to 2.5 m/s")?;
                if let Some(y) = face_yaw {
                    check_finite("walk face_yaw (rad)", y)?;
                }
                let delta = to - from.position;
                let dist = delta.norm();
                let (heading, dir) = if dist > 1e-6 { (delta.y.atan2(delta.x), delta / dist) } else { (from.yaw, Vector2::new(from.yaw.cos(), from.yaw.sin())) };
                let end_yaw = face_yaw.unwrap_or(heading);
                let turn1 = if dist > 1e-6 { turn_time(from.yaw, heading) } else { 0.0 };
                // Peak speed of a minimum-jerk profile is 1.875 × mean speed.
                let walk = if dist > 1e-6 { 1.875 * dist / speed + 0.3 } else { 0.0 };
                let turn2 = turn_time(heading, end_yaw);
                let step = 0.36 * body.height * (speed / 1.2).clamp(0.4, 1.5).sqrt();
                let d = (turn1 + walk + turn2).max(0.2);
                let kind = ClipKind::Walk { turn1, walk, turn2, heading, dir, dist, stride: 2.0 * step, end_yaw };
                (kind, d, Stance { position: to, yaw: end_yaw })
            }
            Action::Reach { side, target, duration, hold } => {
                point("reach target", &target)?;
                positive("reach duration (s)", duration)?;
                check_range("reach hold (s)", hold, 0.0, 600.0, "0 to 600 s")?;
                let lean = lean_for(body, floor_z, &from, side, &[target]);
                (ClipKind::Reach { side, target, ramp: duration, hold, lean }, 2.0 * duration + hold, from)
            }
            Action::Sweep { side, from: a, to: b, duration } => {
                point("sweep start", &a)?;
                point("sweep end", &b)?;
                positive("sweep duration (s)", duration)?;
                let lean = lean_for(body, floor_z, &from, side, &[a, b]);
                let kind = ClipKind::Sweep { side, from: a, to: b, ramp: SWEEP_RAMP_S, sweep: duration, lean };
                (kind, duration + 2.0 * SWEEP_RAMP_S, from)
            }
            Action::Gesture { kind, style } => {
                style.validate()?;
                let (ramp_in, body_t, ramp_out) = kind.phases(&style);
                (ClipKind::Gesture { kind, style, ramp_in, body: body_t, ramp_out }, ramp_in + body_t + ramp_out, from)
            }
        };
        from.validate("stance")?;
        Ok(Clip { start, duration, from, to, kind })
    }

    pub fn span_kind(&self) -> SpanKind {
        match self.kind {
            ClipKind::Stand => SpanKind::Stand,
            ClipKind::Turn { .. } => SpanKind::Turn,
            ClipKind::Walk { .. } => SpanKind::Walk,
            ClipKind::Reach { .. } => SpanKind::Reach,
            ClipKind::Sweep { .. } => SpanKind::Sweep,
            ClipKind::Gesture { kind, .. } => SpanKind::Gesture(kind),
        }
    }

    /// Body configuration `tau` s into the clip; `sway` is applied before the arms are placed,
    /// so reaching hands still hit their targets.
    pub fn eval(&self, body: &BodySize, floor_z: f64, tau: f64, sway: &Sway, t_abs: f64) -> BodyConfig {
        let tau = tau.clamp(0.0, self.duration);
        let mut c = BodyConfig::standing(body, floor_z, self.from.position.coords, self.from.yaw);
        let mut gait: Option<(f64, f64, f64)> = None;
        match self.kind {
            ClipKind::Stand | ClipKind::Reach { .. } | ClipKind::Sweep { .. } | ClipKind::Gesture { .. } => {}
            ClipKind::Turn { yaw } => {
                c.yaw = self.from.yaw + wrap_diff(self.from.yaw, yaw) * min_jerk(tau / self.duration);
            }
            ClipKind::Walk { turn1, walk, turn2, heading, dir, dist, stride, end_yaw } => {
                if tau < turn1 {
                    c.yaw = self.from.yaw + wrap_diff(self.from.yaw, heading) * min_jerk(tau / turn1);
                } else if tau < turn1 + walk || turn2 <= 0.0 {
                    let u = if walk > 0.0 { (tau - turn1) / walk } else { 1.0 };
                    let s = dist * min_jerk(u);
                    c.position += s * dir;
                    c.yaw = heading;
                    let half = 0.5 * stride;
                    let env = smoothstep(s / half) * smoothstep((dist - s) / half);
                    gait = Some((s / stride, env, stride));
                } else {
                    c.position += dist * dir;
                    c.yaw = heading + wrap_diff(heading, end_yaw) * min_jerk((tau - turn1 - walk) / turn2);
                }
            }
        }
        sway.apply(&mut c, t_abs);
        let (mut along, mut lift) = ([0.0; 2], [0.0; 2]);
        if let Some((phase, env, stride)) = gait {
            let l = body.lengths();
            let amp = 0.3 * stride;
            let mut drop = 0.0;
            for side in [Side::Right, Side::Left] {
                let i = side.index();
                let ph = phase + 0.5 * i as f64;
                let (o, h) = foot_cycle(ph, amp, 0.06 * body.height);
                along[i] = env * o;
                lift[i] = env * h;
                let leg = 0.995 * (l.thigh + l.shank);
                let need = (leg * leg - along[i] * along[i]).max(0.0).sqrt();
                // The feet swing in opposition: a smooth sum of the two needs is about their max.
                drop += soft_positive(l.hip_height - (l.ankle_height + lift[i] + need), 0.005);
            }
            let cap = 0.03 * body.height;
            c.pelvis_drop += cap * (drop / cap).tanh();
            c.trunk_pitch += 0.05 * env;
            let swing = 0.3 * env * (std::f64::consts::TAU * phase).cos();
            for side in [Side::Right, Side::Left] {
                let mut a = REST_ARM;
                a.flex -= side.sign() * swing;
                a.elbow += 0.25 * env;
                c.arms[side.index()] = ArmConfig::from_angles(side, &a);
            }
        }
        c.feet = c.feet_at(body, floor_z, along, lift);
        match self.kind {
            ClipKind::Reach { side, target, ramp, hold, lean } => {
                let w = ramp_weight(tau, ramp, hold, ramp);
                c.trunk_pitch += w * lean;
                look_at(&mut c, body, floor_z, &target, w);
                let arm = reach_arm(&c, body, floor_z, side, &target, 1.8, 0.0);
                c.arms[side.index()] = c.arms[side.index()].blend(&arm, w);
            }
            ClipKind::Sweep { side, from, to, ramp, sweep, lean } => {
                let w = ramp_weight(tau, ramp, sweep, ramp);
                let target = from + (to - from) * min_jerk((tau - ramp) / sweep);
                c.trunk_pitch += w * lean;
                look_at(&mut c, body, floor_z, &target, w);
                let arm = reach_arm(&c, body, floor_z, side, &target, 2.6, 0.1);
                c.arms[side.index()] = c.arms[side.index()].blend(&arm, w);
            }
            ClipKind::Gesture { kind, style, ramp_in, body: body_t, ramp_out } => {
                let w = ramp_weight(tau, ramp_in, body_t, ramp_out);
                let a = kind.arm_angles(&style, (tau - ramp_in).clamp(0.0, body_t));
                let arm = ArmConfig::from_angles(Side::Right, &a);
                c.arms[0] = c.arms[0].blend(&arm, w);
            }
            _ => {}
        }
        c
    }
}

/// 0 → 1 smoothly (cubic smoothstep), clamped.
fn smoothstep(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * (3.0 - 2.0 * u)
}

/// Weight rising over `rise` s (minimum jerk), 1 for `hold` s, falling over `fall` s.
fn ramp_weight(tau: f64, rise: f64, hold: f64, fall: f64) -> f64 {
    if tau < rise {
        min_jerk(tau / rise)
    } else if tau <= rise + hold {
        1.0
    } else {
        1.0 - min_jerk((tau - rise - hold) / fall)
    }
}

/// Foot offset along the walking direction relative to the hips and foot lift (m) at gait phase
/// `phase` (cycles): stance for 60 % of the cycle (the foot stays on the floor while the body
/// passes over it), swing for 40 % (a cubic Hermite curve that leaves and lands with the stance
/// velocity, so the offset is C1; the lift is `clearance`·sin² for the same reason).
fn foot_cycle(phase: f64, amp: f64, clearance: f64) -> (f64, f64) {
    let u = phase.rem_euclid(1.0);
    if u < 0.6 {
        (amp * (1.0 - 2.0 * u / 0.6), 0.0)
    } else {
        let v = (u - 0.6) / 0.4;
        // Stance slope d(offset)/du = −2A/0.6, i.e. −(0.4 · 2A/0.6) per unit v.
        let m = -0.4 * 2.0 * amp / 0.6;
        let (v2, v3) = (v * v, v * v * v);
        let h00 = 2.0 * v3 - 3.0 * v2 + 1.0;
        let h10 = v3 - 2.0 * v2 + v;
        let h01 = -2.0 * v3 + 3.0 * v2;
        let h11 = v3 - v2;
        let o = -amp * h00 + m * h10 + amp * h01 + m * h11;
        let lift = clearance * (std::f64::consts::PI * v).sin().powi(2);
        (o, lift)
    }
}

/// max(x, 0), smoothed over ±`eps` (C∞).
fn soft_positive(x: f64, eps: f64) -> f64 {
    0.5 * (x + (x * x + eps * eps).sqrt())
}

/// `x` clamped to [lo, hi] smoothly (tanh saturation around the middle of the range).
fn soft_clamp(x: f64, lo: f64, hi: f64) -> f64 {
    let mid = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo);
    mid + half * ((x - mid) / half).tanh()
}

/// Turns the head towards `target` with weight `w`.
fn look_at(c: &mut BodyConfig, body: &BodySize, floor_z: f64, target: &Point3<f64>, w: f64) {
    let l = body.lengths();
    let f = c.trunk_frames(&l, floor_z);
    let head = f.pelvis_pos + f.trunk * Vector3::new(0.0, 0.0, l.pelvis_to_neck + l.neck_to_head);
    let d = f.trunk.inverse() * (target - head);
    let pitch = soft_clamp((-d.z).atan2(d.xy().norm().max(1e-6)), -0.4, 0.8);
    let yaw = soft_clamp(d.y.atan2(d.x.max(1e-6)), -1.0, 1.0);
    c.head_pitch += w * pitch;
    c.head_yaw += w * yaw;
}

/// Arm with the hand point at `target`: IK for the wrist, corrected twice for the hand offset
/// along the forearm.
fn reach_arm(c: &BodyConfig, body: &BodySize, floor_z: f64, side: Side, target: &Point3<f64>, pronation: f64, wrist_flex: f64) -> ArmConfig {
    let half_hand = 0.5 * body.lengths().hand;
    let mut wrist = *target;
    let mut arm = arm_ik(c, body, floor_z, side, &wrist, pronation, wrist_flex);
    for _ in 0..3 {
        let mut c2 = *c;
        c2.arms[side.index()] = arm;
        let seg = c2.forward_kinematics(body, floor_z);
        let [_, _, wr, ha] = Segment::arm(side);
        let dir = seg[ha.index()].position - seg[wr.index()].position;
        wrist = target - dir.normalize() * half_hand;
        arm = arm_ik(c, body, floor_z, side, &wrist, pronation, wrist_flex);
    }
    arm
}

/// Smallest forward lean (rad, ≤ [`MAX_LEAN`]) that brings every target within 95 % of the
/// arm's reach.
fn lean_for(body: &BodySize, floor_z: f64, from: &Stance, side: Side, targets: &[Point3<f64>]) -> f64 {
    let l = body.lengths();
    let reach = 0.95 * body.arm_reach();
    let mut c = BodyConfig::standing(body, floor_z, from.position.coords, from.yaw);
    let mut lean = 0.0;
    while lean < MAX_LEAN {
        c.trunk_pitch = lean;
        let f = c.trunk_frames(&l, floor_z);
        let sh = BodyConfig::shoulder(&f, &l, side);
        if targets.iter().all(|t| (t - sh).norm() <= reach) {
            return lean;
        }
        lean += 0.02;
    }
    MAX_LEAN
}

/// Postural sway: slow sums of sines with random frequencies and phases, drawn once per
/// performer from its seed, so a pose is a deterministic function of time.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Sway {
    /// (amplitude, frequency Hz, phase rad) × 2 per degree of freedom: x, y, pitch, roll,
    /// head yaw, head pitch.
    terms: [[(f64, f64, f64); 2]; 6],
}

impl Sway {
    pub fn new(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5ba7_5ba7_5ba7_5ba7);
        let amps = [0.006, 0.006, 0.012, 0.008, 0.06, 0.03];
        let terms = amps.map(|a| {
            [0, 1].map(|_| {
                let amp = a * rng.random_range(0.5..1.0);
                let f = rng.random_range(0.08..0.4);
                let ph = rng.random_range(0.0..std::f64::consts::TAU);
                (amp, f, ph)
            })
        });
        Self { terms }
    }

    fn value(&self, i: usize, t: f64) -> f64 {
        self.terms[i].iter().map(|(a, f, p)| a * (std::f64::consts::TAU * f * t + p).sin()).sum()
    }

    pub fn apply(&self, c: &mut BodyConfig, t: f64) {
        let (s, co) = c.yaw.sin_cos();
        let (dx, dy) = (self.value(0, t), self.value(1, t));
        c.position += Vector2::new(co * dx - s * dy, s * dx + co * dy);
        c.trunk_pitch += self.value(2, t);
        c.trunk_roll += self.value(3, t);
        c.head_yaw += self.value(4, t);
        c.head_pitch += self.value(5, t);
    }
}

/// Validation of a seedless stance (used by the performer).
pub(crate) fn validate_stance(s: &Stance) -> Result<()> {
    s.validate("start stance")
}
