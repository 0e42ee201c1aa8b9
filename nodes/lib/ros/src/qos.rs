//! QoS of the topics of the graph. The README's topic table quotes these.

pub use ros2_client::QosProfile;
use ros2_client::qos::{Durability, History, Reliability, WhenFull};

/// ROS 2's default: reliable, volatile, keep last 10. Used unless a topic says otherwise.
pub fn reliable() -> QosProfile {
    reliable_depth(10)
}

/// Reliable, volatile, keep last `depth`. A write never waits for a slow reader: when a
/// reliable reader has not acknowledged enough (a stalled or vanished subscriber) the message
/// is dropped at once and counted by [`Publisher`](crate::Publisher) — rustdds's default
/// would wait up to 100 ms per write, stalling a 1 kHz loop.
pub fn reliable_depth(depth: usize) -> QosProfile {
    QosProfile {
        reliability: Reliability::Reliable { when_full: WhenFull::Fail },
        durability: Durability::Volatile,
        history: History::KeepLast { depth },
        ..QosProfile::publisher_default()
    }
}

/// [`reliable_depth`] for a bag replay, whose writes wait up to 100 ms for a slow reliable
/// reader before failing: a replay would rather be late than drop a message.
pub fn replay(depth: usize) -> QosProfile {
    QosProfile {
        reliability: Reliability::Reliable { when_full: WhenFull::DEFAULT },
        ..reliable_depth(depth)
    }
}

/// `/clock`: best effort, keep last 1 (as rclcpp's `ClockQoS`): a late tick is useless.
pub fn clock() -> QosProfile {
    QosProfile {
        reliability: Reliability::BestEffort,
        durability: Durability::Volatile,
        history: History::KeepLast { depth: 1 },
        ..QosProfile::publisher_default()
    }
}

/// Streams where only the newest sample matters and loss is fine (as rclcpp's
/// `SensorDataQoS`): best effort, keep last 5.
pub fn sensor_data() -> QosProfile {
    QosProfile {
        reliability: Reliability::BestEffort,
        durability: Durability::Volatile,
        history: History::KeepLast { depth: 5 },
        ..QosProfile::publisher_default()
    }
}

/// `/tf_static` and other latched topics: reliable, transient local, keep last 1.
pub fn latched() -> QosProfile {
    QosProfile {
        reliability: Reliability::Reliable { when_full: WhenFull::DEFAULT },
        durability: Durability::TransientLocal,
        history: History::KeepLast { depth: 1 },
        ..QosProfile::publisher_default()
    }
}

/// Best effort, volatile, keep last `depth`: a reader that matches every writer, reliable or
/// not (what `cowork bag record` uses for a topic before it knows its writers' QoS).
pub fn best_effort_depth(depth: usize) -> QosProfile {
    QosProfile { history: History::KeepLast { depth }, ..sensor_data() }
}

/// Whether `qos` is transient local (a late subscriber gets the last messages: a latched
/// topic such as `/robot_description`).
pub fn is_latched(qos: &QosProfile) -> bool {
    matches!(qos.durability, Durability::TransientLocal)
}

/// The DDS profile of a topic's [`Delivery`](cowork_msgs::topics::Delivery).
pub fn of(delivery: cowork_msgs::topics::Delivery) -> QosProfile {
    use cowork_msgs::topics::Delivery;
    match delivery {
        Delivery::Reliable { depth } => reliable_depth(depth),
        Delivery::BestEffort { depth } => best_effort_depth(depth),
        Delivery::Latched => latched(),
        Delivery::Clock => clock(),
    }
}
