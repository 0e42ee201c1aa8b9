//! A person who physically guides the robot's tool (thesis Sec. 4.1.3, Fig. 4.3(b)): from the
//! first contact on, they press the tool towards where they want it — the robot's own path bent
//! smoothly so that it ends at a new goal g′ — with a force growing with the distance, at least
//! [`Guide::min_force_n`] (firmly enough to take priority over the robot's task, above the TTC's
//! f_s = 15 N) and at most [`Guide::max_force_n`].
//!
//! The robot's path is what the person watched it do: positions sampled every `sample_s` from
//! the start of the execution. Frames and units: robot base frame, m, N, s.

use nalgebra::Vector3;

/// A person who guides the robot's elbow around an obstacle the robot does not see (Sec.
/// 4.1.3, Fig. 4.5(b)): from the first contact on, they want the elbow on the path they watched
/// it take, moved by `bend_m` along `direction` (the way the elbow can move without moving the
/// tool), blended in by a smoothstep over `ramp_s`. The arm yields as an admittance (ẋ = c f,
/// eq. 4.6) in that direction only, so the person pushes along it, as hard as the wanted motion
/// along it needs (their hand moves with the elbow): f = u uᵀ (ẇ + k (w − x)) / c, w the wanted
/// elbow position, kept below `max_force_n` (under the TTC's f_s: the guidance stays in the
/// end-effector task's null space, T² = [T_ee, T_ic]). Frames and units: robot base frame, m, N,
/// s.
#[derive(Debug, Clone, PartialEq)]
pub struct ElbowGuide {
    /// The elbow's path the person watched, one position every `sample_s` from the start (m).
    pub path: Vec<Vector3<f64>>,
    /// Sample period of `path` (s).
    pub sample_s: f64,
    /// First contact, s after the start of the execution.
    pub t_contact_s: f64,
    /// Unit direction of the bend.
    pub direction: Vector3<f64>,
    /// How far the person moves the elbow off the path (m).
    pub bend_m: f64,
    /// The bend is complete this long after the contact (s).
    pub ramp_s: f64,
    /// From this time on (s from the start) the person lets the elbow back onto the watched
    /// path, over `ramp_s` (past the obstacle); `None`: the bend is held to the end.
    pub release_s: Option<f64>,
    /// Feedback of the person's hand on the elbow's distance to where they want it (1/s).
    pub feedback_per_s: f64,
    /// The arm's admittance gain c as the person feels it (m/(N·s); thesis 0.005).
    pub contact_gain: f64,
    /// Largest force (N).
    pub max_force_n: f64,
    /// Below this force the person does not push (N): lighter than the TTC's f_i.
    pub min_force_n: f64,
}

impl ElbowGuide {
    /// A person bending `path` by `bend_m` along `direction` (normalised here) from
    /// `t_contact_s` on, with the figures of the elbow-refinement experiment: a 3.5 s ramp,
    /// 5/s feedback, c = 0.005 m/(N·s), 5–14 N (between the thesis's f_i = 5 N and f_s =
    /// 15 N). `None` when the path has fewer than two samples, `sample_s` is not > 0 or the
    /// direction is zero or not finite.
    pub fn new(path: Vec<Vector3<f64>>, sample_s: f64, t_contact_s: f64, direction: Vector3<f64>, bend_m: f64) -> Option<Self> {
        let n = direction.norm();
        (path.len() >= 2 && sample_s > 0.0 && n.is_finite() && n > 1e-9).then(|| Self {
            path,
            sample_s,
            t_contact_s,
            direction: direction / n,
            bend_m,
            ramp_s: 3.5,
            release_s: None,
            feedback_per_s: 5.0,
            contact_gain: 0.005,
            max_force_n: 14.0,
            min_force_n: 5.0,
        })
    }

    /// Where the person wants the elbow at `t` (s from the start; m): the watched path, bent
    /// after the contact.
    pub fn wanted(&self, t: f64) -> Vector3<f64> {
        let smooth = |s: f64| {
            let s = s.clamp(0.0, 1.0);
            s * s * (3.0 - 2.0 * s)
        };
        let bent = smooth((t - self.t_contact_s) / self.ramp_s)
            * self.release_s.map_or(1.0, |r| 1.0 - smooth((t - r) / self.ramp_s));
        let bend = self.direction * (self.bend_m * bent);
        // `new` asks for two samples; the fields are public, so a shorter path is held, not indexed.
        if self.path.len() < 2 {
            return self.path.first().copied().unwrap_or_default() + bend;
        }
        let last = self.path.len() - 1;
        let x = (t.max(0.0) / self.sample_s).min(last as f64);
        let i = (x.floor() as usize).min(last - 1);
        let a = x - i as f64;
        self.path[i] * (1.0 - a) + self.path[i + 1] * a + bend
    }

    /// The push (N, base frame) on the elbow at `elbow` (m) at time `t`: `None` before the
    /// contact or when it would be lighter than `min_force_n`.
    pub fn push(&self, t: f64, elbow: &Vector3<f64>) -> Option<Vector3<f64>> {
        if t < self.t_contact_s {
            return None;
        }
        let h = self.sample_s;
        let w_dot = (self.wanted(t + h) - self.wanted(t)) / h;
        let u = self.direction;
        let f = u * (u.dot(&(w_dot + (self.wanted(t) - elbow) * self.feedback_per_s)) / self.contact_gain);
        let n = f.norm();
        (n >= self.min_force_n && n.is_finite()).then(|| if n > self.max_force_n { f * (self.max_force_n / n) } else { f })
    }
}

/// The guiding person (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Guide {
    /// The robot's path, one position every `sample_s` from the start of the execution (m).
    pub path: Vec<Vector3<f64>>,
    /// Sample period of `path` (s).
    pub sample_s: f64,
    /// First contact: the person starts guiding this long after the start (s).
    pub t_contact_s: f64,
    /// Where the person wants the motion to end (m).
    pub new_goal: Vector3<f64>,
    /// The person has the tool at g′ this long before the path ends (s): the bend runs from
    /// `t_contact_s` to the end minus this.
    pub settle_s: f64,
    /// Force per metre of distance to the wanted position (N/m).
    pub stiffness_n_per_m: f64,
    /// Least force of a push (N).
    pub min_force_n: f64,
    /// Largest force of a push (N).
    pub max_force_n: f64,
    /// Closer than this to the wanted position the person does not push (m).
    pub deadband_m: f64,
}

impl Guide {
    /// A person bending `path` towards `new_goal` from `t_contact_s` on, with the figures of the
    /// goal-refinement experiment: 3000 N/m, 16–40 N, settled 0.5 s before the end, 0.1 mm dead
    /// band. `None` when the path has fewer than two samples or `sample_s` is not > 0.
    pub fn new(path: Vec<Vector3<f64>>, sample_s: f64, t_contact_s: f64, new_goal: Vector3<f64>) -> Option<Self> {
        (path.len() >= 2 && sample_s > 0.0).then_some(Self {
            path,
            sample_s,
            t_contact_s,
            new_goal,
            settle_s: 0.5,
            stiffness_n_per_m: 3000.0,
            min_force_n: 16.0,
            max_force_n: 40.0,
            deadband_m: 1e-4,
        })
    }

    /// Duration of the robot's path (s).
    pub fn duration_s(&self) -> f64 {
        (self.path.len() - 1) as f64 * self.sample_s
    }

    /// Where the person wants the tool at time `t` (s from the start): the path itself before
    /// the contact, then the path plus (g′ − its end) blended in by a smoothstep.
    pub fn wanted(&self, t: f64) -> Vector3<f64> {
        let span = (self.duration_s() - self.settle_s - self.t_contact_s).max(self.sample_s);
        let s = ((t - self.t_contact_s) / span).clamp(0.0, 1.0);
        let m = s * s * (3.0 - 2.0 * s);
        let last = self.path.len() - 1;
        let i = ((t.max(0.0) / self.sample_s) as usize).min(last);
        self.path[i] + (self.new_goal - self.path[last]) * m
    }

    /// The push (N, base frame) on the tool at `tool` (m) at time `t`: `None` before the contact
    /// or within the dead band.
    pub fn push(&self, t: f64, tool: &Vector3<f64>) -> Option<Vector3<f64>> {
        let e = self.wanted(t) - tool;
        (t >= self.t_contact_s && e.norm() >= self.deadband_m)
            .then(|| e.normalize() * (self.stiffness_n_per_m * e.norm()).clamp(self.min_force_n, self.max_force_n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pushes_only_after_the_contact_towards_the_bent_path() {
        let path: Vec<_> = (0..=400).map(|k| Vector3::new(k as f64 * 0.001, 0.0, 0.0)).collect();
        let g = Guide::new(path, 0.01, 3.0, Vector3::new(0.4, 0.1, 0.0)).expect("guide");
        assert_eq!(g.push(2.9, &Vector3::new(0.29, 0.05, 0.0)), None);
        assert!((g.wanted(1.0) - Vector3::new(0.1, 0.0, 0.0)).norm() < 1e-12);
        // Fully bent 0.5 s before the end: the path's point then, moved by g′ − its end.
        assert!((g.wanted(3.5) - Vector3::new(0.35, 0.1, 0.0)).norm() < 1e-12);
        assert!((g.wanted(4.0) - Vector3::new(0.4, 0.1, 0.0)).norm() < 1e-12);
        let f = g.push(3.5, &Vector3::new(0.35, 0.0, 0.0)).expect("push");
        assert!((f - Vector3::new(0.0, 40.0, 0.0)).norm() < 1e-9, "{f:?}");
        let f = g.push(3.5, &Vector3::new(0.35, 0.0999, 0.0)).expect("push");
        assert!((f.norm() - 16.0).abs() < 1e-9, "{f:?}");
        assert_eq!(g.push(3.5, &Vector3::new(0.35, 0.1, 0.0)), None);
        assert!(Guide::new(vec![Vector3::zeros()], 0.01, 3.0, Vector3::zeros()).is_none());
    }

    #[test]
    fn the_elbow_guide_bends_the_watched_path_and_pushes_below_f_s() {
        let path: Vec<_> = (0..=1000).map(|k| Vector3::new(k as f64 * 0.0003, 0.0, 0.0)).collect();
        let g = ElbowGuide::new(path, 0.01, 3.0, Vector3::new(0.0, 0.0, 2.0), 0.09).expect("guide");
        assert_eq!(g.direction, Vector3::z());
        assert!((g.wanted(2.0) - Vector3::new(0.06, 0.0, 0.0)).norm() < 1e-12);
        assert!((g.wanted(6.5) - Vector3::new(0.195, 0.0, 0.09)).norm() < 1e-12, "{:?}", g.wanted(6.5));
        assert_eq!(g.push(2.9, &Vector3::new(0.087, 0.0, -0.1)), None, "before the contact");
        // On the wanted path once bent: it moves along x, the arm yields along z: no push.
        assert_eq!(g.push(7.0, &g.wanted(7.0)), None);
        // 2 cm under it: 5/s · 0.02 m / 0.005 = 20 N asked, 14 N given, along z.
        let f = g.push(7.0, &(g.wanted(7.0) - Vector3::z() * 0.02)).expect("push");
        assert!((f - Vector3::new(0.0, 0.0, 14.0)).norm() < 1e-9, "{f:?}");
        // Mid-bend (5.25 s, the fastest): 1.5 · 0.09 m / 3.5 s = 3.9 cm/s, 7.7 N.
        let f = g.push(4.75, &g.wanted(4.75)).expect("push");
        assert!((f.z - 7.714).abs() < 0.01 && f.x == 0.0, "{f:?}");
        // Standing still on the path's end: no push.
        assert_eq!(g.push(20.0, &g.wanted(20.0)), None);
        assert!(ElbowGuide::new(vec![Vector3::zeros(); 2], 0.01, 3.0, Vector3::zeros(), 0.09).is_none());
        // Released from 8 s: back on the path 3.5 s later.
        let g = ElbowGuide { release_s: Some(8.0), ..g };
        assert!((g.wanted(8.0) - Vector3::new(0.24, 0.0, 0.09)).norm() < 1e-12);
        assert!((g.wanted(11.5) - Vector3::new(0.3, 0.0, 0.0)).norm() < 1e-12, "{:?}", g.wanted(11.5));
    }
}
