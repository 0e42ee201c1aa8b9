//! What `cowork bridge` measures per topic: messages forwarded to WebSocket clients, their rate,
//! and the latency from DDS receive to the message queued on the clients' sockets.

use std::collections::VecDeque;
use std::time::Instant;

use serde::Serialize;

/// Latencies kept per topic (the most recent; 200 s of `/joint_states` at 1 kHz).
const MAX_LATENCIES: usize = 200_000;

/// Running figures of one served topic.
#[derive(Debug, Default)]
pub struct TopicStats {
    /// Messages forwarded (at least one client subscribed).
    pub forwarded: u64,
    /// Payload bytes forwarded.
    pub bytes: u64,
    /// Messages taken from DDS while no client was subscribed (not sent).
    pub unsubscribed: u64,
    /// First and last forward.
    span: Option<(Instant, Instant)>,
    /// DDS receive → queued on the sockets, ns (the most recent [`MAX_LATENCIES`]).
    latencies_ns: VecDeque<u64>,
}

impl TopicStats {
    /// Counts one forwarded message of `bytes` queued `latency_ns` after DDS received it.
    pub fn forwarded(&mut self, bytes: usize, latency_ns: u64, at: Instant) {
        self.forwarded += 1;
        self.bytes += bytes as u64;
        let (_, last) = self.span.get_or_insert((at, at));
        *last = at;
        if self.latencies_ns.len() == MAX_LATENCIES {
            self.latencies_ns.pop_front();
        }
        self.latencies_ns.push_back(latency_ns);
    }

    /// The figures of the topic so far.
    pub fn summary(&self, topic: &str, type_name: &str) -> TopicSummary {
        let seconds = self.span.map_or(0.0, |(a, b)| b.duration_since(a).as_secs_f64());
        let per_s = |n: f64| if seconds > 0.0 && self.forwarded >= 2 { n / seconds } else { 0.0 };
        let mut sorted: Vec<u64> = self.latencies_ns.iter().copied().collect();
        sorted.sort_unstable();
        let ms = |q: f64| percentile(&sorted, q).map(|ns| ns as f64 * 1e-6);
        TopicSummary {
            topic: topic.to_owned(),
            type_name: type_name.to_owned(),
            forwarded: self.forwarded,
            unsubscribed: self.unsubscribed,
            rate_hz: per_s((self.forwarded.saturating_sub(1)) as f64),
            mb_per_s: per_s(self.bytes as f64 / 1e6),
            latency_median_ms: ms(0.5),
            latency_p99_ms: ms(0.99),
            latency_max_ms: sorted.last().map(|&ns| ns as f64 * 1e-6),
        }
    }
}

/// One topic's figures, as printed and written by `--stats-json`.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TopicSummary {
    /// Topic name.
    pub topic: String,
    /// ROS type, `pkg/msg/Name`.
    pub type_name: String,
    /// Messages forwarded to at least one client.
    pub forwarded: u64,
    /// Messages received while no client was subscribed.
    pub unsubscribed: u64,
    /// Forwarded messages per second between the first and the last.
    pub rate_hz: f64,
    /// Forwarded payload, MB per second.
    pub mb_per_s: f64,
    /// DDS receive → queued on the clients' sockets, median, ms.
    pub latency_median_ms: Option<f64>,
    /// Same, 99th percentile, ms.
    pub latency_p99_ms: Option<f64>,
    /// Same, largest, ms.
    pub latency_max_ms: Option<f64>,
}

/// The `q` quantile (0..=1, nearest rank) of ascending `sorted`; `None` when empty.
pub fn percentile(sorted: &[u64], q: f64) -> Option<u64> {
    if sorted.is_empty() {
        return None;
    }
    let rank = (q.clamp(0.0, 1.0) * sorted.len() as f64).ceil() as usize;
    sorted.get(rank.saturating_sub(1).min(sorted.len() - 1)).copied()
}

/// The summaries as a table (one line per topic).
pub fn table(summaries: &[TopicSummary]) -> String {
    let mut out = format!(
        "{:<34} {:<34} {:>9} {:>9} {:>8} {:>10} {:>8}\n",
        "topic", "type", "forwarded", "msg/s", "MB/s", "median ms", "p99 ms"
    );
    let opt = |v: Option<f64>| v.map_or_else(|| "-".to_owned(), |v| format!("{v:.3}"));
    for s in summaries {
        out.push_str(&format!(
            "{:<34} {:<34} {:>9} {:>9.1} {:>8.2} {:>10} {:>8}\n",
            s.topic,
            s.type_name,
            s.forwarded,
            s.rate_hz,
            s.mb_per_s,
            opt(s.latency_median_ms),
            opt(s.latency_p99_ms)
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    #[test]
    fn nearest_rank_percentiles() {
        let v: Vec<u64> = (1..=100).collect();
        assert_eq!(percentile(&v, 0.5), Some(50));
        assert_eq!(percentile(&v, 0.99), Some(99));
        assert_eq!(percentile(&v, 1.0), Some(100));
        assert_eq!(percentile(&v, 0.0), Some(1));
        assert_eq!(percentile(&[7], 0.99), Some(7));
        assert_eq!(percentile(&[], 0.5), None);
    }

    #[test]
    fn rate_and_latency_of_forwarded_messages() {
        let t0 = Instant::now();
        let mut s = TopicStats::default();
        for i in 0..31u32 {
            s.forwarded(1_000_000, u64::from(i) * 1_000_000, t0 + Duration::from_millis(u64::from(i) * 100));
        }
        let sum = s.summary("/camera/depth/image_raw", "sensor_msgs/msg/Image");
        assert_eq!(sum.forwarded, 31);
        assert!((sum.rate_hz - 10.0).abs() < 1e-9, "{sum:?}");
        assert!((sum.mb_per_s - 31.0 / 3.0).abs() < 1e-9, "{sum:?}");
        assert_eq!(sum.latency_median_ms, Some(15.0));
        assert_eq!(sum.latency_max_ms, Some(30.0));
        assert!(table(&[sum]).contains("/camera/depth/image_raw"));
    }

    #[test]
    fn nothing_forwarded_has_no_rate_and_no_latency() {
        let sum = TopicStats::default().summary("/tf", "tf2_msgs/msg/TFMessage");
        assert_eq!((sum.rate_hz, sum.latency_median_ms), (0.0, None));
    }
}
