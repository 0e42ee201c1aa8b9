//! The scripted person of `coffee-cooperative` (Fig. 5.21): takes the bottle away, says
//! `human add(water)`, pours over the cup and puts the bottle back, by `/lwr/place_object`.

use cowork_msgs::msg::{WorldObject, WorldState};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::PERSON_OBJECT;

/// The scripted person of `coffee-cooperative` (module docs): the bottle's path as keyframes
/// relative to the trigger (the robot's first action + [`BottleTaker::DELAY_S`]), linearly
/// interpolated (position; tilt about the base y axis), sent at 20 Hz of simulated time; the
/// speech once the bottle is away.
#[derive(Debug, Default)]
pub(super) struct BottleTaker {
    /// Trigger time (simulated s) and the bottle's pose then.
    start: Option<(f64, Isometry3<f64>)>,
    /// The cup's position at the trigger.
    cup: Vector3<f64>,
    said: bool,
    last_sent: f64,
    done: bool,
}

impl BottleTaker {
    /// Seconds after the robot's first action start that the person reaches for the bottle.
    const DELAY_S: f64 = 1.0;
    /// When the person says `human add(water)` (after the trigger), s.
    const SAY_AT_S: f64 = 1.7;
    /// Placement period, simulated s.
    const PERIOD_S: f64 = 0.05;

    /// Keyframes: (time after the trigger s, position relative to `home` or absolute, tilt rad).
    fn keyframes(&self, home: &Vector3<f64>) -> [(f64, Vector3<f64>, f64); 10] {
        let lift = Vector3::new(0.0, 0.0, 0.12);
        let away = Vector3::new(1.15, 0.45, 0.35);
        let over_cup = self.cup + Vector3::new(0.12, 0.0, 0.22);
        [
            (0.0, *home, 0.0),
            (0.5, home + lift, 0.0),
            (1.5, away, 0.0),
            (3.5, away, 0.0),
            (5.0, over_cup, 0.0),
            (6.0, over_cup, 1.9),
            (8.0, over_cup, 1.9),
            (9.0, over_cup, 0.0),
            (10.5, home + lift, 0.0),
            (11.0, *home, 0.0),
        ]
    }

    /// What the person does at world report `w` (simulated `now`): bottle placements and speech.
    pub(super) fn step(&mut self, w: &WorldState, robot_started: Option<f64>, now: f64) -> Vec<(Option<WorldObject>, Option<&'static str>)> {
        let mut out = Vec::new();
        if self.done {
            return out;
        }
        let Some(t0) = robot_started else { return out };
        let find = |n: &str| w.objects.iter().find(|o| o.name == n);
        if self.start.is_none() {
            if now < t0 + Self::DELAY_S {
                return out;
            }
            let (Some(b), Some(c)) = (find(PERSON_OBJECT.0), find("cup")) else { return out };
            if w.held_object == PERSON_OBJECT.0 {
                // The robot was faster: the person leaves the bottle to it.
                self.done = true;
                return out;
            }
            let (p, q) = (&b.pose.position, &b.pose.orientation);
            let rot = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z));
            self.start = Some((now, Isometry3::from_parts(Translation3::new(p.x, p.y, p.z), rot)));
            self.cup = Vector3::new(c.pose.position.x, c.pose.position.y, c.pose.position.z);
        }
        let Some((ts, home)) = self.start else { return out };
        let tau = now - ts;
        if !self.said && tau >= Self::SAY_AT_S {
            self.said = true;
            out.push((None, Some("human add(water)")));
        }
        if now - self.last_sent < Self::PERIOD_S {
            return out;
        }
        self.last_sent = now;
        let keys = self.keyframes(&home.translation.vector);
        let last = keys[keys.len() - 1];
        let (pos, tilt) = if tau >= last.0 {
            self.done = true;
            (last.1, last.2)
        } else {
            let i = keys.iter().rposition(|k| k.0 <= tau).unwrap_or(0);
            let (a, b) = (keys[i], keys[(i + 1).min(keys.len() - 1)]);
            let u = if b.0 > a.0 { ((tau - a.0) / (b.0 - a.0)).clamp(0.0, 1.0) } else { 1.0 };
            (a.1 + (b.1 - a.1) * u, a.2 + (b.2 - a.2) * u)
        };
        let rot = if tilt == 0.0 { home.rotation } else { UnitQuaternion::from_euler_angles(0.0, -tilt, 0.0) * home.rotation };
        let mut o = WorldObject { name: PERSON_OBJECT.0.into(), ..Default::default() };
        o.pose.position.x = pos.x;
        o.pose.position.y = pos.y;
        o.pose.position.z = pos.z;
        let c = rot.coords;
        o.pose.orientation.x = c.x;
        o.pose.orientation.y = c.y;
        o.pose.orientation.z = c.z;
        o.pose.orientation.w = c.w;
        out.push((Some(o), None));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cowork_msgs::builtin_interfaces::Time;

    fn world(t: f64, bottle: [f64; 3]) -> WorldState {
        let mut w = WorldState::default();
        w.header.stamp = Time::from_secs_f64(t);
        for (name, p) in [("bottle", bottle), ("cup", [0.6, 0.0, 0.05])] {
            let mut o = WorldObject { name: name.into(), ..Default::default() };
            o.pose.position.x = p[0];
            o.pose.position.y = p[1];
            o.pose.position.z = p[2];
            o.pose.orientation.w = 1.0;
            w.objects.push(o);
        }
        w
    }

    #[test]
    fn the_person_takes_the_bottle_away_pours_and_puts_it_back_where_it_was() {
        let mut person = BottleTaker::default();
        let home = [0.45, 0.25, 0.11];
        let (mut said, mut left_at, mut last) = (0, None, None);
        let mut over_cup_tilted = false;
        // Nothing before the robot starts, then the person acts from 1 s after it.
        assert!(person.step(&world(0.5, home), None, 0.5).is_empty());
        for i in 0..1300 {
            let t = 10.0 + 0.01 * f64::from(i);
            let at = last.unwrap_or(home);
            for (placed, speech) in person.step(&world(t, at), Some(10.0), t) {
                said += usize::from(speech == Some("human add(water)"));
                if let Some(o) = placed {
                    let p = [o.pose.position.x, o.pose.position.y, o.pose.position.z];
                    if left_at.is_none() && p[0] > 1.0 {
                        left_at = Some(t);
                    }
                    let q = &o.pose.orientation;
                    let tilt = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z)).angle();
                    over_cup_tilted |= tilt > 1.5 && (p[0] - 0.6).hypot(p[1]) < 0.15;
                    last = Some(p);
                }
            }
        }
        assert_eq!(said, 1);
        let left = left_at.expect("carried out of the workspace (x > 1 m)");
        assert!(left > 11.0 && left < 12.7, "{left}");
        assert!(over_cup_tilted, "poured over the cup");
        assert_eq!(last, Some(home), "put back exactly where it stood");
        assert!(person.step(&world(20.0, home), Some(10.0), 20.0).is_empty(), "done");
    }

    #[test]
    fn the_person_leaves_a_bottle_the_robot_already_holds() {
        let mut person = BottleTaker::default();
        let mut w = world(11.5, [0.45, 0.25, 0.2]);
        w.held_object = "bottle".into();
        assert!(person.step(&w, Some(10.0), 11.5).is_empty());
        assert!(person.step(&world(12.0, [0.45, 0.25, 0.11]), Some(10.0), 12.0).is_empty());
    }
}
