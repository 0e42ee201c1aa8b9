//! `builtin_interfaces`: ROS time and duration.

use serde::{Deserialize, Serialize};

use crate::ros_message;

const NANOS_PER_SEC: i64 = 1_000_000_000;

/// Split signed nanoseconds into (seconds, nanoseconds in [0, 1e9)), saturating the seconds
/// to the i32 range of the message.
fn split_nanos(nanos: i64) -> (i32, u32) {
    let sec = nanos.div_euclid(NANOS_PER_SEC);
    let nanosec = nanos.rem_euclid(NANOS_PER_SEC);
    match i32::try_from(sec) {
        // rem_euclid is in [0, 1e9), which fits u32.
        Ok(sec) => (sec, nanosec as u32),
        Err(_) if sec < 0 => (i32::MIN, 0),
        Err(_) => (i32::MAX, 999_999_999),
    }
}

/// Nanoseconds closest to `secs` seconds (NaN gives 0, infinities saturate).
fn secs_to_nanos(secs: f64) -> i64 {
    // `as` saturates out-of-range floats and maps NaN to 0.
    (secs * 1e9).round() as i64
}

/// ROS time: `sec` seconds plus `nanosec` nanoseconds in [0, 1e9).
///
/// A time before the epoch (or a negative duration) keeps `nanosec` non-negative:
/// -1.7 s is `{ sec: -2, nanosec: 300_000_000 }`.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct Time {
    /// Seconds (s).
    pub sec: i32,
    /// Nanoseconds added to `sec`, in [0, 1e9).
    pub nanosec: u32,
}

impl Time {
    /// The time `nanos` nanoseconds after the epoch (seconds saturate at the i32 range).
    pub fn from_nanos(nanos: i64) -> Self {
        let (sec, nanosec) = split_nanos(nanos);
        Self { sec, nanosec }
    }

    /// Nanoseconds since the epoch.
    pub fn to_nanos(&self) -> i64 {
        i64::from(self.sec) * NANOS_PER_SEC + i64::from(self.nanosec)
    }

    /// The time `secs` seconds after the epoch, rounded to the nearest nanosecond.
    pub fn from_secs_f64(secs: f64) -> Self {
        Self::from_nanos(secs_to_nanos(secs))
    }

    /// Seconds since the epoch.
    pub fn to_secs_f64(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

ros_message!(Time = "builtin_interfaces" / "Time" in "ros_std/builtin_interfaces/msg", deps []);

/// ROS duration: `sec` seconds plus `nanosec` nanoseconds in [0, 1e9).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct Duration {
    /// Seconds (s).
    pub sec: i32,
    /// Nanoseconds added to `sec`, in [0, 1e9).
    pub nanosec: u32,
}

impl Duration {
    /// A duration of `nanos` nanoseconds (seconds saturate at the i32 range).
    pub fn from_nanos(nanos: i64) -> Self {
        let (sec, nanosec) = split_nanos(nanos);
        Self { sec, nanosec }
    }

    /// Length in nanoseconds.
    pub fn to_nanos(&self) -> i64 {
        i64::from(self.sec) * NANOS_PER_SEC + i64::from(self.nanosec)
    }

    /// A duration of `secs` seconds, rounded to the nearest nanosecond.
    pub fn from_secs_f64(secs: f64) -> Self {
        Self::from_nanos(secs_to_nanos(secs))
    }

    /// Length in seconds.
    pub fn to_secs_f64(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

ros_message!(Duration = "builtin_interfaces" / "Duration" in "ros_std/builtin_interfaces/msg", deps []);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_time_keeps_nanosec_positive() {
        let t = Time::from_secs_f64(-1.7);
        assert_eq!(
            t,
            Time {
                sec: -2,
                nanosec: 300_000_000
            }
        );
        assert_eq!(t.to_nanos(), -1_700_000_000);
    }

    #[test]
    fn nanos_round_trip_and_saturation() {
        for n in [0, 1, 999_999_999, 1_000_000_000, -1, 123_456_789_012] {
            assert_eq!(Time::from_nanos(n).to_nanos(), n);
            assert_eq!(Duration::from_nanos(n).to_nanos(), n);
        }
        assert_eq!(
            Time::from_nanos(i64::MAX),
            Time {
                sec: i32::MAX,
                nanosec: 999_999_999
            }
        );
        assert_eq!(
            Time::from_nanos(i64::MIN),
            Time {
                sec: i32::MIN,
                nanosec: 0
            }
        );
        assert_eq!(Time::from_secs_f64(f64::NAN), Time::default());
        assert!((Time::from_secs_f64(12.25).to_secs_f64() - 12.25).abs() < 1e-12);
    }
}
