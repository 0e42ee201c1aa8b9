//! State variables V (thesis Sec. 4.3.2): boolean literals such as `hand.free`, `water.taken`,
//! `foa8.done`, arm-qualified for dual-arm robots (`left.hand.free`, `left.tomato.taken`), plus
//! the perceived objects (distance to the end effector, visibility, workspace area).

use std::collections::{BTreeSet, HashMap};
use std::fmt;

use crate::schema::{Cond, Seg};

/// A ground condition with its literals pre-joined into state keys.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GroundCond {
    /// The condition as written (all segments constants).
    pub cond: Cond,
    /// `(negated, "a.b.c")` per literal.
    pub keys: Vec<(bool, String)>,
}

impl GroundCond {
    /// Builds the keys of a ground condition (variables, if any, are joined by name).
    pub fn new(cond: Cond) -> Self {
        let keys = cond
            .literals
            .iter()
            .map(|l| {
                let key = l
                    .path
                    .iter()
                    .map(|s| match s {
                        Seg::Atom(a) | Seg::Var(a) => a.as_str(),
                    })
                    .collect::<Vec<_>>()
                    .join(".");
                (l.negated, key)
            })
            .collect();
        Self { cond, keys }
    }

    /// True for the always-true condition.
    pub fn is_true(&self) -> bool {
        self.keys.is_empty()
    }
}

impl fmt::Display for GroundCond {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.cond)
    }
}

/// What is known about one object.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ObjectInfo {
    /// End-effector–object distance (m), single-arm or when no per-arm value is given.
    pub distance_m: Option<f64>,
    /// Per-arm end-effector–object distance (m), indexed like the arms.
    pub arm_distance_m: Vec<Option<f64>>,
    /// False when the object is not seen (taken away by a person, occluded).
    pub visible: bool,
    /// Workspace area: an arm name (reachable by that arm only) or the shared central area.
    pub area: Option<String>,
}

/// State variables and perceived objects.
#[derive(Debug, Clone)]
pub struct State {
    vars: BTreeSet<String>,
    objects: HashMap<String, ObjectInfo>,
    arms: Vec<String>,
    dual: bool,
    holding: Vec<Option<String>>,
}

impl State {
    /// Initial state: every hand free, nothing known about objects. `arms` is empty for a
    /// single-arm robot.
    pub fn new(arms: &[String]) -> Self {
        let dual = !arms.is_empty();
        let arms: Vec<String> = if dual { arms.to_vec() } else { vec![String::new()] };
        let mut s = Self { vars: BTreeSet::new(), objects: HashMap::new(), holding: vec![None; arms.len()], arms, dual };
        for a in 0..s.arms.len() {
            let k = s.key(a, "hand.free");
            s.vars.insert(k);
        }
        if dual {
            s.vars.insert("hand.free".into());
        }
        s
    }

    /// Number of arms (1 for a single-arm robot).
    pub fn n_arms(&self) -> usize {
        self.arms.len()
    }

    /// Arm names (one empty name for a single-arm robot).
    pub fn arm_names(&self) -> &[String] {
        &self.arms
    }

    /// Index of a named arm.
    pub fn arm_index(&self, name: &str) -> Option<usize> {
        self.arms.iter().position(|a| a == name)
    }

    /// True for a dual-arm robot.
    pub fn is_dual(&self) -> bool {
        self.dual
    }

    fn key(&self, arm: usize, suffix: &str) -> String {
        if self.dual { format!("{}.{suffix}", self.arms[arm]) } else { suffix.to_owned() }
    }

    /// Value of one variable (absent = false).
    pub fn get(&self, key: &str) -> bool {
        self.vars.contains(key)
    }

    /// Sets one variable.
    pub fn set(&mut self, key: &str, value: bool) {
        if value {
            if !self.vars.contains(key) {
                self.vars.insert(key.to_owned());
            }
        } else {
            self.vars.remove(key);
        }
    }

    /// Evaluates a ground condition.
    pub fn eval(&self, c: &GroundCond) -> bool {
        c.keys.iter().all(|(neg, k)| self.vars.contains(k.as_str()) != *neg)
    }

    /// The first literal of `c` on a variable the gripper events set (`hand.free`,
    /// `OBJ.taken`, arm-qualified too) that the state contradicts, as written (`tea.taken`).
    /// Teaching may assert a demonstrated subtask's post-condition, but not these: a hand
    /// that closed on nothing has not taken the tea box.
    pub fn unmet_observed(&self, c: &GroundCond) -> Option<String> {
        let observed = |k: &str| k == "hand.free" || k.ends_with(".hand.free") || k.ends_with(".taken");
        c.keys
            .iter()
            .find(|(neg, k)| observed(k) && self.vars.contains(k.as_str()) == *neg)
            .map(|(neg, k)| if *neg { format!("~{k}") } else { k.clone() })
    }

    /// Makes a condition true: positive literals set, negated ones cleared (post-conditions).
    pub fn assert_cond(&mut self, c: &GroundCond) {
        for (neg, k) in &c.keys {
            self.set(k, !neg);
        }
    }

    /// The variables that are true, sorted.
    pub fn true_vars(&self) -> impl Iterator<Item = &str> {
        self.vars.iter().map(String::as_str)
    }

    /// The gripper of `arm` closed on `object` (or on nothing).
    pub fn grasp(&mut self, arm: usize, object: Option<&str>) {
        self.release(arm);
        let free = self.key(arm, "hand.free");
        self.set(&free, false);
        if self.dual && self.holding.iter().enumerate().all(|(i, h)| i == arm || h.is_some()) {
            self.set("hand.free", false);
        }
        if let Some(o) = object {
            self.set(&format!("{o}.taken"), true);
            if self.dual {
                let k = self.key(arm, &format!("{o}.taken"));
                self.set(&k, true);
            }
            self.holding[arm] = Some(o.to_owned());
        } else {
            self.holding[arm] = Some(String::new());
        }
    }

    /// The gripper of `arm` opened.
    pub fn release(&mut self, arm: usize) {
        if let Some(o) = self.holding[arm].take()
            && !o.is_empty()
        {
            self.set(&format!("{o}.taken"), false);
            if self.dual {
                let k = self.key(arm, &format!("{o}.taken"));
                self.set(&k, false);
            }
        }
        let free = self.key(arm, "hand.free");
        self.set(&free, true);
        if self.dual {
            self.set("hand.free", true);
        }
    }

    /// Object held by `arm`, if any.
    pub fn held(&self, arm: usize) -> Option<&str> {
        self.holding.get(arm).and_then(|h| h.as_deref()).filter(|h| !h.is_empty())
    }

    /// Updates (or creates) what is known about an object.
    pub fn object_mut(&mut self, name: &str) -> &mut ObjectInfo {
        let n = self.arms.len();
        self.objects.entry(name.to_owned()).or_insert_with(|| ObjectInfo {
            visible: true,
            arm_distance_m: vec![None; n],
            ..ObjectInfo::default()
        })
    }

    /// What is known about an object.
    pub fn object(&self, name: &str) -> Option<&ObjectInfo> {
        self.objects.get(name)
    }

    /// Distance stimulus σ (m) of `object` for `arm`: the per-arm value if known, else the
    /// common one; `None` when unknown.
    pub fn distance(&self, object: &str, arm: Option<usize>) -> Option<f64> {
        let o = self.objects.get(object)?;
        arm.and_then(|a| o.arm_distance_m.get(a).copied().flatten()).or(o.distance_m)
    }

    /// Whether `arm` can work on `object`: seen (or held by that arm) and not in the area of
    /// another arm. Unknown objects are accessible.
    pub fn accessible(&self, object: &str, arm: Option<usize>) -> bool {
        let Some(o) = self.objects.get(object) else { return true };
        let held_here = arm.is_some_and(|a| self.held(a) == Some(object)) || (!self.dual && self.held(0) == Some(object));
        if !o.visible && !held_here {
            return false;
        }
        match (&o.area, arm) {
            (Some(area), Some(a)) if self.dual => match self.arm_index(area) {
                Some(owner) => owner == a,
                None => true,
            },
            _ => true,
        }
    }

    /// Area of an object, if known.
    pub fn area(&self, object: &str) -> Option<&str> {
        self.objects.get(object).and_then(|o| o.area.as_deref())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grasp_and_release_single_arm() {
        let mut s = State::new(&[]);
        assert!(s.get("hand.free"));
        s.grasp(0, Some("water"));
        assert!(!s.get("hand.free") && s.get("water.taken"));
        s.release(0);
        assert!(s.get("hand.free") && !s.get("water.taken"));
    }

    #[test]
    fn arm_qualified_dual() {
        let mut s = State::new(&["left".into(), "right".into()]);
        assert!(s.get("left.hand.free") && s.get("right.hand.free"));
        s.grasp(0, Some("tomato"));
        assert!(s.get("left.tomato.taken") && s.get("tomato.taken") && !s.get("left.hand.free"));
        assert!(s.get("right.hand.free"));
        s.object_mut("oil").area = Some("right".into());
        assert!(!s.accessible("oil", Some(0)) && s.accessible("oil", Some(1)));
    }
}
