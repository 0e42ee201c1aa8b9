//! Replay scheduling with no ROS dependency: which message goes out when, at what rate, from
//! which offset, in a loop or not, with `/clock` ticks in between.
//!
//! [`Player`] turns a [`BagReader`] and [`PlayOptions`] into a stream of [`PlayItem`]s, each with
//! the instant it is due, relative to the start of playback. The caller publishes them (the
//! `cowork bag play` command does it over DDS, one publisher thread per topic) and waits with
//! [`wait_until`], which sleeps and then spins the last [`SPIN_WINDOW`] for sub-millisecond
//! precision.

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use crate::{BagError, BagReader, Messages, RawMessage, Result};

/// Topic of the simulated clock.
pub const CLOCK_TOPIC: &str = cowork_msgs::topics::CLOCK.name;

/// The last part of a wait that [`wait_until`] spends spinning instead of sleeping: an OS sleep
/// on an idle machine overshoots by 50–100 µs. Kept short on purpose: on a loaded machine a
/// thread that has just slept is scheduled ahead of busy ones, while one that spins (or yields
/// in a loop) loses its turn to them — measured on this 2-core machine at load 6–8, waiting
/// with a 1.5 ms `yield_now` spin was 3.6–5.2 ms late at the median, with 0.1–0.5 ms of
/// `spin_loop` 0.01–0.1 ms.
pub const SPIN_WINDOW: Duration = Duration::from_micros(200);

/// Replay speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rate {
    /// Bag time runs this many times as fast as the wall clock (1 = original timing).
    Factor(f64),
    /// Every message is due at once: as fast as the publisher can go.
    Max,
}

/// How to replay a bag.
#[derive(Clone, Debug, PartialEq)]
pub struct PlayOptions {
    /// Replay speed.
    pub rate: Rate,
    /// Start again from the start offset after the last message, forever.
    pub looped: bool,
    /// Skip the first `start_offset_s` seconds (bag time, from the first message).
    pub start_offset_s: f64,
    /// Topics to replay; empty = all.
    pub topics: Vec<String>,
    /// Rate of generated `/clock` ticks (Hz, bag time); 0 = none. Ticks are generated only
    /// when the bag's own `/clock` is not replayed.
    pub clock_hz: f64,
}

impl Default for PlayOptions {
    fn default() -> Self {
        Self {
            rate: Rate::Factor(1.0),
            looped: false,
            start_offset_s: 0.0,
            topics: Vec::new(),
            clock_hz: 100.0,
        }
    }
}

impl PlayOptions {
    /// Rejects a rate that is not finite and positive, a negative or NaN offset and a negative
    /// or NaN clock rate.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &str, value: f64, reason: &str| BagError::InvalidOption {
            name: name.to_owned(),
            value: value.to_string(),
            reason: reason.to_owned(),
        };
        if let Rate::Factor(r) = self.rate
            && !(r.is_finite() && (1e-6..=1e6).contains(&r))
        {
            return Err(bad("rate", r, "must be in [1e-6, 1e6] (or as fast as possible)"));
        }
        if !(self.start_offset_s.is_finite() && self.start_offset_s >= 0.0) {
            return Err(bad("start", self.start_offset_s, "must be a finite number ≥ 0 s"));
        }
        if !(self.clock_hz.is_finite() && self.clock_hz >= 0.0 && self.clock_hz <= 10_000.0) {
            return Err(bad("clock-hz", self.clock_hz, "must be in 0..=10000 Hz"));
        }
        Ok(())
    }
}

/// Maps bag time to wall time since the start of playback.
///
/// `due(t) = loop_base + (t − origin) / rate`, or zero at [`Rate::Max`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Schedule {
    rate: Rate,
    /// Bag time (ns) that is due at the start of each loop.
    origin_ns: u64,
}

impl Schedule {
    /// A schedule at `rate` whose bag time `origin_ns` is due at zero.
    pub fn new(rate: Rate, origin_ns: u64) -> Self {
        Self { rate, origin_ns }
    }

    /// Wall time after the start of playback at which bag time `t_ns` is due, in the loop
    /// that started at `loop_base`. Bag times before the origin are due at `loop_base`.
    pub fn due(&self, t_ns: u64, loop_base: Duration) -> Duration {
        match self.rate {
            Rate::Max => Duration::ZERO,
            Rate::Factor(r) => {
                let bag = t_ns.saturating_sub(self.origin_ns) as f64 * 1e-9;
                // Saturating: an extreme rate must not panic the replay (the options bound it).
                let wall = Duration::try_from_secs_f64(bag / r).unwrap_or(Duration::MAX);
                loop_base.saturating_add(wall)
            }
        }
    }

    /// Wall duration of `bag_ns` of bag time at this rate (zero at [`Rate::Max`]).
    pub fn wall(&self, bag_ns: u64) -> Duration {
        self.due(self.origin_ns.saturating_add(bag_ns), Duration::ZERO)
    }
}

/// One thing to publish.
#[derive(Clone, Debug)]
pub enum PlayItem {
    /// A message of the bag, untouched.
    Message {
        /// The message.
        message: RawMessage,
        /// Due this long after the start of playback.
        due: Duration,
        /// Which pass over the bag (0 for the first; only grows with `looped`).
        pass: u32,
    },
    /// A generated `/clock` tick (`rosgraph_msgs/Clock`).
    Clock {
        /// The clock value (ns, bag time).
        time_ns: u64,
        /// Due this long after the start of playback.
        due: Duration,
    },
}

impl PlayItem {
    /// When the item is due after the start of playback.
    pub fn due(&self) -> Duration {
        match self {
            Self::Message { due, .. } | Self::Clock { due, .. } => *due,
        }
    }
}

/// Replays a bag as a stream of [`PlayItem`]s (see the module docs).
///
/// Items come in due order. Damage in the file is an `Err` item (naming the file and byte
/// offset) and the stream goes on with what is readable after it. With `looped`, the next pass
/// starts one mean message interval after the last message of the previous one; bag time (and
/// so `/clock`) starts again from the offset.
#[derive(Debug)]
pub struct Player<'a> {
    reader: &'a BagReader,
    options: PlayOptions,
    topics: Option<BTreeSet<String>>,
    schedule: Schedule,
    messages: Messages<'a>,
    /// First bag time replayed (start of the bag + offset), ns.
    begin_ns: u64,
    /// Last message time of the bag, ns.
    end_ns: u64,
    /// Messages per pass after filtering (from the bag's info).
    per_pass: u64,
    pass: u32,
    loop_base: Duration,
    generate_clock: bool,
    clock_period_ns: u64,
    next_clock_ns: u64,
    pending: Option<RawMessage>,
    finished: bool,
}

impl<'a> Player<'a> {
    /// Prepares playback of `reader` with `options` (validated). A topic asked for that the bag
    /// does not have is an error listing the bag's topics.
    pub fn new(reader: &'a BagReader, options: PlayOptions) -> Result<Self> {
        options.validate()?;
        let info = reader.info();
        let topics = if options.topics.is_empty() {
            None
        } else {
            let wanted: BTreeSet<String> = options.topics.iter().cloned().collect();
            for t in &wanted {
                if !info.topics.iter().any(|i| &i.topic == t) {
                    return Err(BagError::UnknownTopic {
                        path: reader.path().to_path_buf(),
                        topic: t.clone(),
                        available: info
                            .topics
                            .iter()
                            .map(|i| i.topic.as_str())
                            .collect::<Vec<_>>()
                            .join(", "),
                    });
                }
            }
            Some(wanted)
        };
        let selected = |topic: &str| topics.as_ref().is_none_or(|s| s.contains(topic));
        let per_pass = info
            .topics
            .iter()
            .filter(|t| selected(&t.topic))
            .map(|t| t.message_count)
            .sum();
        let start_ns = info.start_ns.unwrap_or(0);
        let offset_ns = (options.start_offset_s * 1e9).round() as u64;
        let begin_ns = start_ns.saturating_add(offset_ns);
        let bag_has_clock = info.topics.iter().any(|t| t.topic == CLOCK_TOPIC);
        let generate_clock = options.clock_hz > 0.0 && !(bag_has_clock && selected(CLOCK_TOPIC));
        let clock_period_ns = if options.clock_hz > 0.0 {
            ((1e9 / options.clock_hz).round() as u64).max(1)
        } else {
            u64::MAX
        };
        Ok(Self {
            reader,
            schedule: Schedule::new(options.rate, begin_ns),
            topics,
            options,
            messages: reader.messages(),
            begin_ns,
            end_ns: info.end_ns.unwrap_or(0),
            per_pass,
            pass: 0,
            loop_base: Duration::ZERO,
            generate_clock,
            clock_period_ns,
            next_clock_ns: begin_ns,
            pending: None,
            finished: false,
        })
    }

    /// Messages one pass will replay (after the topic filter, before the start offset).
    pub fn messages_per_pass(&self) -> u64 {
        self.per_pass
    }

    /// Bag time replayed per pass (ns): from the start offset to the last message.
    pub fn span_ns(&self) -> u64 {
        self.end_ns.saturating_sub(self.begin_ns)
    }

    /// The schedule (rate and origin).
    pub fn schedule(&self) -> Schedule {
        self.schedule
    }

    /// Whether `/clock` ticks are generated (the bag's own `/clock` is not replayed).
    pub fn generates_clock(&self) -> bool {
        self.generate_clock
    }

    /// The options in use.
    pub fn options(&self) -> &PlayOptions {
        &self.options
    }

    /// The next selected message at or after the offset, or `None` at the end of a pass.
    fn next_message(&mut self) -> Option<Result<RawMessage>> {
        if let Some(m) = self.pending.take() {
            return Some(Ok(m));
        }
        let topics = &self.topics;
        for item in self.messages.by_ref() {
            match item {
                Err(e) => return Some(Err(e)),
                Ok(m)
                    if m.log_time_ns >= self.begin_ns
                        && topics.as_ref().is_none_or(|s| s.contains(&*m.topic)) =>
                {
                    return Some(Ok(m));
                }
                Ok(_) => {}
            }
        }
        None
    }

    fn start_next_pass(&mut self) -> bool {
        if !self.options.looped || self.per_pass == 0 {
            return false;
        }
        let span = self.span_ns();
        let gap_ns = if self.per_pass > 1 {
            span / (self.per_pass - 1)
        } else {
            1_000_000
        }
        .max(1_000_000);
        self.loop_base += self.schedule.wall(span.saturating_add(gap_ns));
        self.pass += 1;
        self.messages = self.reader.messages();
        self.next_clock_ns = self.begin_ns;
        true
    }
}

impl Iterator for Player<'_> {
    type Item = Result<PlayItem>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if self.finished {
                return None;
            }
            let message = match self.next_message() {
                Some(Err(e)) => return Some(Err(e)),
                Some(Ok(m)) => m,
                None => {
                    if self.start_next_pass() {
                        continue;
                    }
                    self.finished = true;
                    return None;
                }
            };
            let t = message.log_time_ns;
            if self.generate_clock && self.next_clock_ns <= t {
                let mut tick = self.next_clock_ns;
                if self.options.rate == Rate::Max {
                    // One tick per message burst: the latest tick boundary not after it.
                    let k = (t - tick) / self.clock_period_ns;
                    tick += k * self.clock_period_ns;
                }
                self.next_clock_ns = tick.saturating_add(self.clock_period_ns);
                self.pending = Some(message);
                return Some(Ok(PlayItem::Clock {
                    time_ns: tick,
                    due: self.schedule.due(tick, self.loop_base),
                }));
            }
            let due = self.schedule.due(t, self.loop_base);
            return Some(Ok(PlayItem::Message {
                message,
                due,
                pass: self.pass,
            }));
        }
    }
}

/// Waits until `deadline`: sleeps until [`SPIN_WINDOW`] before it, then spins on the clock.
/// Returns at once for a deadline in the past.
pub fn wait_until(deadline: Instant) {
    let now = Instant::now();
    if deadline <= now {
        return;
    }
    let left = deadline - now;
    if left > SPIN_WINDOW {
        std::thread::sleep(left - SPIN_WINDOW);
    }
    while Instant::now() < deadline {
        std::hint::spin_loop();
    }
}

/// Percentiles of a set of samples (sorted in place); `None` when empty.
///
/// `q` in 0..=1, nearest-rank.
pub fn percentile(samples: &mut [f64], q: f64) -> Option<f64> {
    if samples.is_empty() {
        return None;
    }
    samples.sort_by(f64::total_cmp);
    let rank = ((q.clamp(0.0, 1.0) * samples.len() as f64).ceil() as usize).max(1);
    samples.get(rank - 1).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedule_scales_bag_time_by_the_rate() {
        let s = Schedule::new(Rate::Factor(2.0), 1_000_000_000);
        assert_eq!(s.due(1_000_000_000, Duration::ZERO), Duration::ZERO);
        assert_eq!(s.due(3_000_000_000, Duration::ZERO), Duration::from_secs(1));
        assert_eq!(s.due(500, Duration::from_secs(5)), Duration::from_secs(5));
        let m = Schedule::new(Rate::Max, 0);
        assert_eq!(m.due(9_000_000_000, Duration::from_secs(3)), Duration::ZERO);
    }

    #[test]
    fn bad_options_are_refused() {
        for o in [
            PlayOptions { rate: Rate::Factor(0.0), ..Default::default() },
            PlayOptions { rate: Rate::Factor(f64::NAN), ..Default::default() },
            PlayOptions { start_offset_s: -1.0, ..Default::default() },
            PlayOptions { clock_hz: f64::INFINITY, ..Default::default() },
        ] {
            assert!(o.validate().is_err(), "{o:?}");
        }
        assert!(PlayOptions::default().validate().is_ok());
    }

    #[test]
    fn percentile_is_nearest_rank() {
        let mut v = vec![5.0, 1.0, 3.0, 2.0, 4.0];
        assert_eq!(percentile(&mut v, 0.5), Some(3.0));
        assert_eq!(percentile(&mut v, 1.0), Some(5.0));
        assert_eq!(percentile(&mut v, 0.0), Some(1.0));
        assert_eq!(percentile(&mut [], 0.5), None);
    }

    #[test]
    fn wait_until_is_not_early() {
        let start = Instant::now();
        let deadline = start + Duration::from_millis(3);
        wait_until(deadline);
        assert!(Instant::now() >= deadline);
    }
}
