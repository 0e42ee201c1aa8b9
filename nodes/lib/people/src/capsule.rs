//! Capsule bodies on a skeleton for the depth renderer ([`cowork_depth::Capsule`]).

pub use cowork_depth::Capsule;
use nalgebra::{Point3, Vector3};

use crate::pose::{Foot, Segment, Side, SkeletonPose};

/// Number of capsules of a body.
pub const BODY_CAPSULE_COUNT: usize = 16;

/// Names of the capsules returned by [`body_capsules`], in order.
pub const BODY_CAPSULE_NAMES: [&str; BODY_CAPSULE_COUNT] = [
    "torso_right",
    "torso_left",
    "neck",
    "head",
    "right_upper_arm",
    "right_forearm",
    "right_hand",
    "left_upper_arm",
    "left_forearm",
    "left_hand",
    "right_thigh",
    "right_shank",
    "right_foot",
    "left_thigh",
    "left_shank",
    "left_foot",
];

/// The body of `pose` as capsules (see [`BODY_CAPSULE_NAMES`]): two torso capsules from the
/// hips (pelvis frame) to the base of the neck (sternum frame), neck, head, upper arms,
/// forearms, hands (wrist to finger tips), and legs from the hip joints through the knees
/// (bent forward, two-link inverse kinematics) to the ankles and feet on the floor. Radii scale
/// with the body height. O(1), no allocation.
pub fn body_capsules(pose: &SkeletonPose) -> [Capsule; BODY_CAPSULE_COUNT] {
    let l = pose.body.lengths();
    let r = pose.body.radii();
    let pelvis = pose.segment(Segment::Pelvis);
    let sternum = pose.segment(Segment::Sternum);
    let head = pose.segment(Segment::Head);
    let p0 = pelvis.position;
    // The trunk frame is the sternum's; the sternum point is in front of the trunk axis.
    let axis_at = |z: f64, y: f64| p0 + sternum.orientation * Vector3::new(0.0, y, z);
    let hip_at = |y: f64| p0 + pelvis.orientation * Vector3::new(0.0, y, -0.02 * pose.body.height);
    let neck_base = axis_at(l.pelvis_to_neck, 0.0);
    let top_z = l.pelvis_to_neck - 0.03 * pose.body.height;
    let mut out = [Capsule { a: p0, b: p0, radius: 0.0 }; BODY_CAPSULE_COUNT];
    out[0] = Capsule { a: hip_at(-r.torso_half_width), b: axis_at(top_z, -r.torso_half_width), radius: r.torso };
    out[1] = Capsule { a: hip_at(r.torso_half_width), b: axis_at(top_z, r.torso_half_width), radius: r.torso };
    let head_axis = head.orientation * Vector3::z();
    out[2] = Capsule { a: neck_base, b: head.position - 0.03 * pose.body.height * head_axis, radius: r.neck };
    out[3] = Capsule {
        a: head.position - 0.025 * pose.body.height * head_axis,
        b: head.position + 0.02 * pose.body.height * head_axis,
        radius: r.head,
    };
    for (k, side) in [Side::Right, Side::Left].into_iter().enumerate() {
        let [sh, el, wr, ha] = Segment::arm(side);
        let (s, e, w, h) = (pose.position(sh), pose.position(el), pose.position(wr), pose.position(ha));
        let tip = w + (h - w) * 2.0;
        let hand_dir = (tip - w).try_normalize(1e-12).unwrap_or_else(Vector3::zeros);
        out[4 + 3 * k] = Capsule { a: s, b: e, radius: r.upper_arm };
        out[5 + 3 * k] = Capsule { a: e, b: w, radius: r.forearm };
        out[6 + 3 * k] = Capsule { a: w, b: tip - r.hand * hand_dir, radius: r.hand };
        let hip = p0 + pelvis.orientation * Vector3::new(0.0, -side.sign() * l.hip_half_width, 0.0);
        let foot = &pose.feet[side.index()];
        let knee = knee(&hip, foot, l.thigh, l.shank);
        out[10 + 3 * k] = Capsule { a: hip, b: knee, radius: r.thigh };
        out[11 + 3 * k] = Capsule { a: knee, b: foot.ankle, radius: r.shank };
        let sole = Vector3::new(0.0, 0.0, r.foot - l.ankle_height);
        let heel = foot.ankle + sole - foot.heading * (0.2 * l.foot - r.foot).max(0.0);
        let toe = foot.ankle + sole + foot.heading * (0.8 * l.foot - r.foot).max(0.0);
        out[12 + 3 * k] = Capsule { a: heel, b: toe, radius: r.foot };
    }
    out
}

/// Knee joint centre: two-link inverse kinematics in the plane of the leg and the foot's
/// heading, knee in front; on the hip–ankle line (at the thigh's length) when the leg cannot
/// reach.
fn knee(hip: &Point3<f64>, foot: &Foot, thigh: f64, shank: f64) -> Point3<f64> {
    let d = foot.ankle - hip;
    let dist = d.norm();
    if dist < 1e-9 {
        return *hip;
    }
    let dh = d / dist;
    if dist >= thigh + shank {
        return hip + dh * thigh;
    }
    let a = (thigh * thigh - shank * shank + dist * dist) / (2.0 * dist);
    let h = (thigh * thigh - a * a).max(0.0).sqrt();
    let perp = foot.heading - foot.heading.dot(&dh) * dh;
    let perp = perp.try_normalize(1e-9).unwrap_or_else(|| dh.cross(&Vector3::z()).try_normalize(1e-9).unwrap_or_else(Vector3::x));
    hip + dh * a + perp * h
}
