//! The arm bases in the world frame, from `/tf_static`: each arm's object poses
//! (`/<arm>/object_stream`, in that arm's base frame) are turned into the world frame with
//! them, where [`AreaParams::classify`](crate::AreaParams::classify) decides the area.

use cowork_msgs::geometry_msgs::{Point, TransformStamped};
use cowork_msgs::tf2_msgs::TFMessage;

/// A rigid transform child → parent: `p_parent = translation + rotation · p_child` (m; unit
/// quaternion `[x, y, z, w]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Child origin in the parent frame (m).
    pub translation: [f64; 3],
    /// Child orientation in the parent frame, unit quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
}

impl Placement {
    /// From a `TransformStamped`: `None` when a value is not finite or the quaternion is (near)
    /// zero; the quaternion is normalised (tf2 accepts a slightly denormalised one too).
    pub fn from_transform(t: &TransformStamped) -> Option<Self> {
        let (v, q) = (&t.transform.translation, &t.transform.rotation);
        let translation = [v.x, v.y, v.z];
        let n = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
        if !(translation.iter().all(|c| c.is_finite()) && n.is_finite() && n > 1e-6) {
            return None;
        }
        Some(Self { translation, rotation: [q.x / n, q.y / n, q.z / n, q.w / n] })
    }

    /// `p` (child frame, m) in the parent frame. Three cross products, no allocation.
    pub fn apply(&self, p: &Point) -> [f64; 3] {
        let [x, y, z, w] = self.rotation;
        let v = [p.x, p.y, p.z];
        let cross = |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
        // v' = v + 2w (u × v) + 2 u × (u × v), u the vector part.
        let u = [x, y, z];
        let uv = cross(u, v);
        let uuv = cross(u, uv);
        let t = self.translation;
        [
            t[0] + v[0] + 2.0 * (w * uv[0] + uuv[0]),
            t[1] + v[1] + 2.0 * (w * uv[1] + uuv[1]),
            t[2] + v[2] + 2.0 * (w * uv[2] + uuv[2]),
        ]
    }
}

/// The newest `world -> <arm>/<base_link>` transform of every arm, from `/tf_static`.
#[derive(Debug, Clone, Default)]
pub struct ArmBases {
    parent: String,
    /// (child frame, placement), indexed like the arms.
    arms: Vec<(String, Option<Placement>)>,
}

impl ArmBases {
    /// Bases of the arms whose base frames are `base_frames` (`left/lwr_base_link`), under
    /// `parent` (`world`). Leading `/` of frame names are ignored, as tf2 does.
    pub fn new(parent: &str, base_frames: impl IntoIterator<Item = String>) -> Self {
        let clean = |f: &str| f.trim_start_matches('/').to_owned();
        Self { parent: clean(parent), arms: base_frames.into_iter().map(|f| (clean(&f), None)).collect() }
    }

    /// Takes the arm bases of a `/tf_static` message (other transforms, e.g. the camera, are
    /// not looked at); a base transform that is not finite is reported in `bad` (its child
    /// frame) and the one known before is kept.
    pub fn on_tf_static(&mut self, msg: &TFMessage, bad: &mut Vec<String>) {
        for t in &msg.transforms {
            let child = t.child_frame_id.trim_start_matches('/');
            let Some(slot) = self.arms.iter_mut().find(|(f, _)| f == child) else { continue };
            if t.header.frame_id.trim_start_matches('/') != self.parent {
                continue;
            }
            match Placement::from_transform(t) {
                Some(p) => slot.1 = Some(p),
                None => bad.push(slot.0.clone()),
            }
        }
    }

    /// Arm `i`'s base in the parent frame, once known.
    pub fn get(&self, i: usize) -> Option<&Placement> {
        self.arms.get(i).and_then(|(_, p)| p.as_ref())
    }

    /// Arm `i`'s base frame name.
    pub fn frame(&self, i: usize) -> &str {
        self.arms.get(i).map_or("", |(f, _)| f.as_str())
    }

    /// The parent frame (`world`).
    pub fn parent(&self) -> &str {
        &self.parent
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cowork_msgs::geometry_msgs::{Quaternion, Transform, Vector3};

    #[test]
    fn a_quarter_turn_about_x_maps_z_to_minus_y() {
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let t = TransformStamped {
            transform: Transform { translation: Vector3::new(1.0, 2.0, 3.0), rotation: Quaternion::new(s, 0.0, 0.0, s) },
            ..Default::default()
        };
        let p = Placement::from_transform(&t).expect("finite").apply(&Point::new(0.0, 0.0, 1.0));
        for (a, b) in p.iter().zip([1.0, 1.0, 3.0]) {
            assert!((a - b).abs() < 1e-12, "{p:?}");
        }
        let zero = TransformStamped { transform: Transform { rotation: Quaternion::new(0.0, 0.0, 0.0, 0.0), ..Default::default() }, ..Default::default() };
        assert!(Placement::from_transform(&zero).is_none());
    }
}
