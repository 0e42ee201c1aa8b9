//! Writes a small deterministic bag of the graph's main types (JointState, a 32FC1 depth Image,
//! CameraInfo, TFMessage, String and the custom HumanState and Skeleton), and the values written
//! as JSON lines, for the cross-check against the `mcap` / `mcap-ros2-support` Python readers.
//!
//! `cargo run -p cowork_bag --example write_sample_bag -- OUT.mcap --expect OUT.jsonl`

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use clap::Parser;
use cowork_bag::BagWriter;
use cowork_msgs::RosMessage;
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{
    Point, Pose, Quaternion, Transform, TransformStamped, Twist, Vector3,
};
use cowork_msgs::msg::{HumanState, Skeleton};
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState};
use cowork_msgs::std_msgs::{Header, String as RosString};
use cowork_msgs::tf2_msgs::TFMessage;

#[derive(Debug, Parser)]
struct Args {
    /// The bag to write.
    output: PathBuf,
    /// JSON lines file receiving {topic, type, log_time_ns, publish_time_ns, msg} per message.
    #[arg(long)]
    expect: PathBuf,
    /// Frames per topic.
    #[arg(long, default_value_t = 5)]
    frames: u32,
}

struct Sample {
    writer: BagWriter,
    expect: std::io::BufWriter<std::fs::File>,
}

impl Sample {
    fn put<T: RosMessage>(&mut self, topic: &str, t_ns: u64, msg: &T) -> anyhow::Result<()> {
        let ch = self.writer.add_channel::<T>(topic)?;
        // publish time a little before the log time, as a recorder sees it.
        self.writer.write(ch, t_ns, t_ns - 250_000, msg)?;
        let line = serde_json::json!({
            "topic": topic,
            "type": T::type_name(),
            "log_time_ns": t_ns,
            "publish_time_ns": t_ns - 250_000,
            "msg": serde_json::to_value(msg)?,
        });
        writeln!(self.expect, "{line}")?;
        Ok(())
    }
}

fn header(t_ns: u64, frame: &str) -> Header {
    Header {
        stamp: Time {
            sec: (t_ns / 1_000_000_000) as i32,
            nanosec: (t_ns % 1_000_000_000) as u32,
        },
        frame_id: frame.into(),
    }
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let file = std::fs::File::create(&args.expect)
        .with_context(|| format!("creating {}", args.expect.display()))?;
    let mut s = Sample {
        writer: BagWriter::create(&args.output)?,
        expect: std::io::BufWriter::new(file),
    };
    let (w, h) = (16u32, 12u32);
    let segments = [
        "pelvis",
        "sternum",
        "head",
        "l_shoulder",
        "r_shoulder",
        "l_elbow",
        "r_elbow",
        "l_wrist",
        "r_wrist",
        "l_hand",
        "r_hand",
    ];
    for k in 0..args.frames {
        let t = 1_700_000_000_000_000_000 + u64::from(k) * 33_333_333;
        let kf = f64::from(k);
        s.put(
            "/joint_states",
            t,
            &JointState {
                header: header(t, ""),
                name: (1..=7).map(|j| format!("lwr_a{j}_joint")).collect(),
                position: (0..7).map(|j| 0.1 * kf - 0.05 * f64::from(j)).collect(),
                velocity: (0..7).map(|j| 0.01 * f64::from(j) + 1e-3 * kf).collect(),
                effort: vec![],
            },
        )?;
        let depth: Vec<u8> = (0..w * h)
            .flat_map(|i| (0.5 + 0.001 * i as f32 + 0.01 * k as f32).to_le_bytes())
            .collect();
        s.put(
            "/camera/depth/image_raw",
            t + 1_000,
            &Image {
                header: header(t, "camera_depth_optical_frame"),
                height: h,
                width: w,
                encoding: "32FC1".into(),
                is_bigendian: 0,
                step: w * 4,
                data: depth,
            },
        )?;
        s.put(
            "/camera/depth/camera_info",
            t + 2_000,
            &CameraInfo {
                header: header(t, "camera_depth_optical_frame"),
                height: h,
                width: w,
                distortion_model: "plumb_bob".into(),
                d: vec![0.0, 0.01, -0.002, 0.0, 0.0],
                k: [525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0],
                r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                p: [
                    525.0, 0.0, 319.5, 0.0, 0.0, 525.0, 239.5, 0.0, 0.0, 0.0, 1.0, 0.0,
                ],
                ..Default::default()
            },
        )?;
        s.put(
            "/tf",
            t + 3_000,
            &TFMessage {
                transforms: vec![TransformStamped {
                    header: header(t, "world"),
                    child_frame_id: "lwr_link_7".into(),
                    transform: Transform {
                        translation: Vector3 {
                            x: 0.1 * kf,
                            y: -0.2,
                            z: 1.1,
                        },
                        rotation: Quaternion {
                            x: 0.0,
                            y: 0.0,
                            z: 0.382_683_432_365_089_8,
                            w: 0.923_879_532_511_286_7,
                        },
                    },
                }],
            },
        )?;
        s.put(
            "/speech_command",
            t + 4_000,
            &RosString {
                data: ["teach", "done", "gripper close", "stop", "repeat"][k as usize % 5].into(),
            },
        )?;
        s.put(
            "/human/state",
            t + 5_000,
            &HumanState {
                header: header(t, "world"),
                mode: HumanState::MODE_INTERACTION,
                present: true,
                distance: 0.75 - 0.05 * kf,
                hand_position: Point {
                    x: 0.6,
                    y: 0.1 * kf,
                    z: 1.0,
                },
                hand_velocity: Vector3 {
                    x: -0.1,
                    y: 0.05,
                    z: 0.0,
                },
                speed_scale: 0.1,
                stopped: k == 3,
            },
        )?;
        s.put(
            "/human/skeleton",
            t + 6_000,
            &Skeleton {
                header: header(t, "world"),
                source: "xsens".into(),
                person_id: 7,
                segment_names: segments.iter().map(|n| (*n).to_owned()).collect(),
                poses: (0..segments.len())
                    .map(|i| Pose {
                        position: Point {
                            x: 1.5 - 0.01 * kf,
                            y: 0.02 * i as f64,
                            z: 0.9 + 0.05 * i as f64,
                        },
                        orientation: Quaternion {
                            w: 1.0,
                            ..Default::default()
                        },
                    })
                    .collect(),
                velocities: (0..segments.len())
                    .map(|i| Twist {
                        linear: Vector3 {
                            x: -0.3,
                            y: 0.0,
                            z: 0.001 * i as f64,
                        },
                        angular: Vector3::default(),
                    })
                    .collect(),
            },
        )?;
    }
    let summary = s.writer.finish()?;
    s.expect.flush()?;
    eprintln!(
        "wrote {} messages on {} topics to {}",
        summary.message_count,
        summary.channel_count,
        args.output.display()
    );
    Ok(())
}
