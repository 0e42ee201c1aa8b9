//! A scripted person as capsules (analytic stand-in for the skeleton the depth tracker or the
//! Xsens suit gives): torso, head, both arms, right hand. Base frame, m, s; the person faces
//! the robot (−x), so the right hand is on the +y side; the table top is z = 0.

use nalgebra::{Point3, Vector3};

use crate::obstacle::Obstacle;

/// Keyframes `(time s, value)`, eased between keys (smoothstep: zero velocity at each key, so
/// the motion and its velocity are continuous). Before the first / after the last key the
/// value is held.
#[derive(Debug, Clone, PartialEq)]
pub struct Track(pub Vec<(f64, Point3<f64>)>);

impl Track {
    /// Value at `t`.
    pub fn at(&self, t: f64) -> Point3<f64> {
        let k = &self.0;
        let Some(first) = k.first() else { return Point3::origin() };
        if t <= first.0 {
            return first.1;
        }
        for w in k.windows(2) {
            let ((t0, p0), (t1, p1)) = (w[0], w[1]);
            if t <= t1 {
                let s = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
                let e = s * s * (3.0 - 2.0 * s);
                return p0 + (p1 - p0) * e;
            }
        }
        k[k.len() - 1].1
    }

    /// Velocity at `t` (m/s), by central difference of [`Track::at`].
    pub fn velocity(&self, t: f64) -> Vector3<f64> {
        const H: f64 = 1e-4;
        (self.at(t + H) - self.at(t - H)) / (2.0 * H)
    }
}

/// A person: where the pelvis is (on the table-top frame, z ignored) and where the right hand
/// is relative to the right shoulder.
#[derive(Debug, Clone, PartialEq)]
pub struct Person {
    /// Pelvis position over time (x, y used; the pelvis is at `pelvis_z`).
    pub pelvis: Track,
    /// Right hand, absolute (base frame) over time; the arm hangs when the hand is at rest.
    pub right_hand: Track,
    /// Height of the pelvis above the table top (m).
    pub pelvis_z: f64,
}

/// Radii of the body capsules (m).
const TORSO_R: f64 = 0.15;
const HEAD_R: f64 = 0.11;
const UPPER_ARM_R: f64 = 0.05;
const FOREARM_R: f64 = 0.04;
const HAND_R: f64 = 0.05;

impl Person {
    fn joints(&self, t: f64) -> [Point3<f64>; 7] {
        let p = self.pelvis.at(t);
        let pelvis = Point3::new(p.x, p.y, self.pelvis_z);
        let neck = pelvis + Vector3::new(0.0, 0.0, 0.5);
        let head = neck + Vector3::new(0.0, 0.0, 0.17);
        let r_shoulder = neck + Vector3::new(0.0, 0.2, -0.05);
        let l_shoulder = neck + Vector3::new(0.0, -0.2, -0.05);
        let hand = self.right_hand.at(t);
        // Elbow: below the middle of shoulder and hand (a bent arm), for a capsule model.
        let elbow = nalgebra::center(&r_shoulder, &hand) + Vector3::new(0.0, 0.03, -0.08);
        let l_hand = l_shoulder + Vector3::new(0.05, -0.05, -0.55);
        [pelvis, neck, head, r_shoulder, elbow, hand, l_hand]
    }

    /// The rest position of the right hand for a pelvis at `(x, y)`: hanging by the side.
    pub fn rest_hand(x: f64, y: f64, pelvis_z: f64) -> Point3<f64> {
        Point3::new(x + 0.05, y + 0.25, pelvis_z + 0.45 - 0.55)
    }

    /// The body at `t` as capsules with their velocities (appended to `out`).
    pub fn obstacles(&self, t: f64, out: &mut Vec<Obstacle>) {
        const H: f64 = 1e-4;
        let j = self.joints(t);
        let jp = self.joints(t + H);
        let jm = self.joints(t - H);
        let v = |i: usize| (jp[i] - jm[i]) / (2.0 * H);
        let [pelvis, neck, head, r_sh, elbow, hand, l_hand] = [0, 1, 2, 3, 4, 5, 6];
        let l_sh_offset = Vector3::new(0.0, -0.2, -0.05);
        let l_sh = j[neck] + l_sh_offset;
        out.push(Obstacle::capsule("person.torso", j[pelvis], j[neck], TORSO_R, v(pelvis), v(neck)));
        let mut head_ball = Obstacle::sphere("person.head", j[head], HEAD_R, v(head));
        head_ball.human = true;
        out.push(head_ball);
        out.push(Obstacle::capsule("person.upper_arm_r", j[r_sh], j[elbow], UPPER_ARM_R, v(r_sh), v(elbow)));
        out.push(Obstacle::capsule("person.forearm_r", j[elbow], j[hand], FOREARM_R, v(elbow), v(hand)));
        let mut hand_ball = Obstacle::sphere("person.hand_r", j[hand], HAND_R, v(hand));
        hand_ball.human = true;
        out.push(hand_ball);
        out.push(Obstacle::capsule("person.arm_l", l_sh, j[l_hand], UPPER_ARM_R, v(neck), v(l_hand)));
    }

    /// Right-hand position at `t` (m).
    pub fn hand(&self, t: f64) -> Point3<f64> {
        self.right_hand.at(t)
    }

    /// Right shoulder position at `t` (m).
    pub fn right_shoulder(&self, t: f64) -> Point3<f64> {
        self.joints(t)[3]
    }

    /// Pelvis position at `t` (m).
    pub fn pelvis_at(&self, t: f64) -> Point3<f64> {
        let p = self.pelvis.at(t);
        Point3::new(p.x, p.y, self.pelvis_z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn track_eases_between_keys_and_holds_outside() {
        let t = Track(vec![(1.0, Point3::new(0.0, 0.0, 0.0)), (3.0, Point3::new(2.0, 0.0, 0.0))]);
        assert_eq!(t.at(0.0).x, 0.0);
        assert_eq!(t.at(5.0).x, 2.0);
        assert!((t.at(2.0).x - 1.0).abs() < 1e-12);
        // Smoothstep: zero speed at the keys, 1.5× the mean speed in the middle.
        assert!(t.velocity(1.0).norm() < 1e-3);
        assert!((t.velocity(2.0).x - 1.5).abs() < 1e-6);
    }

    #[test]
    fn person_is_six_human_capsules_moving_with_the_script() {
        let p = Person {
            pelvis: Track(vec![(0.0, Point3::new(2.0, 0.0, 0.0)), (2.0, Point3::new(1.0, 0.0, 0.0))]),
            right_hand: Track(vec![(0.0, Person::rest_hand(2.0, 0.0, 0.2))]),
            pelvis_z: 0.2,
        };
        let mut out = Vec::new();
        p.obstacles(1.0, &mut out);
        assert_eq!(out.len(), 6);
        assert!(out.iter().all(|o| o.human));
        // The torso walks towards the robot (−x) at 0.75 m/s in the middle of the walk.
        assert!((out[0].velocity.x + 0.75).abs() < 1e-6, "{}", out[0].velocity);
    }
}
