//! `/fded/markers`: the fDED result drawn for viewers (RViz, Foxglove).
//!
//! Per link, four markers with the link index as id, one namespace per kind: the closest robot
//! point (sphere), the closest obstacle point (sphere), the segment between them (line list)
//! and the obstacle normal at the obstacle point (arrow). A link with no obstacle in view gets
//! `DELETE` for its four ids, so its old markers vanish. The global minimum is drawn red, the
//! other links amber. Every marker has a short lifetime, so a stopped node leaves nothing
//! stale behind in the viewer.

use cowork_fded::FdedOutput;
use cowork_msgs::builtin_interfaces::Duration;
use cowork_msgs::geometry_msgs::{Point, Pose, Vector3};
use cowork_msgs::std_msgs::{ColorRGBA, Header};
use cowork_msgs::visualization_msgs::{Marker, MarkerArray};

/// Namespace of the closest robot point spheres.
pub const NS_ROBOT_POINT: &str = "fded/robot_point";
/// Namespace of the closest obstacle point spheres.
pub const NS_OBSTACLE_POINT: &str = "fded/obstacle_point";
/// Namespace of the robot–obstacle segments.
pub const NS_SEGMENT: &str = "fded/segment";
/// Namespace of the obstacle normal arrows.
pub const NS_NORMAL: &str = "fded/normal";

/// Markers per link, in this order: robot point, obstacle point, segment, normal.
pub const MARKERS_PER_LINK: usize = 4;

/// Seconds a marker stays in the viewer without a refresh (results come at the camera rate).
const LIFETIME_S: f64 = 0.5;
/// Sphere diameter, m.
const POINT_DIAMETER: f64 = 0.03;
/// Segment line width, m.
const LINE_WIDTH: f64 = 0.006;

const CLOSEST: ColorRGBA = ColorRGBA::new(0.9, 0.1, 0.1, 1.0);
const OTHER: ColorRGBA = ColorRGBA::new(1.0, 0.65, 0.0, 0.9);
const ROBOT: ColorRGBA = ColorRGBA::new(0.2, 0.4, 1.0, 1.0);
const OBSTACLE: ColorRGBA = ColorRGBA::new(0.1, 0.8, 0.2, 1.0);
const NORMAL: ColorRGBA = ColorRGBA::new(0.8, 0.2, 0.8, 1.0);

/// Rewrites `array` with the markers of `out` (points in the base frame named by `header`).
/// `arrow_length` is the drawn length of the normals, m. The array keeps its buffers between
/// frames once it has `MARKERS_PER_LINK × links` markers.
pub fn fill_markers(array: &mut MarkerArray, header: &Header, out: &FdedOutput, arrow_length: f64) {
    let n = out.links.len() * MARKERS_PER_LINK;
    array.markers.resize_with(n, Marker::default);
    let lifetime = Duration::from_secs_f64(LIFETIME_S);
    for (i, l) in out.links.iter().enumerate() {
        let id = i32::try_from(l.link).unwrap_or(i32::MAX);
        let slot = &mut array.markers[i * MARKERS_PER_LINK..(i + 1) * MARKERS_PER_LINK];
        let kinds = [
            (NS_ROBOT_POINT, Marker::SPHERE),
            (NS_OBSTACLE_POINT, Marker::SPHERE),
            (NS_SEGMENT, Marker::LINE_LIST),
            (NS_NORMAL, Marker::ARROW),
        ];
        for (m, (ns, kind)) in slot.iter_mut().zip(kinds) {
            m.header.stamp = header.stamp;
            if m.header.frame_id != header.frame_id {
                m.header.frame_id.clone_from(&header.frame_id);
            }
            if m.ns != ns {
                m.ns = ns.to_owned();
            }
            m.id = id;
            m.type_ = kind;
            m.lifetime = lifetime;
            m.pose = Pose::default();
            m.points.clear();
            m.action = if l.valid { Marker::ADD } else { Marker::DELETE };
        }
        if !l.valid {
            continue;
        }
        let line = if out.closest == Some(i) { CLOSEST } else { OTHER };
        let (r, o) = (point(&l.robot_point.coords), point(&l.obstacle_point.coords));
        let [robot, obstacle, segment, normal] = slot else { unreachable!("slot has MARKERS_PER_LINK markers") };
        robot.pose.position = r;
        robot.scale = uniform(POINT_DIAMETER);
        robot.color = ROBOT;
        obstacle.pose.position = o;
        obstacle.scale = uniform(POINT_DIAMETER);
        obstacle.color = OBSTACLE;
        segment.points.extend([r, o]);
        segment.scale = Vector3 { x: LINE_WIDTH, y: 0.0, z: 0.0 };
        segment.color = line;
        let tip = l.obstacle_point.coords + l.normal * arrow_length;
        normal.points.extend([o, point(&tip)]);
        // Arrow with two points: shaft diameter, head diameter, head length.
        normal.scale = Vector3 { x: 0.1 * arrow_length, y: 0.2 * arrow_length, z: 0.3 * arrow_length };
        normal.color = NORMAL;
    }
}

fn uniform(s: f64) -> Vector3 {
    Vector3 { x: s, y: s, z: s }
}

fn point(v: &nalgebra::Vector3<f64>) -> Point {
    Point { x: v.x, y: v.y, z: v.z }
}

#[cfg(test)]
mod tests {
    use cowork_fded::LinkDistance;
    use nalgebra::{Point3, Vector3 as V3};

    use super::*;

    fn output() -> FdedOutput {
        let mut seen = LinkDistance::none(1);
        seen.valid = true;
        seen.distance = 0.5;
        seen.robot_point = Point3::new(0.1, 0.2, 0.3);
        seen.obstacle_point = Point3::new(0.6, 0.2, 0.3);
        seen.normal = V3::new(-1.0, 0.0, 0.0);
        FdedOutput {
            stamp: 1.0,
            links: vec![LinkDistance::none(0), seen],
            closest: Some(1),
            times: Default::default(),
            counts: Default::default(),
        }
    }

    #[test]
    fn a_valid_link_gets_points_segment_and_normal_and_an_invalid_one_is_deleted() {
        let mut array = MarkerArray::default();
        let header = Header::new(cowork_msgs::builtin_interfaces::Time::from_secs_f64(1.0), "base");
        fill_markers(&mut array, &header, &output(), 0.2);
        assert_eq!(array.markers.len(), 2 * MARKERS_PER_LINK);
        for m in &array.markers[..MARKERS_PER_LINK] {
            assert_eq!((m.id, m.action), (0, Marker::DELETE));
        }
        let [robot, obstacle, segment, normal] = &array.markers[MARKERS_PER_LINK..] else { panic!("4 markers") };
        for m in [robot, obstacle, segment, normal] {
            assert_eq!((m.id, m.action, m.header.frame_id.as_str()), (1, Marker::ADD, "base"));
            assert!(m.lifetime.to_nanos() > 0);
        }
        assert_eq!((robot.ns.as_str(), robot.type_), (NS_ROBOT_POINT, Marker::SPHERE));
        assert_eq!(robot.pose.position, Point { x: 0.1, y: 0.2, z: 0.3 });
        assert_eq!(obstacle.pose.position, Point { x: 0.6, y: 0.2, z: 0.3 });
        assert_eq!(segment.type_, Marker::LINE_LIST);
        assert_eq!(segment.points, vec![robot.pose.position, obstacle.pose.position]);
        assert_eq!(segment.color, CLOSEST);
        assert_eq!(normal.type_, Marker::ARROW);
        assert_eq!(normal.points[0], obstacle.pose.position);
        assert!((normal.points[1].x - 0.4).abs() < 1e-12, "arrow tip {:?}", normal.points[1]);

        // The next frame sees nothing: the link's markers are deleted, the array reused.
        let mut none = output();
        none.links[1] = LinkDistance::none(1);
        none.closest = None;
        fill_markers(&mut array, &header, &none, 0.2);
        assert!(array.markers.iter().all(|m| m.action == Marker::DELETE && m.points.is_empty()));
    }
}
