//! How a node's loop gets its inputs: a typed `Input` enum per node, delivered by an
//! [`InputSource`] — over DDS (a [`WaitSet`] that blocks on the subscriptions until a message
//! arrives or the node's next deadline), or a scripted list of `(t, Input)` for tests
//! (`cowork_testkit::ScriptedSource`) — and the [`RunOptions`] every node's `run` takes.
//!
//! The loop of every node has the same shape:
//!
//! ```ignore
//! let stop = options.start();
//! while !stop.requested() {
//!     match source.next(deadline) {
//!         Event::Input(input) => node.on_input(input, source.now_s()),
//!         Event::Deadline => node.tick(source.now_s()),
//!         Event::End => break,
//!     }
//! }
//! ```

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result};
use cowork_msgs::RosMessage;
use ros2_client::dds::rustdds::mio1;

use crate::Subscription;

/// What an [`InputSource`] hands the loop next.
#[derive(Debug, Clone, PartialEq)]
pub enum Event<I> {
    /// A message (or other input) arrived.
    Input(I),
    /// The deadline the loop asked for passed without an input: time to tick.
    Deadline,
    /// The source has nothing more (a scripted source at its end); a DDS source never ends.
    End,
}

/// A source of a node's inputs with its own clock (s): the node's clock over DDS (simulated or
/// wall time), the script's times in tests.
pub trait InputSource<I> {
    /// The next input, or [`Event::Deadline`] once the source's clock reaches `deadline_s`
    /// with nothing waiting. Never returns an input stamped after `deadline_s`.
    fn next(&mut self, deadline_s: f64) -> Event<I>;
    /// The source's clock now (s).
    fn now_s(&self) -> f64;
}

/// Blocks a thread until one of its subscriptions has a message or a timeout passes, instead
/// of polling with sleeps. Register every subscription the loop drains; after a wake-up the
/// loop must drain them with `take()` (which clears the wake-up: the poll is edge-triggered).
pub struct WaitSet {
    poll: mio1::Poll,
    events: mio1::Events,
    registered: usize,
}

impl std::fmt::Debug for WaitSet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "WaitSet({} subscriptions)", self.registered)
    }
}

impl WaitSet {
    /// An empty wait set.
    pub fn new() -> Result<Self> {
        Ok(Self { poll: mio1::Poll::new().context("cannot create a poll for the subscriptions")?, events: mio1::Events::with_capacity(64), registered: 0 })
    }

    /// Wakes [`wait`](Self::wait) when `subscription` receives a message.
    pub fn add<T: RosMessage>(&mut self, subscription: &mut Subscription<T>) -> Result<()> {
        let token = mio1::Token(self.registered);
        subscription
            .register(self.poll.registry(), token)
            .with_context(|| format!("cannot wait on {}", subscription.topic()))?;
        self.registered += 1;
        Ok(())
    }

    /// Waits until a registered subscription has a message (true) or `timeout` passes
    /// (false). Capped at 100 ms so a stop request is seen promptly; an interrupted or failed
    /// poll returns true (the caller drains and finds nothing: no message is lost).
    pub fn wait(&mut self, timeout: Duration) -> bool {
        let timeout = timeout.min(Duration::from_millis(100));
        match self.poll.poll(&mut self.events, Some(timeout)) {
            Ok(()) => !self.events.is_empty(),
            Err(_) => true,
        }
    }
}

/// The DDS [`InputSource`] of a node: its subscriptions, each mapped to a variant of the
/// node's `Input`, taken in the order they were added (a node adds the topics whose messages
/// must be handled first — controller status before the world report that followed it —
/// first; every topic is drained faster than it arrives) and, when none has a message, a [`WaitSet`] wait until one arrives or the deadline
/// (node clock: simulated with `use_sim_time`) passes. Returns [`Event::End`] once the
/// [`StopCheck`] says stop.
pub struct DdsSource<I> {
    node: crate::RosNode,
    takers: Vec<Box<dyn FnMut() -> Option<I> + Send>>,
    waits: WaitSet,
    stop: StopCheck,
}

impl<I> std::fmt::Debug for DdsSource<I> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "DdsSource({} on {:?})", self.node.name(), self.waits)
    }
}

impl<I: 'static> DdsSource<I> {
    /// A source on `node` with no subscriptions yet, ending when `stop` says so.
    pub fn new(node: crate::RosNode, stop: StopCheck) -> Result<Self> {
        Ok(Self { node, takers: Vec::new(), waits: WaitSet::new()?, stop })
    }

    /// Subscribes to `topic` (its reader delivery) and delivers its messages as `wrap(msg)`.
    pub fn add<T: RosMessage>(&mut self, topic: &cowork_msgs::topics::Topic<T>, wrap: fn(T) -> I) -> Result<()> {
        let mut sub = self.node.subscribe(topic)?;
        self.waits.add(&mut sub)?;
        self.takers.push(Box::new(move || sub.take().map(wrap)));
        Ok(())
    }

    /// Like [`add`](Self::add) for `topic` in `namespace` ([`crate::RosNode::subscribe_in`]),
    /// e.g. one arm's `/left/joint_states` in a node that serves several arms.
    pub fn add_in<T: RosMessage>(
        &mut self,
        topic: &cowork_msgs::topics::Topic<T>,
        namespace: &str,
        wrap: impl Fn(T) -> I + Send + 'static,
    ) -> Result<()> {
        let mut sub = self.node.subscribe_in(topic, namespace)?;
        self.waits.add(&mut sub)?;
        self.takers.push(Box::new(move || sub.take().map(&wrap)));
        Ok(())
    }

    /// The node, to create publishers and read its clock.
    pub fn node(&mut self) -> &mut crate::RosNode {
        &mut self.node
    }

    /// Whether the node's clock runs (with `use_sim_time`: a `/clock` message arrived).
    pub fn clock_started(&self) -> bool {
        self.node.clock_started()
    }

    /// The stop check the source ends on.
    pub fn stop_check(&self) -> &StopCheck {
        &self.stop
    }

    fn take_any(&mut self) -> Option<I> {
        self.takers.iter_mut().find_map(|take| take())
    }
}

impl<I: 'static> InputSource<I> for DdsSource<I> {
    fn next(&mut self, deadline_s: f64) -> Event<I> {
        loop {
            if self.stop.requested() {
                return Event::End;
            }
            if let Some(input) = self.take_any() {
                return Event::Input(input);
            }
            let now = self.now_s();
            if self.clock_started() && now >= deadline_s {
                return Event::Deadline;
            }
            // Wall time: the node-time gap. Simulated time may run faster than the wall
            // clock (a simulator at --max), so there the wait is at most 1 ms of wall time
            // (one `/clock` period of lwr_sim at real time) and the deadline is checked again.
            let gap = if !self.clock_started() {
                0.1
            } else if self.node.uses_sim_time() {
                (deadline_s - now).min(1e-3)
            } else {
                deadline_s - now
            };
            self.waits.wait(crate::duration_s(gap));
        }
    }

    fn now_s(&self) -> f64 {
        self.node.now().to_secs_f64()
    }
}

/// Options of every node's `run`: when to stop besides Ctrl-C / SIGTERM.
#[derive(Debug, Default, Clone)]
pub struct RunOptions {
    /// Stop after this many wall-clock seconds.
    pub duration_s: Option<f64>,
    /// Stop when this flag is raised (tests, a parent thread).
    pub stop: Option<Arc<AtomicBool>>,
}

impl RunOptions {
    /// Runs for `duration_s` seconds at most (None: until stopped).
    pub fn for_duration(duration_s: Option<f64>) -> Self {
        Self { duration_s, stop: None }
    }

    /// Starts the clock of `duration_s`; ask the result whether to stop.
    pub fn start(&self) -> StopCheck {
        StopCheck { started: Instant::now(), duration_s: self.duration_s, stop: self.stop.clone() }
    }
}

/// Whether a running node should stop: Ctrl-C / SIGTERM ([`crate::shutdown`]), the
/// [`RunOptions`] flag, or its duration elapsed.
#[derive(Debug, Clone)]
pub struct StopCheck {
    started: Instant,
    duration_s: Option<f64>,
    stop: Option<Arc<AtomicBool>>,
}

impl StopCheck {
    /// True once the node should stop.
    pub fn requested(&self) -> bool {
        crate::shutdown::requested()
            || self.stop.as_ref().is_some_and(|s| s.load(Ordering::SeqCst))
            || self.duration_s.is_some_and(|d| self.started.elapsed().as_secs_f64() >= d)
    }

    /// Wall-clock seconds since the start.
    pub fn elapsed_s(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stop_flag_and_duration_stop_a_run() {
        let flag = Arc::new(AtomicBool::new(false));
        let check = RunOptions { duration_s: None, stop: Some(flag.clone()) }.start();
        assert!(!check.requested());
        flag.store(true, Ordering::SeqCst);
        assert!(check.requested());
        assert!(RunOptions::for_duration(Some(1e-9)).start().requested());
        assert!(!RunOptions::for_duration(Some(3600.0)).start().requested());
    }

    #[test]
    fn an_empty_wait_set_times_out() {
        let mut w = WaitSet::new().unwrap();
        let t = Instant::now();
        assert!(!w.wait(Duration::from_millis(5)));
        assert!(t.elapsed() >= Duration::from_millis(4));
    }
}
