//! The objects the robot is manipulating are not obstacles: their pixels are removed from the
//! depth frame before fDED, as fDED removes the robot itself (thesis Sec. 5.1.2: the robot's
//! own body never repels it; a bottle in the hand, or the bottle the hand is closing on, is
//! part of the task, not of the environment).
//!
//! `robot_manager` says which objects those are on `/manipulated_objects`
//! (cowork_msgs/ObjectStream, scene names, poses in the base frame, stamped with the time of
//! the `/lwr/world` report they come from): the object in the gripper and the object the running
//! action (NOA, or FOA towards an object) goes to. The shapes come from the scene file
//! (`manipulated.scene`); a pixel is removed when its 3-D point lies inside the object's
//! shape grown by `manipulated.margin_m`.
//!
//! Fail closed: the list used for a frame is the one whose stamp is closest to the frame's;
//! when none is within `manipulated.max_age_s` (robot_manager dead, late or never started), an
//! object whose name has no shape, or a list with a non-finite pose (which also clears what
//! was known), nothing is removed — every object stays an obstacle. Everything else (the
//! table, the other objects, people) is untouched.

use std::collections::{HashMap, VecDeque};

use cowork_depth::{DepthImage, Intrinsics};
use cowork_msgs::msg::ObjectStream;
use cowork_sim::Shape;
use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion};

/// Lists remembered for matching frames by stamp (1 s of robot_manager's 100 Hz reports).
pub const MANIPULATED_HISTORY: usize = 128;
/// Objects in one list at most (a peer cannot make a frame cost more than this many boxes).
pub const MAX_MANIPULATED: usize = 8;

/// Why a manipulated-objects list or an object in it was not used (the warning text).
#[derive(Debug, Clone, PartialEq)]
pub enum Refusal {
    /// The message was refused as a whole (what was known is cleared).
    Message(String),
    /// Nothing is removed from this frame (no list close enough in time).
    Stale(String),
    /// One object stays an obstacle (no shape known).
    Object(String),
}

/// What [`ManipulatedObjects::remove`] did to one frame.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Removal {
    /// Objects whose pixels were removed (scene names).
    pub objects: Vec<String>,
    /// Pixels set to no return.
    pub pixels: usize,
}

/// One list: (scene name, pose in the base frame) of each object.
type List = Vec<(String, Isometry3<f64>)>;

/// The shapes of the scene objects and the recent lists from robot_manager.
#[derive(Debug, Clone)]
pub struct ManipulatedObjects {
    shapes: HashMap<String, Shape>,
    margin_m: f64,
    max_age_s: f64,
    base_frame: String,
    /// (stamp s, [(scene name, pose base frame)]), stamps non-decreasing.
    history: VecDeque<(f64, List)>,
}

impl ManipulatedObjects {
    /// For the objects `shapes` (scene name → shape), growing each by `margin_m` (m), using a
    /// list only for frames within `max_age_s` (s) of its stamp; lists must be in `base_frame`.
    pub fn new(shapes: HashMap<String, Shape>, margin_m: f64, max_age_s: f64, base_frame: &str) -> Self {
        Self { shapes, margin_m, max_age_s, base_frame: base_frame.to_owned(), history: VecDeque::with_capacity(MANIPULATED_HISTORY) }
    }

    /// The frame the lists must be in.
    pub fn set_base_frame(&mut self, base_frame: &str) {
        base_frame.clone_into(&mut self.base_frame);
    }

    /// Scene names with a known shape.
    pub fn known(&self) -> impl Iterator<Item = &str> {
        self.shapes.keys().map(String::as_str)
    }

    /// A list from robot_manager. A list in another frame, with more than [`MAX_MANIPULATED`]
    /// objects or with a non-finite stamp or pose is refused and clears what was known, so the
    /// next frames keep every object as an obstacle until a good list arrives.
    pub fn on_list(&mut self, msg: &ObjectStream) -> Result<(), Refusal> {
        let topic = crate::TOPIC_MANIPULATED;
        let refuse = |this: &mut Self, why: String| {
            this.history.clear();
            Err(Refusal::Message(format!("{topic}: message refused: {why}; every object is an obstacle until a good one arrives")))
        };
        let frame = msg.header.frame_id.trim_start_matches('/');
        if !frame.is_empty() && frame != self.base_frame {
            let why = format!("frame {:?} is not the base frame {:?}", cowork_ros::text_prefix(frame, 80), self.base_frame);
            return refuse(self, why);
        }
        if msg.objects.len() > MAX_MANIPULATED {
            return refuse(self, format!("{} objects (at most {MAX_MANIPULATED})", msg.objects.len()));
        }
        let stamp = msg.header.stamp.to_secs_f64();
        if !stamp.is_finite() {
            return refuse(self, "header.stamp is not finite".into());
        }
        let mut list = Vec::with_capacity(msg.objects.len());
        for o in &msg.objects {
            let (p, q) = (&o.pose.position, &o.pose.orientation);
            let quat = Quaternion::new(q.w, q.x, q.y, q.z);
            if ![p.x, p.y, p.z, q.x, q.y, q.z, q.w].iter().all(|v| v.is_finite()) || quat.norm() < 1e-6 {
                return refuse(self, format!("object {:?}: pose not finite", cowork_ros::text_prefix(&o.name, 80)));
            }
            let pose = Isometry3::from_parts(Translation3::new(p.x, p.y, p.z), UnitQuaternion::from_quaternion(quat));
            list.push((o.name.clone(), pose));
        }
        // Time went back (a restarted simulator): the older lists no longer apply.
        if self.history.back().is_some_and(|(s, _)| stamp < *s) {
            self.history.clear();
        }
        if self.history.len() == MANIPULATED_HISTORY {
            self.history.pop_front();
        }
        self.history.push_back((stamp, list));
        Ok(())
    }

    /// Removes from `depth` (taken at `stamp` s by a camera at `camera` in the base frame with
    /// intrinsics `k`) the pixels of the objects of the list closest in time to `stamp`.
    /// `notices` gets why something stayed an obstacle. Cost: the pixels in each object's
    /// projected bounding box (a few thousand for a bottle 1.5 m away).
    pub fn remove(
        &self,
        stamp: f64,
        camera: &Isometry3<f64>,
        k: &Intrinsics,
        depth: &mut DepthImage,
        notices: &mut Vec<Refusal>,
    ) -> Removal {
        let mut removal = Removal::default();
        let topic = crate::TOPIC_MANIPULATED;
        // Newest first, so that of lists with the same stamp the last one received wins.
        let Some((t, list)) = self.history.iter().rev().min_by(|a, b| (a.0 - stamp).abs().total_cmp(&(b.0 - stamp).abs())) else {
            return removal;
        };
        let gap = (t - stamp).abs();
        if gap > self.max_age_s {
            notices.push(Refusal::Stale(format!(
                "{topic}: no list within {} s of the depth frame at {stamp:.3} s (closest {gap:.3} s away): every object stays an obstacle",
                self.max_age_s
            )));
            return removal;
        }
        for (name, pose) in list {
            let Some(shape) = self.shapes.get(name) else {
                notices.push(Refusal::Object(format!(
                    "{topic}: object {:?} has no known shape (known: {}): it stays an obstacle",
                    cowork_ros::text_prefix(name, 80),
                    self.known().collect::<Vec<_>>().join(", ")
                )));
                continue;
            };
            removal.pixels += remove_shape(shape, self.margin_m, &(camera.inverse() * pose), k, depth);
            removal.objects.push(name.clone());
        }
        removal
    }
}

/// Half-extents of the shape's bounding box in its own frame, m.
fn half_extents(shape: &Shape) -> [f64; 3] {
    match *shape {
        Shape::Box { size } => [size[0] / 2.0, size[1] / 2.0, size[2] / 2.0],
        Shape::Cylinder { radius, height } => [radius, radius, height / 2.0],
        Shape::Sphere { radius } => [radius; 3],
    }
}

/// Whether `p` (object frame, m) lies inside `shape` grown by `margin` (m).
fn inside(shape: &Shape, margin: f64, p: &Point3<f64>) -> bool {
    shape.contains_grown(p, margin)
}

/// Sets to no return the pixels of `depth` whose point lies inside `shape` (grown by
/// `margin`) at `in_camera` (object pose in the camera optical frame); returns their count.
fn remove_shape(shape: &Shape, margin: f64, in_camera: &Isometry3<f64>, k: &Intrinsics, depth: &mut DepthImage) -> usize {
    let h = half_extents(shape);
    let r = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt() + margin;
    let c = in_camera.translation.vector;
    let (w, hgt) = (k.width as usize, k.height as usize);
    if w == 0 || hgt == 0 || depth.data.len() != w * hgt {
        return 0;
    }
    // Pixel box of the bounding sphere: conservative (both the near and the far depth of the
    // sphere divide each side); the whole image when the camera is within the sphere's depth.
    let (u0, u1, v0, v1) = if c.z - r > 1e-3 {
        let (near, far) = (c.z - r, c.z + r);
        let lo = |a: f64| (a / near).min(a / far);
        let hi = |a: f64| (a / near).max(a / far);
        (
            k.cx + k.fx * lo(c.x - r),
            k.cx + k.fx * hi(c.x + r),
            k.cy + k.fy * lo(c.y - r),
            k.cy + k.fy * hi(c.y + r),
        )
    } else if c.z + r <= 0.0 {
        return 0;
    } else {
        (0.0, w as f64, 0.0, hgt as f64)
    };
    let clamp = |x: f64, n: usize| x.floor().clamp(0.0, n as f64) as usize;
    let (u0, u1, v0, v1) = (clamp(u0, w), clamp(u1 + 1.0, w), clamp(v0, hgt), clamp(v1 + 1.0, hgt));
    let to_object = in_camera.inverse();
    let mut n = 0;
    for v in v0..v1 {
        let row = &mut depth.data[v * w..(v + 1) * w];
        let y = (v as f64 - k.cy) / k.fy;
        for (u, d) in row.iter_mut().enumerate().take(u1).skip(u0) {
            if *d <= 0.0 {
                continue;
            }
            let z = f64::from(*d);
            let p = Point3::new((u as f64 - k.cx) / k.fx * z, y * z, z);
            if inside(shape, margin, &(to_object * p)) {
                *d = 0.0;
                n += 1;
            }
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_box_seen_straight_on_is_removed_and_nothing_else() {
        let k = Intrinsics { width: 64, height: 48, fx: 50.0, fy: 50.0, cx: 31.5, cy: 23.5 };
        // A wall at 2 m, a 0.2 m cube 1 m in front of the camera.
        let mut img = DepthImage { width: 64, height: 48, data: vec![2.0; 64 * 48] };
        let cube = Shape::Box { size: [0.2, 0.2, 0.2] };
        let at = Isometry3::translation(0.0, 0.0, 1.0);
        let mut seen = 0;
        for v in 0..48 {
            for u in 0..64 {
                let (x, y) = ((u as f64 - k.cx) / k.fx * 0.9, (v as f64 - k.cy) / k.fy * 0.9);
                if x.abs() <= 0.1 && y.abs() <= 0.1 {
                    img.data[v * 64 + u] = 0.9;
                    seen += 1;
                }
            }
        }
        assert!(seen > 50);
        let n = remove_shape(&cube, 0.01, &at, &k, &mut img);
        assert_eq!(n, seen);
        assert!(img.data.iter().all(|d| *d == 0.0 || *d == 2.0), "the wall stays");
        assert_eq!(img.data.iter().filter(|d| **d == 2.0).count(), 64 * 48 - seen);
        // Behind the camera: nothing.
        assert_eq!(remove_shape(&cube, 0.01, &Isometry3::translation(0.0, 0.0, -1.0), &k, &mut img), 0);
    }

    #[test]
    fn inside_each_shape() {
        let m = 0.01;
        let cyl = Shape::Cylinder { radius: 0.035, height: 0.22 };
        assert!(inside(&cyl, m, &Point3::new(0.04, 0.0, 0.115)));
        assert!(!inside(&cyl, m, &Point3::new(0.05, 0.0, 0.0)));
        assert!(!inside(&cyl, m, &Point3::new(0.0, 0.0, 0.13)));
        let s = Shape::Sphere { radius: 0.1 };
        assert!(inside(&s, m, &Point3::new(0.0, 0.105, 0.0)) && !inside(&s, m, &Point3::new(0.0, 0.12, 0.0)));
    }
}
