//! Demonstrations played into a running graph on the simulated clock: kinesthetic (the
//! teacher's wrenches on the arm) or by imitation (an Xsens demonstrator's skeletons, which
//! `human_observer` retargets onto the arms and `lwr_sim` follows).

use std::collections::VecDeque;
use std::path::Path;
use std::time::{Duration, Instant};

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::WrenchStamped;
use cowork_msgs::msg::Skeleton;
use cowork_msgs::std_msgs::String as RosString;
use cowork_ros::{Publisher, RosNode};

use crate::{Error, Result};

/// How far past a word's due time the clock may run before the word is said, s.
const WORD_HOLD_S: f64 = 0.2;

/// Gap of simulated time between two bags of one feed, s: the arm rests under a zero wrench.
pub const BAG_GAP_S: f64 = 1.0;

#[derive(Debug)]
enum Item {
    Wrench(WrenchStamped),
    /// An Xsens demonstrator's frame (imitation teaching).
    Skeleton(Box<Skeleton>),
    Speech(RosString),
}

/// A teacher's word without the arm it is addressed to (`left: teach` → (`left`, `teach`)),
/// lower case.
fn word(s: &RosString) -> (String, String) {
    let text = s.data.trim().to_ascii_lowercase();
    match text.split_once(':') {
        Some((arm, w)) if !arm.trim().is_empty() && !arm.contains(char::is_whitespace) => (arm.trim().to_owned(), w.trim().to_owned()),
        _ => (String::new(), text),
    }
}

/// One or more teaching bags' `/external_wrench` (kinesthetic) or `/human/skeleton` (imitation)
/// and `/speech_command`, published into the graph on the simulated clock
/// ([`TeachingFeed::play`]). Bags play one after the other, [`BAG_GAP_S`] apart, with a zero
/// wrench at the end of each (the teacher lets go).
#[derive(Debug)]
pub struct TeachingFeed {
    /// (feed time s, item), sorted by time.
    items: Vec<(f64, Item)>,
    /// Feed time at which each bag starts, and its length, s.
    bags: Vec<(f64, f64)>,
    wrench: Publisher<WrenchStamped>,
    skeleton: Publisher<Skeleton>,
    speech: Publisher<RosString>,
    /// Whether any bag is an imitation (skeletons).
    imitation: bool,
}

fn read(bag: &Path, offset_s: f64, items: &mut Vec<(f64, Item)>) -> Result<f64> {
    let bad = |message: String| Error::Bag { path: bag.to_owned(), message };
    let reader = cowork_bag::BagReader::open(bag).map_err(|e| bad(e.to_string()))?;
    let (mut last, mut wrenches, mut skeletons) = (0.0f64, 0usize, 0usize);
    for m in reader.messages() {
        let m = m.map_err(|e| bad(e.to_string()))?;
        let t = m.log_time_ns as f64 * 1e-9;
        let item = match &*m.topic {
            "/external_wrench" => {
                wrenches += 1;
                Item::Wrench(m.decode().map_err(|e| bad(format!("/external_wrench at {t:.3} s: {e}")))?)
            }
            "/human/skeleton" => {
                let k: Skeleton = m.decode().map_err(|e| bad(format!("/human/skeleton at {t:.3} s: {e}")))?;
                if k.source != Skeleton::SOURCE_XSENS {
                    continue;
                }
                skeletons += 1;
                Item::Skeleton(Box::new(k))
            }
            "/speech_command" => Item::Speech(m.decode().map_err(|e| bad(format!("/speech_command at {t:.3} s: {e}")))?),
            _ => continue,
        };
        last = last.max(t);
        items.push((offset_s + t, item));
    }
    match (wrenches, skeletons) {
        (0, 0) => {
            return Err(bad(
                "no /external_wrench and no Xsens /human/skeleton message: not a demonstration (kinesthetic or by imitation)".into(),
            ));
        }
        (w, k) if w > 0 && k > 0 => {
            return Err(bad(format!("{w} wrenches and {k} Xsens skeletons: a demonstration is kinesthetic or by imitation, not both")));
        }
        _ => {}
    }
    Ok(last)
}

/// Per addressee (an arm, or everyone), keeps the first bag's `teach` and the last bag's
/// `done` that say it to them and drops the others.
fn one_session_per_arm(per_bag: &mut [Vec<(f64, Item)>]) {
    let says = |b: &Vec<(f64, Item)>, arm: &str, w: &str| b.iter().any(|(_, i)| matches!(i, Item::Speech(s) if word(s) == (arm.to_owned(), w.to_owned())));
    for k in 0..per_bag.len() {
        let mut own = std::mem::take(&mut per_bag[k]);
        own.retain(|(_, i)| match i {
            Item::Speech(s) => {
                let (arm, w) = word(s);
                match w.as_str() {
                    "teach" => !per_bag[..k].iter().any(|b| says(b, &arm, "teach")),
                    "done" => !per_bag[k + 1..].iter().any(|b| says(b, &arm, "done")),
                    _ => true,
                }
            }
            Item::Wrench(_) | Item::Skeleton(_) => true,
        });
        per_bag[k] = own;
    }
}

impl TeachingFeed {
    /// Reads the two topics of `bag` (bag time, s) and creates their publishers on `node`.
    pub fn new(node: &mut RosNode, bag: &Path) -> Result<Self> {
        Self::from_bags(node, &[bag])
    }

    /// The bags one after the other as one teaching session (Sec. 4.3.3: the teacher shows the
    /// subtasks in a row and says `done` once): bag k + 1 starts [`BAG_GAP_S`] after the last
    /// message of bag k, the teacher's hands off in between (zero wrenches at 100 Hz); every
    /// `done` but the last and every `teach` but the first are left out — per arm for words
    /// addressed to one (`left: teach`), so a session per arm stays one.
    pub fn from_bags<P: AsRef<Path>>(node: &mut RosNode, bags: &[P]) -> Result<Self> {
        Self::from_bags_in(node, bags, "/")
    }

    /// As [`from_bags`](Self::from_bags), the wrenches (kinesthetic: the teacher's; by
    /// imitation: the zero wrenches that carry the clock between and after the skeletons) on
    /// `/external_wrench` in `namespace` (`/left` for a graph with named arms, where the
    /// simulator reads each arm's).
    pub fn from_bags_in<P: AsRef<Path>>(node: &mut RosNode, bags: &[P], namespace: &str) -> Result<Self> {
        let mut items = Vec::new();
        let mut spans = Vec::new();
        let mut offset = 0.0;
        let mut per_bag = Vec::new();
        for bag in bags {
            let mut own = Vec::new();
            let len = read(bag.as_ref(), offset, &mut own)?;
            per_bag.push(own);
            offset += len + BAG_GAP_S;
            spans.push((offset - len - BAG_GAP_S, len));
        }
        let imitation = per_bag.iter().flatten().any(|(_, i)| matches!(i, Item::Skeleton(_)));
        one_session_per_arm(&mut per_bag);
        let n = per_bag.len();
        for (k, own) in per_bag.iter_mut().enumerate() {
            items.append(own);
            let (start, len) = spans[k];
            if k + 1 < n {
                let offset = start;
                let mut t = offset + len + 1e-3;
                while t < offset + len + BAG_GAP_S - 1e-3 {
                    items.push((t, Item::Wrench(WrenchStamped::default())));
                    t += 0.01;
                }
            }
        }
        // Stable: a bag's own order is kept for equal stamps.
        items.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Deep enough that a write never meets a full queue (the teacher's forces are never
        // dropped), and a replay's write waits rather than drops.
        let q = cowork_ros::qos::replay(4096);
        let dds = |topic: &'static str| move |e: anyhow::Error| Error::Dds { topic, message: format!("{e:#}") };
        Ok(Self {
            items,
            bags: spans,
            wrench: node.publisher(&cowork_msgs::topics::EXTERNAL_WRENCH.name_in(namespace), &q).map_err(dds("/external_wrench"))?,
            skeleton: node.publisher("/human/skeleton", &q).map_err(dds("/human/skeleton"))?,
            speech: node.publisher("/speech_command", &q).map_err(dds("/speech_command"))?,
            imitation,
        })
    }

    /// Feed time of the last message, s.
    pub fn duration_s(&self) -> f64 {
        self.items.last().map_or(0.0, |(t, _)| *t)
    }

    /// Start (feed time) and length of each bag, s.
    pub fn bags(&self) -> &[(f64, f64)] {
        &self.bags
    }

    /// Leaves out every `word` the teacher says (case-insensitive), e.g. `teach` when it has
    /// been said already and the arm let go before the demonstration was made.
    pub fn without_word(mut self, word: &str) -> Self {
        self.items.retain(|(_, i)| !matches!(i, Item::Speech(s) if s.data.trim().eq_ignore_ascii_case(word)));
        self
    }

    /// Speech words with their feed times, s.
    pub fn words(&self) -> Vec<(f64, String)> {
        self.items
            .iter()
            .filter_map(|(t, i)| match i {
                Item::Speech(s) => Some((*t, s.data.clone())),
                Item::Wrench(_) | Item::Skeleton(_) => None,
            })
            .collect()
    }

    /// Whether at least `wrench` readers of `/external_wrench` and `speech` of
    /// `/speech_command` are matched (and, for an imitation, two of `/human/skeleton`: the
    /// human observer that retargets it and the simulator).
    pub fn matched(&self, node: &RosNode, wrench: usize, speech: usize) -> bool {
        self.wrench.subscription_count(node) >= wrench
            && self.speech.subscription_count(node) >= speech
            && (!self.imitation || self.skeleton.subscription_count(node) >= 2)
    }

    /// Whether the demonstrations are by imitation (Xsens skeletons) rather than kinesthetic.
    pub fn is_imitation(&self) -> bool {
        self.imitation
    }

    /// Plays the teacher into an `lwr_sim` that follows wrench stamps
    /// (`--follow-wrench-stamps`): every wrench is stamped with its due simulated time `t0` +
    /// feed time and published up to `lead_s` ahead of `/clock` (of `node`, which must use sim
    /// time), so the simulator applies it exactly then and waits whenever this feed falls
    /// behind; each speech word is published when `/clock` reaches its due time (the manager
    /// relays `gripper close|open` to the simulator; the demonstration holds still around them).
    /// A last zero wrench at `settle_s` after the feed lets the simulator run on that long.
    /// `alive` is polled while waiting (its error ends the feed); `limit` bounds the wall time.
    pub fn play(
        self,
        node: &RosNode,
        t0: f64,
        lead_s: f64,
        settle_s: f64,
        limit: Duration,
        alive: &mut dyn FnMut() -> std::result::Result<(), String>,
    ) -> Result<FeedSummary> {
        let mut polls = 0u32;
        let mut poll = || {
            polls += 1;
            if polls.is_multiple_of(500) {
                alive()?;
            }
            Ok(None)
        };
        self.play_paced(node, t0, lead_s, settle_s, limit, f64::INFINITY, &mut poll)
    }

    /// As [`TeachingFeed::play`], and in lockstep with a follower that reports how far (in
    /// simulated time, s) it has processed the world — the robot manager's `/robot_stream`
    /// stamp: `poll` is called on every turn and returns that time (`None`: nothing new; an
    /// error ends the feed). No wrench is published more than `follower_lead_s` ahead of it, so
    /// the simulator's clock waits for a follower that stalls (a slow disk under its database
    /// save, a loaded machine) instead of running on while its inputs queue up and overflow;
    /// and a word is published only once the follower has reached its due time, so the
    /// follower sees the words and the motion in the order the teacher made them.
    #[allow(clippy::too_many_arguments)]
    pub fn play_paced(
        self,
        node: &RosNode,
        t0: f64,
        lead_s: f64,
        settle_s: f64,
        limit: Duration,
        follower_lead_s: f64,
        poll: &mut dyn FnMut() -> std::result::Result<Option<f64>, String>,
    ) -> Result<FeedSummary> {
        let dds = |topic: &'static str| move |e: anyhow::Error| Error::Dds { topic, message: format!("{e:#}") };
        let start = Instant::now();
        let paced = follower_lead_s.is_finite();
        let mut follower = f64::NEG_INFINITY;
        let mut summary = FeedSummary { last_s: t0, ..FeedSummary::default() };
        let end = t0 + self.duration_s() + settle_s;
        let (mut wrenches, mut words) = (VecDeque::new(), VecDeque::new());
        for (t, item) in self.items {
            match item {
                Item::Speech(s) => words.push_back((t0 + t, s)),
                timed => wrenches.push_back((t0 + t, timed)),
            }
        }
        let mut last_zero = f64::NEG_INFINITY;
        loop {
            if let Some(f) = poll().map_err(Error::Aborted)? {
                follower = follower.max(f);
            }
            let now = node.now().to_secs_f64();
            let mut progressed = false;
            // While a word is due, the clock goes no further than just past it (the teacher
            // holds still there, at least 0.5 s either side) until it is said. Far enough past
            // it that the follower's next report is stamped after it: the manager streams every
            // other 50 Hz tick (0.04 s) and the clock stops at the last wrench (0.01 s apart); at
            // 0.05 s a clock stopped at due + 0.04 waited for a report due at due + 0.04 + ε, and
            // the teaching hung (tea-reuse seed 1, 2026-12-03).
            let word_due = words.front().map_or(f64::INFINITY, |(d, _)| *d + WORD_HOLD_S);
            let cap = if paced { follower + follower_lead_s } else { f64::INFINITY };
            let horizon = (now + lead_s).min(cap).min(word_due);
            while let Some((due, _)) = wrenches.front()
                && *due <= horizon
            {
                match wrenches.pop_front() {
                    Some((due, Item::Wrench(mut w))) => {
                        w.header.stamp = Time::from_secs_f64(due);
                        self.wrench.publish(w).map_err(dds("/external_wrench"))?;
                    }
                    Some((due, Item::Skeleton(mut k))) => {
                        k.header.stamp = Time::from_secs_f64(due);
                        self.skeleton.publish(*k).map_err(dds("/human/skeleton"))?;
                    }
                    _ => break,
                }
                summary.published += 1;
                progressed = true;
            }
            while let Some((due, _)) = words.front()
                && *due <= now
                && (!paced || follower >= *due)
            {
                let Some((due, s)) = words.pop_front() else { break };
                summary.max_late_s = summary.max_late_s.max(now - due);
                if now - due > 0.05 {
                    summary.late_50ms += 1;
                }
                self.speech.publish(s).map_err(dds("/speech_command"))?;
                summary.last_s = due;
                summary.published += 1;
                progressed = true;
            }
            // The teacher has let go: zero wrenches carry the clock on (to the words still due
            // and to the end), paced like the others.
            if wrenches.is_empty() && last_zero < end {
                let to = (now + lead_s).min(cap).min(end);
                if to >= last_zero + 0.01 || (to >= end && last_zero < end) {
                    let mut w = WrenchStamped::default();
                    w.header.stamp = Time::from_secs_f64(to);
                    self.wrench.publish(w).map_err(dds("/external_wrench"))?;
                    last_zero = to;
                    progressed = true;
                }
            }
            if words.is_empty() && last_zero >= end && now >= end - 1e-6 {
                break;
            }
            if start.elapsed() > limit {
                return Err(Error::FeedTimeout {
                    limit_s: limit.as_secs_f64(),
                    sim_s: now,
                    left: wrenches.len() + words.len(),
                });
            }
            if !progressed {
                std::thread::sleep(Duration::from_micros(500));
            }
        }
        summary.dropped = self.wrench.dropped() + self.skeleton.dropped() + self.speech.dropped();
        Ok(summary)
    }
}

/// What [`TeachingFeed::play`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FeedSummary {
    /// Simulated time of the last message, s.
    pub last_s: f64,
    /// Messages published.
    pub published: u64,
    /// Messages a full reliable queue dropped (must be 0).
    pub dropped: u64,
    /// Largest lateness of a speech word behind its due simulated time, s.
    pub max_late_s: f64,
    /// Speech words more than 50 ms of simulated time late.
    pub late_50ms: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bag(name: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../bags").join(name)
    }

    #[test]
    fn the_bundled_pour_is_read_with_its_words_in_order() {
        let mut items = Vec::new();
        let len = read(&bag("kinesthetic-pour.mcap"), 10.0, &mut items).unwrap();
        assert!((25.0..35.0).contains(&len), "{len}");
        let words: Vec<&str> = items
            .iter()
            .filter_map(|(_, i)| match i {
                Item::Speech(s) => Some(s.data.as_str()),
                Item::Wrench(_) | Item::Skeleton(_) => None,
            })
            .collect();
        assert_eq!(words, ["teach", "gripper close", "gripper open", "done"]);
        assert!(items.iter().all(|(t, _)| *t >= 10.0 && *t <= 10.0 + len));
        let wrenches = items.iter().filter(|(_, i)| matches!(i, Item::Wrench(_))).count();
        assert!(wrenches as f64 > 90.0 * len, "100 Hz of wrenches: {wrenches}");
    }

    #[test]
    fn a_bag_without_wrenches_or_no_bag_is_refused_by_name() {
        let mut items = Vec::new();
        let e = read(&bag("static-scene.mcap"), 0.0, &mut items).unwrap_err().to_string();
        assert!(e.contains("static-scene.mcap") && e.contains("not a demonstration"), "{e}");
        let e = read(&bag("no-such.mcap"), 0.0, &mut items).unwrap_err().to_string();
        assert!(e.contains("no-such.mcap"), "{e}");
    }

    #[test]
    fn each_arm_keeps_its_own_teaching_session_across_bags() {
        let say = |t: f64, w: &str| (t, Item::Speech(RosString::new(w)));
        let mut bags = vec![
            vec![say(0.0, "teach"), say(1.0, "gripper close"), say(2.0, "done")],
            vec![say(0.0, "teach"), say(2.0, "done")],
            vec![say(0.0, "left: teach"), say(1.0, "left: gripper close"), say(2.0, "Left: done")],
            vec![say(0.0, "right: teach"), say(2.0, "right: done")],
        ];
        one_session_per_arm(&mut bags);
        let words: Vec<Vec<&str>> = bags
            .iter()
            .map(|b| {
                b.iter()
                    .filter_map(|(_, i)| match i {
                        Item::Speech(s) => Some(s.data.as_str()),
                        _ => None,
                    })
                    .collect()
            })
            .collect();
        assert_eq!(words, [vec!["teach", "gripper close"], vec!["done"], vec!["left: teach", "left: gripper close", "Left: done"], vec![
            "right: teach",
            "right: done"
        ]]);
    }
}
