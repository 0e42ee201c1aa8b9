//! Checking a `cowork_msgs/Skeleton` before anything is computed from it.
//!
//! Both sources (Xsens suit at 120 Hz, depth-camera tracker at 30 Hz) name their joints with the
//! 11 `SEGMENT_*` names of the message; a message must carry all of them, in any order, with
//! finite positions and (near-)unit quaternions. Extra segments are ignored with a notice.

use cowork_msgs::msg::Skeleton;
use cowork_people::{SkeletonPose, Source};
use nalgebra::Quaternion;

use crate::error::{ObserverError, Result};

/// A quaternion whose norm is further than this from 1 is rejected (a tracker bug, not
/// rounding); closer ones are normalised.
pub const QUATERNION_NORM_TOLERANCE: f64 = 0.05;

/// A checked skeleton frame.
#[derive(Clone, Debug)]
pub struct BodyFrame {
    /// Tracker id.
    pub person_id: u32,
    /// `header.stamp`, s.
    pub stamp: f64,
    /// The source.
    pub source: Source,
    /// The pose (body size measured from the arms, feet on the floor).
    pub pose: SkeletonPose,
    /// Things that were accepted but are worth a warning (extra segments, unknown source).
    pub notices: Vec<String>,
}

fn bad(msg: &Skeleton, field: impl Into<String>, reason: impl Into<String>) -> ObserverError {
    ObserverError::BadSkeleton { person_id: msg.person_id, field: field.into(), reason: reason.into() }
}

/// Checks `msg` and builds its pose. `base_frame`: the frame the poses must be in (an empty
/// `header.frame_id` is taken to be it); `floor_z`: floor height in that frame (m).
pub fn check_skeleton(msg: &Skeleton, base_frame: &str, floor_z: f64) -> Result<BodyFrame> {
    let mut notices = Vec::new();
    let stamp = msg.header.stamp.to_secs_f64();
    if !stamp.is_finite() || stamp < 0.0 {
        return Err(bad(msg, "header.stamp", format!("{stamp} s is not a valid time")));
    }
    if !msg.header.frame_id.is_empty() && msg.header.frame_id.trim_start_matches('/') != base_frame {
        return Err(bad(msg, "header.frame_id", format!("{:?}: poses must be in the robot base frame {base_frame:?}", msg.header.frame_id)));
    }
    let source = match msg.source.as_str() {
        Skeleton::SOURCE_XSENS => Source::Xsens,
        Skeleton::SOURCE_DEPTH_TRACKER => Source::DepthTracker,
        other => {
            notices.push(format!("field `source`: unknown source {other:?}, treated as a depth tracker"));
            Source::DepthTracker
        }
    };
    if msg.poses.len() != msg.segment_names.len() {
        return Err(bad(msg, "poses", format!("{} poses for {} segment names", msg.poses.len(), msg.segment_names.len())));
    }
    if !msg.velocities.is_empty() && msg.velocities.len() != msg.segment_names.len() {
        return Err(bad(msg, "velocities", format!("{} velocities for {} segment names", msg.velocities.len(), msg.segment_names.len())));
    }
    let mut fixed: Option<Skeleton> = None;
    let mut extra = Vec::new();
    for (i, name) in msg.segment_names.iter().enumerate() {
        if msg.segment_names[..i].contains(name) {
            return Err(bad(msg, format!("segment_names[{i}]"), format!("segment {name:?} appears twice")));
        }
        if !Skeleton::XSENS_SEGMENTS.contains(&name.as_str()) {
            extra.push(name.as_str());
            continue;
        }
        let p = &msg.poses[i];
        if ![p.position.x, p.position.y, p.position.z].iter().all(|v| v.is_finite()) {
            return Err(bad(msg, format!("poses[{i}].position"), format!("segment {name:?}: not finite")));
        }
        let o = &p.orientation;
        let n = Quaternion::new(o.w, o.x, o.y, o.z).norm();
        if !n.is_finite() || (n - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
            return Err(bad(msg, format!("poses[{i}].orientation"), format!("segment {name:?}: quaternion norm {n:.4} is not 1")));
        }
        if let Some(t) = msg.velocities.get(i)
            && ![t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z].iter().all(|v| v.is_finite())
        {
            // Velocities are optional: drop them all rather than the frame.
            let f = fixed.get_or_insert_with(|| msg.clone());
            f.velocities.clear();
            notices.push(format!("field `velocities[{i}]`: segment {name:?} not finite; velocities ignored"));
        }
    }
    if let Some(missing) = Skeleton::XSENS_SEGMENTS.iter().find(|s| !msg.segment_names.iter().any(|n| n == *s)) {
        return Err(bad(msg, "segment_names", format!("segment {missing:?} is missing ({} given)", msg.segment_names.len())));
    }
    if !extra.is_empty() {
        notices.push(format!("field `segment_names`: extra segments ignored: {}", extra.join(", ")));
    }
    let pose = SkeletonPose::from_message_measured(fixed.as_ref().unwrap_or(msg), floor_z)
        .map_err(|e| bad(msg, "poses", e.to_string()))?;
    Ok(BodyFrame { person_id: msg.person_id, stamp, source, pose, notices })
}

#[cfg(test)]
mod tests {
    use super::*;
    use cowork_people::{BodySize, MessageMeta, Performer, Stance};
    use cowork_msgs::builtin_interfaces::Time;

    fn message() -> Skeleton {
        let p = Performer::new(3, BodySize::MEDIUM, Stance::new(0.0, -1.0, 1.5), 1).expect("performer");
        p.pose(0.5).to_message(&MessageMeta {
            stamp: Time::from_secs_f64(2.0),
            frame_id: "lwr_base_link",
            source: Skeleton::SOURCE_XSENS,
            person_id: 3,
            with_velocities: true,
        })
    }

    #[test]
    fn a_good_message_passes_and_measures_the_body() {
        let f = check_skeleton(&message(), "lwr_base_link", -0.75).expect("good");
        assert_eq!(f.person_id, 3);
        assert!((f.stamp - 2.0).abs() < 1e-9);
        assert!((f.pose.body.height - 1.72).abs() < 0.02, "{}", f.pose.body.height);
        assert!(f.notices.is_empty());
    }

    #[test]
    fn bad_messages_name_the_field() {
        let field = |m: &Skeleton| match check_skeleton(m, "lwr_base_link", -0.75) {
            Err(ObserverError::BadSkeleton { field, .. }) => field,
            other => panic!("expected a bad skeleton, got {other:?}"),
        };
        let mut m = message();
        m.segment_names.remove(4);
        m.poses.remove(4);
        m.velocities.remove(4);
        assert_eq!(field(&m), "segment_names");
        let mut m = message();
        m.poses[2].position.y = f64::NAN;
        assert_eq!(field(&m), "poses[2].position");
        let mut m = message();
        m.poses[6].orientation.w *= 3.0;
        assert_eq!(field(&m), "poses[6].orientation");
        let mut m = message();
        m.poses.pop();
        assert_eq!(field(&m), "poses");
        let mut m = message();
        m.header.frame_id = "camera".into();
        assert_eq!(field(&m), "header.frame_id");
        let mut m = message();
        m.segment_names[1] = m.segment_names[0].clone();
        assert_eq!(field(&m), "segment_names[1]");
    }

    #[test]
    fn extra_segments_and_bad_velocities_are_notices() {
        let mut m = message();
        m.segment_names.push("left_toe".into());
        m.poses.push(Default::default());
        m.velocities.push(Default::default());
        m.velocities[0].linear.x = f64::INFINITY;
        let f = check_skeleton(&m, "lwr_base_link", -0.75).expect("usable");
        assert_eq!(f.notices.len(), 2, "{:?}", f.notices);
        let mut m = message();
        m.source = "kinect2".into();
        assert_eq!(check_skeleton(&m, "lwr_base_link", -0.75).expect("usable").notices.len(), 1);
    }
}
