//! The world judge of the kitchen experiments: what each used object did (held, tilted over the
//! cup, put back upright), what must not have moved, and the object the robot must never hold,
//! all from `/lwr/world`.

use std::collections::BTreeMap;

use cowork_msgs::msg::WorldState;

use super::{Kitchen, PERSON_OBJECT};

/// What the judge keeps of `/lwr/world`.
#[derive(Debug)]
pub(super) struct Judge {
    /// Used objects and the tilt over the cup each must reach while held, rad.
    used: Vec<(String, f64)>,
    /// An object the robot must never hold (the person's), and whether it did.
    never_held: Option<(String, bool)>,
    worlds: u64,
    grasped: BTreeMap<String, bool>,
    pub(super) max_tilt_over_cup: BTreeMap<String, f64>,
    last: Option<WorldState>,
    pub(super) last_t: Option<f64>,
    first: Option<WorldState>,
}

impl Judge {
    pub(super) fn new(kitchen: &Kitchen) -> Self {
        Self {
            used: kitchen.used.iter().map(|(n, d)| ((*n).to_owned(), d.to_radians())).collect(),
            never_held: kitchen.cooperative.then(|| (PERSON_OBJECT.0.to_owned(), false)),
            worlds: 0,
            grasped: BTreeMap::new(),
            max_tilt_over_cup: BTreeMap::new(),
            last: None,
            last_t: None,
            first: None,
        }
    }

    pub(super) fn on_world(&mut self, w: WorldState) {
        self.last_t = Some(w.header.stamp.to_secs_f64());
        self.worlds += 1;
        if self.first.is_none() {
            self.first = Some(w.clone());
        }
        let find = |n: &str| w.objects.iter().find(|o| o.name == n);
        if let Some((name, held)) = self.never_held.as_mut() {
            *held |= *name == w.held_object;
        }
        if let Some((name, _)) = self.used.iter().find(|(n, _)| *n == w.held_object) {
            self.grasped.insert(name.clone(), true);
            if let (Some(b), Some(c)) = (find(name), find("cup")) {
                let d = (b.pose.position.x - c.pose.position.x).hypot(b.pose.position.y - c.pose.position.y);
                if d < 0.15 {
                    let m = self.max_tilt_over_cup.entry(name.clone()).or_insert(0.0);
                    *m = m.max(b.tilt);
                }
            }
        }
        self.last = Some(w);
    }

    /// Why the trial failed, judged from the world; empty on success.
    pub(super) fn verdict(&self) -> String {
        let (Some(first), Some(last)) = (&self.first, &self.last) else { return "no /lwr/world report".into() };
        let mut why = Vec::new();
        for (name, min_tilt) in &self.used {
            if !self.grasped.get(name).copied().unwrap_or(false) {
                why.push(format!("the {name} was never held"));
            }
            let tilt = self.max_tilt_over_cup.get(name).copied().unwrap_or(0.0);
            if tilt <= *min_tilt {
                why.push(format!("the {name} was not used over the cup (max tilt {:.0}°, needs {:.0}°)", tilt.to_degrees(), min_tilt.to_degrees()));
            }
            // Put back: not held, upright, resting at the height it stood at (on the table).
            let z0 = first.objects.iter().find(|o| &o.name == name).map(|o| o.pose.position.z);
            match (last.objects.iter().find(|o| &o.name == name), z0) {
                (Some(b), Some(z0)) if last.held_object != *name && b.tilt < 10f64.to_radians() && (b.pose.position.z - z0).abs() < 0.02 => {}
                (Some(b), _) => why.push(format!(
                    "the {name} is not back upright on the table (held {:?}, tilt {:.0}°, z {:.3} m)",
                    last.held_object,
                    b.tilt.to_degrees(),
                    b.pose.position.z
                )),
                (None, _) => why.push(format!("the {name} is gone")),
            }
        }
        if !last.held_object.is_empty() {
            why.push(format!("the {} is still held", last.held_object));
        }
        if let Some((name, true)) = &self.never_held {
            why.push(format!("the robot held the {name} (the person's)"));
        }
        for o in first.objects.iter().filter(|o| !self.used.iter().any(|(n, _)| *n == o.name)) {
            let moved = last.objects.iter().find(|x| x.name == o.name).map_or(f64::INFINITY, |x| {
                let (a, b) = (&o.pose.position, &x.pose.position);
                ((a.x - b.x).powi(2) + (a.y - b.y).powi(2) + (a.z - b.z).powi(2)).sqrt()
            });
            if moved > 0.01 {
                why.push(format!("{} moved {:.3} m", o.name, moved));
            }
        }
        why.join("; ")
    }
}
