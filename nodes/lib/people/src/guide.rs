//! A person who physically guides the robot's tool (thesis Sec. 4.1.3, Fig. 4.3(b)): from the
//! first contact on, they press the tool towards where they want it — the robot's own path bent
//! smoothly so that it ends at a new goal g′ — with a force growing with the distance, at least
//! [`Guide::min_force_n`] (firmly enough to take priority over the robot's task, above the TTC's
//! f_s = 15 N) and at most [`Guide::max_force_n`].
//!
//! The robot's path is what the person watched it do: positions sampled every `sample_s` from
//! the start of the execution. Frames and units: robot base frame, m, N, s.

use nalgebra::Vector3;

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
}
