//! Body configuration (stance, trunk, head, arm joint angles, feet) and its forward kinematics.
//!
//! The arm is a 7-DoF chain in the trunk frame: a 3-DoF shoulder (`upper`, a rotation taking the
//! hanging arm to the upper-arm frame), elbow flexion, forearm pronation and two wrist angles.
//! Segment lengths are fixed by construction, so every pose is a rigid body chain.

use nalgebra::{Matrix3, Point3, Rotation3, UnitQuaternion, Vector2, Vector3};

use crate::body::{BodySize, SegmentLengths};
use crate::pose::{Foot, SEGMENT_COUNT, Segment, SegmentState, Side, SkeletonPose};

/// Joint configuration of one arm (rad), relative to the trunk frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ArmConfig {
    /// Upper-arm frame in the trunk frame; identity = arm hanging down (−z), palm forward.
    pub upper: UnitQuaternion<f64>,
    /// Elbow flexion (0 = straight).
    pub elbow: f64,
    /// Forearm pronation (0 = palm forward when hanging, π/2 = palm towards the thigh).
    pub pronation: f64,
    /// Wrist flexion towards the palm (negative = extension).
    pub wrist_flex: f64,
    /// Wrist radial/ulnar deviation.
    pub wrist_dev: f64,
}

/// Shoulder, elbow and wrist angles of an arm (rad); see [`ArmConfig::from_angles`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ArmAngles {
    /// Shoulder flexion (raising the arm forward).
    pub flex: f64,
    /// Shoulder abduction (raising the arm sideways, outwards).
    pub abd: f64,
    /// Humeral rotation (internal positive).
    pub rot: f64,
    pub elbow: f64,
    pub pronation: f64,
    pub wrist_flex: f64,
    pub wrist_dev: f64,
}

impl ArmAngles {
    pub fn scaled_from(&self, rest: &ArmAngles, amplitude: f64) -> ArmAngles {
        let s = |a: f64, r: f64| r + amplitude * (a - r);
        ArmAngles {
            flex: s(self.flex, rest.flex),
            abd: s(self.abd, rest.abd),
            rot: s(self.rot, rest.rot),
            elbow: s(self.elbow, rest.elbow),
            pronation: self.pronation,
            wrist_flex: s(self.wrist_flex, rest.wrist_flex),
            wrist_dev: s(self.wrist_dev, rest.wrist_dev),
        }
    }
}

/// The relaxed hanging arm: slightly abducted, elbow a little bent, palm towards the thigh.
pub(crate) const REST_ARM: ArmAngles = ArmAngles {
    flex: 0.06,
    abd: 0.10,
    rot: 0.0,
    elbow: 0.22,
    pronation: 1.35,
    wrist_flex: 0.05,
    wrist_dev: 0.0,
};

fn rot_x(a: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::x_axis(), a)
}
fn rot_y(a: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::y_axis(), a)
}
fn rot_z(a: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a)
}

/// `q` or `−q`, whichever has w ≥ 0 (the same rotation), so interpolation stays continuous.
fn canonical(q: UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    if q.w < 0.0 { UnitQuaternion::new_unchecked(-q.into_inner()) } else { q }
}

impl ArmConfig {
    /// The arm of `side` at the given anatomical angles. Flexion turns the arm forward about the
    /// trunk's lateral axis, then abduction turns it outwards about the trunk's forward axis.
    pub fn from_angles(side: Side, a: &ArmAngles) -> Self {
        let s = side.sign();
        let upper = rot_x(-s * a.abd) * rot_y(-a.flex) * rot_z(s * a.rot);
        Self {
            upper: canonical(upper),
            elbow: a.elbow,
            pronation: a.pronation,
            wrist_flex: a.wrist_flex,
            wrist_dev: a.wrist_dev,
        }
    }

    /// Interpolation from `self` (w = 0) to `other` (w = 1): slerp of the shoulder, linear in the
    /// other angles.
    pub fn blend(&self, other: &ArmConfig, w: f64) -> ArmConfig {
        let w = w.clamp(0.0, 1.0);
        let lerp = |a: f64, b: f64| a + w * (b - a);
        let upper = self.upper.try_slerp(&other.upper, w, 1e-9).unwrap_or(if w < 0.5 { self.upper } else { other.upper });
        ArmConfig {
            upper: canonical(upper),
            elbow: lerp(self.elbow, other.elbow),
            pronation: lerp(self.pronation, other.pronation),
            wrist_flex: lerp(self.wrist_flex, other.wrist_flex),
            wrist_dev: lerp(self.wrist_dev, other.wrist_dev),
        }
    }
}

/// Everything that places a body in the room at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct BodyConfig {
    /// Floor point below the hip-joint centre (m, base frame x, y).
    pub position: Vector2<f64>,
    /// Facing direction (rad about the base z axis; 0 = facing +x).
    pub yaw: f64,
    /// Lowering of the hip joints below standing height (m, gait and knee flexion).
    pub pelvis_drop: f64,
    /// Forward lean of the trunk about the hips (rad).
    pub trunk_pitch: f64,
    /// Sideways lean of the trunk (rad, positive to the left).
    pub trunk_roll: f64,
    /// Twist of the trunk relative to the pelvis (rad).
    pub trunk_yaw: f64,
    /// Head nod, positive looking down (rad).
    pub head_pitch: f64,
    /// Head turn, positive to the left (rad).
    pub head_yaw: f64,
    /// Right and left arm (index [`Side::index`]).
    pub arms: [ArmConfig; 2],
    /// Right and left foot.
    pub feet: [Foot; 2],
}

/// Pelvis and trunk frames of a configuration.
pub(crate) struct TrunkFrames {
    pub pelvis_pos: Point3<f64>,
    pub pelvis: UnitQuaternion<f64>,
    pub trunk: UnitQuaternion<f64>,
}

impl BodyConfig {
    /// Standing still at `position` facing `yaw`, arms at rest, feet under the hips.
    pub fn standing(body: &BodySize, floor_z: f64, position: Vector2<f64>, yaw: f64) -> Self {
        let arms = [Side::Right, Side::Left].map(|s| ArmConfig::from_angles(s, &REST_ARM));
        let mut c = BodyConfig {
            position,
            yaw,
            pelvis_drop: 0.0,
            trunk_pitch: 0.0,
            trunk_roll: 0.0,
            trunk_yaw: 0.0,
            head_pitch: 0.0,
            head_yaw: 0.0,
            arms,
            feet: [Foot { ankle: Point3::origin(), heading: Vector3::x() }; 2],
        };
        c.feet = c.feet_at(body, floor_z, [0.0, 0.0], [0.0, 0.0]);
        c
    }

    /// Feet below the hips, each moved `along[i]` m along the facing direction and lifted
    /// `lift[i]` m (index [`Side::index`]).
    pub fn feet_at(&self, body: &BodySize, floor_z: f64, along: [f64; 2], lift: [f64; 2]) -> [Foot; 2] {
        let l = body.lengths();
        let fwd = Vector3::new(self.yaw.cos(), self.yaw.sin(), 0.0);
        let left = Vector3::new(-fwd.y, fwd.x, 0.0);
        [Side::Right, Side::Left].map(|side| {
            let i = side.index();
            let p = Vector3::new(self.position.x, self.position.y, floor_z + l.ankle_height + lift[i])
                - side.sign() * l.hip_half_width * left
                + along[i] * fwd;
            Foot { ankle: Point3::from(p), heading: fwd }
        })
    }

    pub fn trunk_frames(&self, l: &SegmentLengths, floor_z: f64) -> TrunkFrames {
        let pelvis = rot_z(self.yaw);
        let trunk = pelvis * rot_z(self.trunk_yaw) * rot_y(self.trunk_pitch) * rot_x(self.trunk_roll);
        let pelvis_pos = Point3::new(self.position.x, self.position.y, floor_z + l.hip_height - self.pelvis_drop);
        TrunkFrames { pelvis_pos, pelvis, trunk }
    }

    /// Shoulder joint centre of `side` (m, base frame).
    pub fn shoulder(frames: &TrunkFrames, l: &SegmentLengths, side: Side) -> Point3<f64> {
        frames.pelvis_pos + frames.trunk * Vector3::new(0.0, -side.sign() * l.shoulder_half_width, l.pelvis_to_shoulder)
    }

    /// Positions and orientations of the 11 segments (velocities zero).
    pub fn forward_kinematics(&self, body: &BodySize, floor_z: f64) -> [SegmentState; SEGMENT_COUNT] {
        let l = body.lengths();
        let f = self.trunk_frames(&l, floor_z);
        let mut out = [SegmentState::default(); SEGMENT_COUNT];
        let mut set = |s: Segment, p: Point3<f64>, q: UnitQuaternion<f64>| {
            out[s.index()].position = p;
            out[s.index()].orientation = q;
        };
        set(Segment::Pelvis, f.pelvis_pos, f.pelvis);
        set(Segment::Sternum, f.pelvis_pos + f.trunk * Vector3::new(l.sternum_forward, 0.0, l.pelvis_to_sternum), f.trunk);
        let head = f.trunk * rot_z(self.head_yaw) * rot_y(self.head_pitch);
        let neck = f.pelvis_pos + f.trunk * Vector3::new(0.0, 0.0, l.pelvis_to_neck);
        set(Segment::Head, neck + head * Vector3::new(l.head_forward, 0.0, l.neck_to_head), head);
        for side in [Side::Right, Side::Left] {
            let arm = &self.arms[side.index()];
            let [sh, el, wr, ha] = Segment::arm(side);
            let s = side.sign();
            let shoulder = Self::shoulder(&f, &l, side);
            let upper = f.trunk * arm.upper;
            let elbow = shoulder + upper * Vector3::new(0.0, 0.0, -l.upper_arm);
            let fore = upper * rot_y(-arm.elbow) * rot_z(s * arm.pronation);
            let wrist = elbow + fore * Vector3::new(0.0, 0.0, -l.forearm);
            let hand = fore * rot_y(-arm.wrist_flex) * rot_x(-s * arm.wrist_dev);
            let hand_pt = wrist + hand * Vector3::new(0.0, 0.0, -0.5 * l.hand);
            set(sh, shoulder, upper);
            set(el, elbow, fore);
            set(wr, wrist, hand);
            set(ha, hand_pt, hand);
        }
        out
    }

    /// A full pose (velocities zero).
    pub fn pose(&self, body: &BodySize, floor_z: f64, time: f64) -> SkeletonPose {
        SkeletonPose { time, body: *body, floor_z, segments: self.forward_kinematics(body, floor_z), feet: self.feet }
    }
}

/// Arm configuration whose wrist is at `wrist_target` (base frame), or as close as the arm
/// reaches, with the given pronation and wrist angles. The elbow lies in the plane through the
/// shoulder, the wrist target and a hint direction that points backwards, outwards and down, as
/// people hold their elbows; the elbow is never fully straight (≥ ~20°), so the solution is
/// smooth in the target.
pub(crate) fn arm_ik(
    config: &BodyConfig,
    body: &BodySize,
    floor_z: f64,
    side: Side,
    wrist_target: &Point3<f64>,
    pronation: f64,
    wrist_flex: f64,
) -> ArmConfig {
    let l = body.lengths();
    let f = config.trunk_frames(&l, floor_z);
    let shoulder = BodyConfig::shoulder(&f, &l, side);
    // Work in the trunk frame.
    let inv = f.trunk.inverse();
    let mut d = inv * (wrist_target - shoulder);
    let (lu, lf) = (l.upper_arm, l.forearm);
    let max = 0.985 * (lu + lf);
    let min = 0.35 * (lu + lf);
    let n = d.norm();
    if n < 1e-9 {
        d = Vector3::new(0.0, 0.0, -min);
    } else if n > max {
        d *= max / n;
    } else if n < min {
        d *= min / n;
    }
    let dist = d.norm();
    let dh = d / dist;
    let cos_e = ((dist * dist - lu * lu - lf * lf) / (2.0 * lu * lf)).clamp(-1.0, 1.0);
    let elbow = cos_e.acos();
    // Elbow centre on the circle around d.
    let a = (lu * lu - lf * lf + dist * dist) / (2.0 * dist);
    let r = (lu * lu - a * a).max(0.0).sqrt();
    let hint = Vector3::new(-1.0, -side.sign() * 0.35, -0.35);
    let mut perp = hint - hint.dot(&dh) * dh;
    if perp.norm() < 1e-9 {
        // Target straight along the hint (backwards and down): any perpendicular will do.
        perp = dh.cross(&Vector3::z());
    }
    let perp = perp.normalize();
    let e = a * dh + r * perp;
    let u = e / lu;
    let fo = (d - e) / lf;
    let z = -u;
    let y = fo.cross(&u);
    let y = if y.norm() > 1e-9 { y.normalize() } else { perp.cross(&z).normalize() };
    let x = y.cross(&z);
    let m = Matrix3::from_columns(&[x, y, z]);
    let upper = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m));
    ArmConfig { upper: canonical(upper), elbow, pronation, wrist_flex, wrist_dev: 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dist(p: &SkeletonPose, a: Segment, b: Segment) -> f64 {
        (p.position(a) - p.position(b)).norm()
    }

    #[test]
    fn rest_pose_is_plausible() {
        let body = BodySize::MEDIUM;
        let c = BodyConfig::standing(&body, -0.75, Vector2::new(1.0, -1.0), 0.3);
        let p = c.pose(&body, -0.75, 0.0);
        let l = body.lengths();
        assert!((dist(&p, Segment::RightShoulder, Segment::RightElbow) - l.upper_arm).abs() < 1e-12);
        assert!((dist(&p, Segment::RightElbow, Segment::RightWrist) - l.forearm).abs() < 1e-12);
        // Hands hang beside the hips, head on top.
        let hand = p.position(Segment::RightHand);
        let pelvis = p.position(Segment::Pelvis);
        assert!(hand.z < pelvis.z + 0.05 && hand.z > pelvis.z - 0.25, "hand {hand} pelvis {pelvis}");
        let head = p.position(Segment::Head);
        assert!((head.z - (-0.75 + 0.935 * body.height)).abs() < 0.02);
        // Right is at −y of a body facing yaw 0.3: right shoulder to the right of the left one.
        let fwd = Vector3::new(0.3f64.cos(), 0.3f64.sin(), 0.0);
        let rl = p.position(Segment::RightShoulder) - p.position(Segment::LeftShoulder);
        assert!(fwd.cross(&rl).z < 0.0);
    }

    #[test]
    fn ik_reaches_reachable_targets() {
        let body = BodySize::TALL;
        let c = BodyConfig::standing(&body, -0.75, Vector2::new(0.0, 0.0), 1.0);
        let l = body.lengths();
        let f = c.trunk_frames(&l, -0.75);
        let sh = BodyConfig::shoulder(&f, &l, Side::Right);
        for t in [Vector3::new(0.3, -0.2, -0.1), Vector3::new(0.1, 0.3, 0.3), Vector3::new(0.4, 0.0, 0.1), Vector3::new(0.0, -0.1, -0.45)] {
            let target = sh + t;
            let mut c2 = c;
            c2.arms[0] = arm_ik(&c, &body, -0.75, Side::Right, &target, 0.5, 0.0);
            let p = c2.pose(&body, -0.75, 0.0);
            assert!((p.position(Segment::RightWrist) - target).norm() < 1e-9, "target {t}");
        }
    }
}
