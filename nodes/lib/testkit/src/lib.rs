//! Test-only helpers shared by the cowork crates (used as a dev-dependency only).
//!
//! [`CountingAllocator`] forwards to the system allocator and counts allocations per thread, so a
//! zero-allocation test is not disturbed by other test threads:
//!
//! ```ignore
//! #[global_allocator]
//! static GLOBAL: cowork_testkit::CountingAllocator = cowork_testkit::CountingAllocator;
//!
//! let before = cowork_testkit::allocations();
//! hot_loop();
//! assert_eq!(cowork_testkit::allocations() - before, 0);
//! ```
#![allow(unsafe_code)] // a GlobalAlloc implementation is unsafe by definition

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

/// System allocator that counts `alloc` and `realloc` calls of the current thread.
#[derive(Debug, Clone, Copy, Default)]
pub struct CountingAllocator;

// SAFETY: every call is forwarded unchanged to the system allocator; counting touches only a
// const-initialised thread-local `Cell` (no allocation, `try_with` tolerates thread teardown).
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Allocations (and reallocations) made so far on the calling thread, when
/// [`CountingAllocator`] is the global allocator; always 0 otherwise.
pub fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

/// A scripted [`InputSource`](cowork_ros::InputSource) for a node's golden tests: inputs at
/// given times (s) on a mock clock that jumps from one input or deadline to the next, so a
/// test of minutes of node time runs in microseconds and gives the same outputs every time.
#[derive(Debug, Clone)]
pub struct ScriptedSource<I> {
    script: std::collections::VecDeque<(f64, I)>,
    now_s: f64,
    end_s: f64,
    /// `now_s` as f64 bits, for [`ScriptedSource::clock`] handles.
    shared_now: std::sync::Arc<std::sync::atomic::AtomicU64>,
}

/// A handle on a [`ScriptedSource`]'s mock clock, readable while the node loop holds the
/// source (an output callback stamping what it records).
#[derive(Debug, Clone)]
pub struct ClockHandle(std::sync::Arc<std::sync::atomic::AtomicU64>);

impl ClockHandle {
    /// The source's clock now (s).
    pub fn now_s(&self) -> f64 {
        f64::from_bits(self.0.load(std::sync::atomic::Ordering::Relaxed))
    }
}

impl<I> ScriptedSource<I> {
    /// `script` sorted by time (s); the clock starts at the first input's time (or 0) and the
    /// source ends at `end_s` (or at its last input when `end_s` is earlier).
    pub fn new(mut script: Vec<(f64, I)>, end_s: f64) -> Self {
        script.sort_by(|a, b| a.0.total_cmp(&b.0));
        let now_s = script.first().map_or(0.0, |(t, _)| *t);
        let last = script.last().map_or(0.0, |(t, _)| *t);
        let shared_now = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(now_s.to_bits()));
        Self { script: script.into(), now_s, end_s: end_s.max(last), shared_now }
    }

    /// A handle that reads this source's clock.
    pub fn clock(&self) -> ClockHandle {
        ClockHandle(std::sync::Arc::clone(&self.shared_now))
    }

    fn set_now(&mut self, t: f64) {
        self.now_s = self.now_s.max(t);
        self.shared_now.store(self.now_s.to_bits(), std::sync::atomic::Ordering::Relaxed);
    }
}

/// One golden-file line `{"t": t, "out": value}` with every float rounded to 1e-6 (so the
/// last bits of a float computation do not make a difference between machines).
pub fn json_line(t: f64, value: &impl serde::Serialize) -> String {
    fn round(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Number(n) => {
                if let Some(f) = n.as_f64().filter(|_| !n.is_i64() && !n.is_u64()) {
                    *v = serde_json::json!((f * 1e6).round() / 1e6);
                }
            }
            serde_json::Value::Array(a) => a.iter_mut().for_each(round),
            serde_json::Value::Object(o) => o.values_mut().for_each(round),
            _ => {}
        }
    }
    let mut v = serde_json::json!({ "t": t, "out": value });
    round(&mut v);
    v.to_string()
}

impl<I> cowork_ros::InputSource<I> for ScriptedSource<I> {
    fn next(&mut self, deadline_s: f64) -> cowork_ros::Event<I> {
        match self.script.front() {
            Some((t, _)) if *t <= deadline_s => {
                let (t, input) = self.script.pop_front().expect("front exists");
                self.set_now(t);
                cowork_ros::Event::Input(input)
            }
            _ if deadline_s > self.end_s || !deadline_s.is_finite() => {
                self.set_now(self.end_s);
                cowork_ros::Event::End
            }
            _ => {
                self.set_now(deadline_s);
                cowork_ros::Event::Deadline
            }
        }
    }

    fn now_s(&self) -> f64 {
        self.now_s
    }
}

/// Compares `lines` (one JSON value per line, as a node's outputs) with the golden JSONL file
/// at `path`; `UPDATE_GOLDEN=1` rewrites the file instead. On a difference the panic names
/// the first differing line of each.
pub fn assert_golden(path: &std::path::Path, lines: &[String]) {
    let got = lines.iter().map(|l| format!("{l}\n")).collect::<String>();
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("creating {}: {e}", dir.display()));
        }
        std::fs::write(path, &got).unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
        return;
    }
    let want = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("golden file {}: {e} (run with UPDATE_GOLDEN=1 to create it)", path.display()));
    if want != got {
        let (i, (w, g)) = want
            .lines()
            .chain(std::iter::repeat("<end>"))
            .zip(got.lines().chain(std::iter::repeat("<end>")))
            .enumerate()
            .find(|(_, (w, g))| w != g)
            .unwrap_or((0, ("?", "?")));
        panic!(
            "{} differs at line {} ({} lines expected, {} got; UPDATE_GOLDEN=1 rewrites it if the change is intended)\n  expected: {w}\n  got:      {g}",
            path.display(),
            i + 1,
            want.lines().count(),
            got.lines().count()
        );
    }
}

#[cfg(test)]
mod scripted_tests {
    use super::ScriptedSource;
    use cowork_ros::{Event, InputSource};

    #[test]
    fn inputs_in_time_order_then_deadlines_then_the_end() {
        let mut s = ScriptedSource::new(vec![(0.2, "b"), (0.1, "a")], 1.0);
        assert_eq!(s.next(0.05), Event::Deadline);
        assert_eq!(s.next(0.15), Event::Input("a"));
        assert!((s.now_s() - 0.1).abs() < 1e-12);
        assert_eq!(s.next(0.15), Event::Deadline);
        assert_eq!(s.next(0.5), Event::Input("b"));
        assert_eq!(s.next(0.9), Event::Deadline);
        assert!((s.now_s() - 0.9).abs() < 1e-12);
        let clock = s.clock();
        assert_eq!(s.next(1.1), Event::End);
        assert!((clock.now_s() - 1.0).abs() < 1e-12);
        assert_eq!(super::json_line(0.5, &[0.1234567891, 2.0]), r#"{"out":[0.123457,2.0],"t":0.5}"#);
    }
}
