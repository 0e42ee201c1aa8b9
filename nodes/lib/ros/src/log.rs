//! Log lines a person can read in a terminal, a pipe or a node's log file.
//!
//! - Colour only on a terminal (and never with `NO_COLOR` set): log files and pipes get plain
//!   text, no ANSI escape codes.
//! - Every line carries the wall clock (UTC) and, once a node in the process follows `/clock`,
//!   the simulated time: `2026-12-07T21:13:36.123456Z sim 12.345  INFO ds_controller: …`.
//! - A line repeated word for word is printed once; the repeats are counted and reported
//!   (`… the last line repeated 41 times in 8.2 s`) when a different line comes, or every
//!   [`FOLD_REPORT_S`] while the repeats go on, as syslog does.

use std::io::{IsTerminal as _, Write};
use std::sync::Mutex;
use std::sync::atomic::{AtomicI64, Ordering};
use std::time::Instant;

use tracing_subscriber::fmt::format::Writer;
use tracing_subscriber::fmt::time::{FormatTime, SystemTime};

/// Simulated time of the process, ns (the newest `/clock` any of its nodes received; < 0 none).
static SIM_TIME_NS: AtomicI64 = AtomicI64::new(-1);

/// While a line repeats, how often the count is reported anyway, s.
pub const FOLD_REPORT_S: f64 = 10.0;

/// Records the simulated time shown in log lines (called by the `/clock` follower).
pub fn set_sim_time_ns(ns: i64) {
    SIM_TIME_NS.store(ns, Ordering::Relaxed);
}

/// The wall clock (RFC 3339, UTC, µs) and, when known, ` sim SECONDS` (ms).
#[derive(Clone, Copy, Debug, Default)]
pub struct WallAndSimTime;

impl FormatTime for WallAndSimTime {
    fn format_time(&self, w: &mut Writer<'_>) -> std::fmt::Result {
        SystemTime.format_time(w)?;
        let ns = SIM_TIME_NS.load(Ordering::Relaxed);
        if ns >= 0 {
            write!(w, " sim {:.3}", ns as f64 * 1e-9)?;
        }
        Ok(())
    }
}

/// Whether log lines to stderr get colour: a terminal, and `NO_COLOR` unset or empty.
pub fn colour() -> bool {
    std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty())
}

/// What a line says without its time: from its level on (the time differs between repeats).
fn key(line: &[u8]) -> &[u8] {
    const LEVELS: [&[u8]; 5] = [b"TRACE", b"DEBUG", b"INFO", b"WARN", b"ERROR"];
    let at = LEVELS.iter().filter_map(|l| line.windows(l.len()).position(|w| w == *l)).min();
    at.map_or(line, |i| &line[i..])
}

#[derive(Debug)]
struct Fold {
    last: Vec<u8>,
    repeats: u64,
    since: Instant,
}

/// Stderr that prints a line repeated word for word once and counts the repeats (see the module
/// docs). One formatted event is one `write` of a [`FoldGuard`].
#[derive(Debug)]
pub struct FoldingStderr {
    state: Mutex<Fold>,
}

impl Default for FoldingStderr {
    fn default() -> Self {
        Self { state: Mutex::new(Fold { last: Vec::new(), repeats: 0, since: Instant::now() }) }
    }
}

impl FoldingStderr {
    /// Passes `line` (one whole event) to `out`, or counts it as a repeat.
    fn line(&self, line: &[u8], out: &mut impl Write) -> std::io::Result<()> {
        let mut s = self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let now = Instant::now();
        if !s.last.is_empty() && key(line) == key(&s.last) {
            s.repeats += 1;
            if now.duration_since(s.since).as_secs_f64() < FOLD_REPORT_S {
                return Ok(());
            }
        }
        if s.repeats > 0 {
            let plural = if s.repeats == 1 { "" } else { "s" };
            writeln!(
                out,
                "… the last line repeated {} time{plural} in {:.1} s",
                s.repeats,
                now.duration_since(s.since).as_secs_f64()
            )?;
        }
        if s.repeats == 0 || key(line) != key(&s.last) {
            out.write_all(line)?;
        }
        s.last.clear();
        s.last.extend_from_slice(line);
        s.repeats = 0;
        s.since = now;
        Ok(())
    }
}

/// The writer of one event ([`FoldingStderr`]'s `MakeWriter`): collects it, passes it on when
/// dropped.
#[derive(Debug)]
pub struct FoldGuard<'a> {
    to: &'a FoldingStderr,
    buffer: Vec<u8>,
}

impl Write for FoldGuard<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.buffer.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Drop for FoldGuard<'_> {
    fn drop(&mut self) {
        if !self.buffer.is_empty() {
            // Nowhere to report a failing stderr.
            let _ = self.to.line(&self.buffer, &mut std::io::stderr().lock());
        }
    }
}

impl<'a> tracing_subscriber::fmt::MakeWriter<'a> for FoldingStderr {
    type Writer = FoldGuard<'a>;

    fn make_writer(&'a self) -> Self::Writer {
        FoldGuard { to: self, buffer: Vec::new() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(lines: &[&str]) -> String {
        let fold = FoldingStderr::default();
        let mut out = Vec::new();
        for l in lines {
            fold.line(l.as_bytes(), &mut out).expect("write");
        }
        String::from_utf8(out).expect("utf-8")
    }

    #[test]
    fn repeats_that_differ_only_in_time_are_folded_and_counted() {
        let out = run(&[
            "2026-12-07T10:00:00.000001Z sim 1.000  WARN ds_controller: stale distances\n",
            "2026-12-07T10:00:00.100001Z sim 1.100  WARN ds_controller: stale distances\n",
            "2026-12-07T10:00:00.200001Z sim 1.200  WARN ds_controller: stale distances\n",
            "2026-12-07T10:00:00.300001Z sim 1.300  INFO ds_controller: distances back\n",
            "2026-12-07T10:00:00.400001Z sim 1.400  INFO ds_controller: distances back after 2 frames\n",
        ]);
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines.len(), 4, "{out}");
        assert!(lines[0].ends_with("stale distances"));
        assert!(lines[1].starts_with("… the last line repeated 2 times in"), "{out}");
        assert!(lines[2].ends_with("distances back") && lines[3].ends_with("after 2 frames"), "{out}");
    }

    #[test]
    fn the_level_starts_the_compared_text() {
        assert_eq!(key(b"2026-12-07T10:00:00Z sim 1.0  INFO a: b"), b"INFO a: b");
        assert_eq!(key(b"no level here"), b"no level here");
    }

    #[test]
    fn the_time_shows_the_simulated_seconds_once_known() {
        let mut text = String::new();
        WallAndSimTime.format_time(&mut Writer::new(&mut text)).expect("format");
        let (wall, _) = text.split_once(' ').unwrap_or((&text, ""));
        assert!(wall.ends_with('Z') && wall.len() == 27, "{text}");
        set_sim_time_ns(12_345_678_901);
        let mut text = String::new();
        WallAndSimTime.format_time(&mut Writer::new(&mut text)).expect("format");
        assert!(text.ends_with(" sim 12.346"), "{text}");
        set_sim_time_ns(-1);
    }
}
