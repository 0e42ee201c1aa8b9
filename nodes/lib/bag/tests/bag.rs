//! Bag round trips, damaged files, wrong schemas and bad images.

use std::path::Path;

use cowork_bag::{BagError, BagReader, BagWriter, RawMessage, check_image};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState};
use cowork_msgs::std_msgs::{Header, String as RosString};
use cowork_msgs::{RosMessage, known_types, with_message_type};
use serde_json::Value;

type TestResult = anyhow::Result<()>;

/// Replaces every number, string and bool of a JSON value with a distinct deterministic value
/// (small enough for a u8), so a round trip can tell fields apart.
fn fill(v: &mut Value, counter: &mut u64) {
    match v {
        Value::Number(n) => {
            *counter += 1;
            let k = *counter % 100 + 1;
            *v = if n.is_f64() {
                serde_json::json!(k as f64 + 0.25)
            } else {
                serde_json::json!(k)
            };
        }
        Value::String(s) => {
            *counter += 1;
            *s = format!("s{counter}");
        }
        Value::Bool(b) => *b = true,
        Value::Array(a) => a.iter_mut().for_each(|x| fill(x, counter)),
        Value::Object(o) => o.values_mut().for_each(|x| fill(x, counter)),
        Value::Null => {}
    }
}

fn sample<T: RosMessage>(seed: u64) -> anyhow::Result<T> {
    let mut json = serde_json::to_value(T::default())?;
    let mut counter = seed;
    fill(&mut json, &mut counter);
    Ok(serde_json::from_value(json)?)
}

fn write_one<T: RosMessage>(w: &mut BagWriter, i: u64) -> anyhow::Result<Value> {
    let topic = format!("/t{i}");
    let ch = w.add_channel::<T>(&topic)?;
    let msg: T = sample(i)?;
    w.write(ch, 1_000 + i, 2_000 + i, &msg)?;
    Ok(serde_json::to_value(msg)?)
}

fn decode_as<T: RosMessage>(m: &RawMessage) -> anyhow::Result<Value> {
    Ok(serde_json::to_value(m.decode::<T>()?)?)
}

#[test]
fn every_known_type_round_trips_through_a_bag() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("all.mcap");
    let mut w = BagWriter::create(&path)?;
    let mut expected = Vec::new();
    for (i, info) in known_types().iter().enumerate() {
        let name = info.type_name();
        let written = with_message_type!(name.as_str(), T => write_one::<T>(&mut w, i as u64))
            .ok_or_else(|| anyhow::anyhow!("{name} not dispatchable"))??;
        expected.push((name, written));
    }
    let summary = w.finish()?;
    assert_eq!(summary.message_count, known_types().len() as u64);

    let reader = BagReader::open(&path)?;
    let info = reader.info();
    assert!(info.from_summary);
    assert_eq!(info.profile, "ros2");
    assert_eq!(info.message_count, expected.len() as u64);
    assert_eq!(info.topics.len(), expected.len());
    let mut n = 0;
    for (m, (name, written)) in reader.messages().zip(&expected) {
        let m = m?;
        assert_eq!(&*m.type_name, name);
        assert_eq!(m.channel.schema_encoding, "ros2msg");
        assert_eq!(m.channel.message_encoding, "cdr");
        assert_eq!(&m.data[..4], &[0, 1, 0, 0]);
        assert!(m.channel.schema_mismatch.is_none(), "{name}");
        let typed = with_message_type!(name.as_str(), T => decode_as::<T>(&m))
            .ok_or_else(|| anyhow::anyhow!("{name}"))??;
        assert_eq!(&typed, written, "{name}");
        assert_eq!(&m.decode_json()?, written, "{name}");
        assert_eq!(m.publish_time_ns, m.log_time_ns + 1_000);
        n += 1;
    }
    assert_eq!(n, expected.len());
    Ok(())
}

fn depth_image(stamp_ns: u64, width: u32, height: u32) -> Image {
    // Depth in m with pseudo-random noise (LCG), so chunks do not compress to nothing.
    let mut state = stamp_ns
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1);
    let data: Vec<u8> = (0..width * height)
        .flat_map(|_| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (1.0 + (state >> 40) as f32 * 1e-7).to_le_bytes()
        })
        .collect();
    Image {
        header: Header {
            stamp: Time {
                sec: (stamp_ns / 1_000_000_000) as i32,
                nanosec: (stamp_ns % 1_000_000_000) as u32,
            },
            frame_id: "camera_depth_optical_frame".into(),
        },
        height,
        width,
        encoding: "32FC1".into(),
        is_bigendian: 0,
        step: width * 4,
        data,
    }
}

/// A bag of `n` 320×240 depth frames (300 KiB each, several chunks) and joint states.
fn write_depth_bag(path: &Path, n: u64) -> anyhow::Result<Vec<(u64, Image)>> {
    let mut w = BagWriter::create(path)?;
    let img = w.add_channel::<Image>("/camera/depth/image_raw")?;
    let js = w.add_channel::<JointState>("/joint_states")?;
    let mut images = Vec::new();
    for k in 0..n {
        let t = 1_000_000_000 + k * 33_333_333;
        let image = depth_image(t, 320, 240);
        w.write(img, t, t, &image)?;
        let state = JointState {
            name: vec!["a1".into(), "a2".into()],
            position: vec![k as f64 * 0.1, -0.2],
            ..Default::default()
        };
        w.write(js, t + 1, t + 1, &state)?;
        images.push((t, image));
    }
    w.finish()?;
    Ok(images)
}

#[test]
fn messages_come_in_log_time_order_with_info_figures() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("order.mcap");
    let mut w = BagWriter::create(&path)?;
    let a = w.add_channel::<RosString>("/speech_command")?;
    let b = w.add_channel::<CameraInfo>("/camera/depth/camera_info")?;
    assert_eq!(w.add_channel::<RosString>("/speech_command")?, a);
    assert!(matches!(
        w.add_channel::<JointState>("/speech_command"),
        Err(BagError::TopicTypeConflict { .. })
    ));
    assert!(matches!(
        w.write(a, 0, 0, &JointState::default()),
        Err(BagError::ChannelTypeMismatch { .. })
    ));
    for (t, word) in [
        (3_000_000_000u64, "done"),
        (1_000_000_000, "teach"),
        (2_500_000_000, "stop"),
    ] {
        w.write(a, t, t, &RosString { data: word.into() })?;
    }
    w.write(
        b,
        2_000_000_000,
        2_000_000_000,
        &CameraInfo {
            width: 640,
            height: 480,
            ..Default::default()
        },
    )?;
    w.finish()?;

    let reader = BagReader::open(&path)?;
    let times: Vec<u64> = reader
        .messages()
        .map(|m| m.map(|m| m.log_time_ns))
        .collect::<Result<_, _>>()?;
    assert_eq!(
        times,
        [1_000_000_000, 2_000_000_000, 2_500_000_000, 3_000_000_000]
    );
    let info = reader.info();
    assert_eq!(info.message_count, 4);
    assert_eq!(info.start_ns, Some(1_000_000_000));
    assert_eq!(info.end_ns, Some(3_000_000_000));
    assert!((info.duration_s - 2.0).abs() < 1e-12);
    let speech = info.topics.iter().find(|t| t.topic == "/speech_command");
    assert_eq!(
        speech.map(|t| (t.type_name.as_str(), t.message_count)),
        Some(("std_msgs/msg/String", 3))
    );
    let table = info.to_table();
    assert!(table.contains("/camera/depth/camera_info"), "{table}");
    assert!(table.contains("sensor_msgs/msg/CameraInfo"), "{table}");
    assert!(table.contains("duration: 2.000 s"), "{table}");
    let json = serde_json::to_value(&info)?;
    assert_eq!(json["message_count"], 4);
    Ok(())
}

#[test]
fn unknown_types_are_carried_through_untouched() -> TestResult {
    let dir = tempfile::tempdir()?;
    let src = dir.path().join("src.mcap");
    let definition = "float64 level\nstring unit\n";
    let payload: Vec<u8> = vec![
        0, 1, 0, 0, 7, 7, 7, 7, 1, 2, 3, 4, 5, 6, 7, 8, 2, 0, 0, 0, 109, 0,
    ];
    let mut w = BagWriter::create(&src)?;
    w.write_raw("/tank", "acme_msgs/msg/Level", definition, 10, 9, &payload)?;
    w.write_raw("/tank", "acme_msgs/msg/Level", definition, 20, 19, &payload)?;
    assert!(matches!(
        w.write_raw(
            "/tank",
            "acme_msgs/msg/Level",
            "float32 level\n",
            30,
            30,
            &payload
        ),
        Err(BagError::TopicTypeConflict { .. })
    ));
    w.finish()?;

    // Copy through a second bag, as replay + record would.
    let dst = dir.path().join("dst.mcap");
    let mut w = BagWriter::create(&dst)?;
    for m in BagReader::open(&src)?.messages() {
        let m = m?;
        assert!(matches!(m.decode_json(), Err(BagError::UnknownType { .. })));
        w.write_raw(
            &m.topic,
            &m.type_name,
            &m.channel.definition,
            m.log_time_ns,
            m.publish_time_ns,
            &m.data,
        )?;
    }
    w.finish()?;
    let out: Vec<RawMessage> = BagReader::open(&dst)?
        .messages()
        .collect::<Result<_, _>>()?;
    assert_eq!(out.len(), 2);
    for (m, t) in out.iter().zip([10u64, 20]) {
        assert_eq!(m.data, payload);
        assert_eq!(&*m.type_name, "acme_msgs/msg/Level");
        assert_eq!(&*m.channel.definition, definition);
        assert_eq!((m.log_time_ns, m.publish_time_ns), (t, t - 1));
    }
    let info = BagReader::open(&dst)?.info();
    assert!(info.to_table().contains("unknown type"));
    Ok(())
}

#[test]
fn truncated_file_is_refused_with_offset_and_recovered_up_to_the_damage() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("full.mcap");
    let images = write_depth_bag(&path, 24)?;
    let bytes = std::fs::read(&path)?;
    let total = BagReader::open(&path)?.messages().count();
    assert_eq!(total, 48);

    let mut recovered_counts = Vec::new();
    for fraction in [0.4, 0.7, 0.95] {
        let cut = (bytes.len() as f64 * fraction) as usize;
        let cut_path = dir.path().join(format!("cut{cut}.mcap"));
        std::fs::write(&cut_path, &bytes[..cut])?;
        let err = BagReader::open(&cut_path)
            .err()
            .ok_or_else(|| anyhow::anyhow!("cut file opened"))?;
        let text = err.to_string();
        assert!(matches!(err, BagError::Truncated { .. }), "{text}");
        assert!(text.contains(&cut_path.display().to_string()), "{text}");
        assert!(text.contains("byte offset"), "{text}");

        let reader = BagReader::open_recoverable(&cut_path)?;
        assert!(reader.damage().is_some());
        let mut n_images = 0;
        let mut n = 0;
        for m in reader.messages() {
            let m = m?;
            if let Ok(image) = m.decode::<Image>() {
                let (t, original) = &images[n_images];
                assert_eq!((m.log_time_ns, &image), (*t, original));
                n_images += 1;
            }
            n += 1;
        }
        assert!(n > 0 && n < total, "fraction {fraction}: {n} of {total}");
        let info = reader.info();
        assert_eq!(info.message_count, n as u64);
        assert!(!info.from_summary);
        assert!(info.to_table().contains("DAMAGED"));
        recovered_counts.push(n);
    }
    assert!(
        recovered_counts.windows(2).all(|w| w[0] <= w[1]),
        "{recovered_counts:?}"
    );
    Ok(())
}

#[test]
fn corrupt_chunk_is_reported_and_reading_goes_on() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("good.mcap");
    write_depth_bag(&path, 24)?;
    let mut bytes = std::fs::read(&path)?;
    // Damage the middle of the file (inside a compressed chunk), leaving lengths intact.
    let mid = bytes.len() / 2;
    for b in &mut bytes[mid..mid + 64] {
        *b ^= 0x5a;
    }
    let bad = dir.path().join("bad.mcap");
    std::fs::write(&bad, &bytes)?;
    let reader = BagReader::open_recoverable(&bad)?;
    let (mut ok, mut errors, mut ok_after_error) = (0, Vec::new(), 0);
    for m in reader.messages() {
        match m {
            Ok(m) => {
                if &*m.topic == "/camera/depth/image_raw" {
                    check_image(&m.topic, &m.decode::<Image>()?)?;
                }
                ok += 1;
                if !errors.is_empty() {
                    ok_after_error += 1;
                }
            }
            Err(e) => errors.push(e.to_string()),
        }
    }
    // The chunks after the damaged one are still read (channels from the summary).
    assert!(ok_after_error > 0, "nothing read after the damage");
    assert!(!errors.is_empty(), "no damage reported");
    assert!(
        errors[0].contains("corrupt record at byte offset"),
        "{errors:?}"
    );
    assert!(errors[0].contains("bad.mcap"), "{errors:?}");
    assert!(ok > 0 && ok < 48, "{ok}");

    // Garbage that is not MCAP at all.
    let junk = dir.path().join("junk.mcap");
    std::fs::write(&junk, b"not an mcap file at all")?;
    assert!(matches!(
        BagReader::open(&junk),
        Err(BagError::NotMcap { .. })
    ));
    assert!(matches!(
        BagReader::open(dir.path().join("missing.mcap")),
        Err(BagError::Io { .. })
    ));

    // A rosbag2 directory in sqlite3 storage (`ros2 bag record` before Iron), with and without
    // its metadata.yaml, and the .db3 file itself: named as such, not "not an MCAP file".
    let db = dir.path().join("run_sqlite");
    std::fs::create_dir(&db)?;
    std::fs::write(db.join("run_sqlite_0.db3"), b"SQLite format 3\0 and pages")?;
    for target in [db.clone(), db.join("run_sqlite_0.db3")] {
        let e = BagReader::open(&target).expect_err("sqlite3");
        assert!(e.to_string().contains("sqlite3 storage is not supported"), "{e}");
    }
    std::fs::write(
        db.join("metadata.yaml"),
        "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n  relative_file_paths: [run_sqlite_0.db3]\n",
    )?;
    let e = BagReader::open(&db).expect_err("sqlite3");
    assert!(matches!(&e, BagError::UnsupportedStorage { storage, .. } if storage == "sqlite3"), "{e}");
    Ok(())
}

/// A chunk header whose `uncompressed_size` was damaged (found by the reliability fuzzer: the
/// decompressor allocated 7.6 EB and the process aborted) is a per-chunk error; later chunks
/// are still read.
#[test]
fn chunk_declaring_an_absurd_size_is_refused_without_allocating_it() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("good.mcap");
    write_depth_bag(&path, 24)?;
    let mut bytes = std::fs::read(&path)?;
    // Walk the top-level records (opcode u8, length u64) to the first chunk (opcode 0x06):
    // message_start_time u64, message_end_time u64, then uncompressed_size u64.
    let mut at = 8;
    while bytes[at] != 0x06 {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into()?);
        at += 9 + usize::try_from(len)?;
    }
    let size_at = at + 9 + 16;
    bytes[size_at..size_at + 8].copy_from_slice(&0x6a73_6f6e_2d74_6f6fu64.to_le_bytes());
    let bad = dir.path().join("huge-chunk.mcap");
    std::fs::write(&bad, &bytes)?;
    let reader = BagReader::open_recoverable(&bad)?;
    let (mut ok, mut errors) = (0, Vec::new());
    for m in reader.messages() {
        match m {
            Ok(_) => ok += 1,
            Err(e) => errors.push(e.to_string()),
        }
    }
    assert!(errors.iter().any(|e| e.contains("declares") && e.contains("huge-chunk.mcap")), "{errors:?}");
    assert!(ok > 0, "the chunks after the damaged one are read");
    Ok(())
}

#[test]
fn wrong_schema_or_payload_for_a_known_type_is_a_per_message_error() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("schema.mcap");
    let image = depth_image(5, 4, 2);
    let good = cowork_msgs::to_cdr(&image);
    let mut w = BagWriter::create(&path)?;
    // An Image schema whose width is uint16: not ours.
    let wrong = Image::ros2msg_definition().replace("uint32 width", "uint16 width");
    w.write_raw(
        "/camera/wrong_schema",
        "sensor_msgs/msg/Image",
        &wrong,
        1_000,
        1_000,
        &good,
    )?;
    // Our schema but a payload cut short.
    let ours = Image::ros2msg_definition();
    w.write_raw(
        "/camera/short_payload",
        "sensor_msgs/msg/Image",
        &ours,
        2_000,
        2_000,
        &good[..20],
    )?;
    let ch = w.add_channel::<Image>("/camera/depth/image_raw")?;
    w.write(ch, 3_000, 3_000, &image)?;
    w.finish()?;

    let reader = BagReader::open(&path)?;
    let results: Vec<_> = reader
        .messages()
        .map(|m| m.map(|m| (m.topic.to_string(), m.decode::<Image>())))
        .collect::<Result<_, _>>()?;
    assert_eq!(results.len(), 3);
    let e0 = results[0]
        .1
        .as_ref()
        .err()
        .map(ToString::to_string)
        .unwrap_or_default();
    assert!(
        e0.contains("/camera/wrong_schema")
            && e0.contains("1000 ns")
            && e0.contains("uint16 width"),
        "{e0}"
    );
    let e1 = results[1]
        .1
        .as_ref()
        .err()
        .map(ToString::to_string)
        .unwrap_or_default();
    assert!(
        e1.contains("/camera/short_payload") && e1.contains("2000 ns"),
        "{e1}"
    );
    assert_eq!(results[2].1.as_ref().ok(), Some(&image));
    // Asking for another type is an error too, not a misread.
    let first = reader
        .messages()
        .next()
        .ok_or_else(|| anyhow::anyhow!("empty"))??;
    assert!(matches!(
        first.decode::<JointState>(),
        Err(BagError::TypeMismatch { .. })
    ));
    let info = reader.info();
    let wrong_topic = info
        .topics
        .iter()
        .find(|t| t.topic == "/camera/wrong_schema");
    assert!(wrong_topic.is_some_and(|t| t.schema_mismatch.is_some()));
    Ok(())
}

#[test]
fn bad_images_are_named_by_topic() {
    let good = depth_image(0, 8, 4);
    assert!(check_image("/d", &good).is_ok());
    let mut mm = good.clone();
    mm.encoding = "16UC1".into();
    mm.step = 16;
    mm.data.truncate(16 * 4);
    assert!(check_image("/d", &mm).is_ok());

    let mut short = good.clone();
    short.data.pop();
    let e = check_image("/camera/depth/image_raw", &short)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        e.contains("/camera/depth/image_raw") && e.contains("step 32 × height 4 = 128"),
        "{e}"
    );

    let mut enc = good.clone();
    enc.encoding = "yuv422_weird".into();
    let e = check_image("/cam", &enc)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        e.contains("/cam") && e.contains("yuv422_weird") && e.contains("32FC1"),
        "{e}"
    );

    let mut step = good;
    step.step = 16;
    step.data.truncate(16 * 4);
    let e = check_image("/cam", &step)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(e.contains("step 16 B is less than width 8"), "{e}");
}

#[test]
fn overlapping_chunks_are_merged_into_log_time_order() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("overlap.mcap");
    let mut w = BagWriter::create(&path)?;
    let img = w.add_channel::<Image>("/camera/depth/image_raw")?;
    let speech = w.add_channel::<RosString>("/speech_command")?;
    // A 1.2 MB frame fills a chunk, so the earlier-stamped messages after it land in later
    // chunks whose time ranges overlap the first one's.
    w.write(img, 2_000, 2_000, &depth_image(2_000, 640, 480))?;
    w.write(
        speech,
        1_000,
        1_000,
        &RosString {
            data: "teach".into(),
        },
    )?;
    w.write(img, 4_000, 4_000, &depth_image(4_000, 640, 480))?;
    w.write(
        speech,
        3_000,
        3_000,
        &RosString {
            data: "done".into(),
        },
    )?;
    w.write(
        speech,
        1_500,
        1_500,
        &RosString {
            data: "stop".into(),
        },
    )?;
    w.finish()?;
    let times: Vec<u64> = BagReader::open(&path)?
        .messages()
        .map(|m| m.map(|m| m.log_time_ns))
        .collect::<Result<_, _>>()?;
    assert_eq!(times, [1_000, 1_500, 2_000, 3_000, 4_000]);
    Ok(())
}

/// A rosbag2 directory (metadata.yaml + one MCAP file, as `ros2 bag record` and `rosbags`
/// write it) opens as its storage file; an empty or split directory is refused, naming why.
#[test]
fn rosbag2_directories_open_their_storage_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bag_dir = dir.path().join("run");
    std::fs::create_dir(&bag_dir).expect("bag dir");
    let empty = cowork_bag::BagReader::open(&bag_dir).expect_err("empty directory");
    assert!(empty.to_string().contains("no .mcap storage file"), "{empty}");
    let file = bag_dir.join("run_0.mcap");
    let mut w = cowork_bag::BagWriter::create(&file).expect("create");
    let ch = w.add_channel::<cowork_msgs::std_msgs::String>("/speech_command").expect("channel");
    w.write(ch, 1_000, 1_000, &cowork_msgs::std_msgs::String { data: "teach".into() }).expect("write");
    w.finish().expect("finish");
    std::fs::write(
        bag_dir.join("metadata.yaml"),
        "rosbag2_bagfile_information:\n  version: 8\n  storage_identifier: mcap\n  relative_file_paths:\n    - run_0.mcap\n",
    )
    .expect("metadata");
    let reader = cowork_bag::BagReader::open(&bag_dir).expect("directory opens");
    assert_eq!(reader.path(), file.as_path());
    assert_eq!(reader.info().message_count, 1);
    std::fs::copy(&file, bag_dir.join("run_1.mcap")).expect("second file");
    std::fs::write(
        bag_dir.join("metadata.yaml"),
        "rosbag2_bagfile_information:\n  relative_file_paths: [run_0.mcap, run_1.mcap]\n",
    )
    .expect("metadata");
    let split = cowork_bag::BagReader::open(&bag_dir).expect_err("split bag");
    assert!(split.to_string().contains("2 storage files (run_0.mcap, run_1.mcap)"), "{split}");
}

/// A writer that fails (dropped without `finish`) leaves the bag that was at its path as it
/// was, and a new path uncreated: a failed command never destroys or half-writes a bag.
#[test]
fn a_writer_dropped_without_finish_leaves_the_old_bag_untouched() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("run.mcap");
    let mut w = BagWriter::create(&path)?;
    let ch = w.add_channel::<JointState>("/joint_states")?;
    w.write(ch, 1, 1, &JointState::default())?;
    w.finish()?;
    let before = std::fs::read(&path)?;
    let mut w = BagWriter::create(&path)?;
    let ch = w.add_channel::<JointState>("/other")?;
    w.write(ch, 2, 2, &JointState::default())?;
    drop(w);
    assert_eq!(std::fs::read(&path)?, before, "the old bag is untouched");
    assert_eq!(std::fs::read_dir(dir.path())?.count(), 1, "no temporary left");
    let fresh = dir.path().join("fresh.mcap");
    drop(BagWriter::create(&fresh)?);
    assert!(!fresh.exists());
    Ok(())
}

/// A recorder killed mid-recording (`kill -9`: the writer never finishes, its buffered bytes
/// never reach the file; here the writer is leaked) loses at most the open chunk, which the
/// time bound keeps within [`cowork_bag::DEFAULT_CHUNK_SPAN_S`] of log time; by size alone a
/// small stream loses everything.
#[test]
fn a_writer_killed_mid_recording_loses_at_most_the_last_second() -> TestResult {
    let dir = tempfile::tempdir()?;
    let n = 5_500u64; // 5.5 s of 1 kHz joint states
    let write_then_die = |path: &Path, span: Option<f64>| -> anyhow::Result<(u64, std::path::PathBuf)> {
        let mut w = BagWriter::create(path)?;
        w.set_chunk_span(span)?;
        let ch = w.add_channel::<JointState>("/joint_states")?;
        for i in 0..n {
            let t = 1_000_000_000 + i * 1_000_000;
            let msg = JointState {
                header: Header { stamp: Time::from_nanos(t as i64), frame_id: "lwr_base_link".into() },
                name: vec!["lwr_a1_joint".into()],
                position: vec![i as f64],
                ..Default::default()
            };
            w.write(ch, t, t, &msg)?;
        }
        let flushes = w.flushes();
        let partial = w.partial_path().to_path_buf();
        std::mem::forget(w);
        assert!(!path.exists(), "an unfinished bag never appears at its path");
        Ok((flushes, partial))
    };
    let read = |path: &Path| -> u64 {
        BagReader::open_recoverable(path).map_or(0, |r| r.messages().filter(Result::is_ok).count() as u64)
    };
    let bounded = dir.path().join("bounded.mcap");
    let (flushes, partial) = write_then_die(&bounded, Some(cowork_bag::DEFAULT_CHUNK_SPAN_S))?;
    let kept = read(&partial);
    eprintln!("1 s chunks: {flushes} flushes, {kept} of {n} messages recovered after the kill");
    assert!(flushes >= 5, "{flushes}");
    assert!(n - kept <= 1_001, "lost {} of {n} messages (more than 1 s at 1 kHz)", n - kept);
    let unbounded = dir.path().join("by_size.mcap");
    let (_, partial) = write_then_die(&unbounded, None)?;
    let kept_by_size = read(&partial);
    eprintln!("chunks by size only: {kept_by_size} of {n} messages recovered after the kill");
    assert!(kept_by_size < kept, "{kept_by_size} vs {kept}");
    let mut w = BagWriter::create(dir.path().join("bad.mcap"))?;
    assert!(w.set_chunk_span(Some(f64::NAN)).is_err() && w.set_chunk_span(Some(0.0)).is_err());
    Ok(())
}
