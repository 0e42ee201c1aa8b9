//! Replay scheduling (`Player`): timing, rate, loop, start offset, topic filter, `/clock` ticks,
//! damaged files; per-message checks of bad input (`check_message`, `check_bag`).

use std::path::Path;
use std::time::Duration;

use cowork_bag::{
    BagError, BagReader, BagWriter, PlayItem, PlayOptions, Player, Rate, Verdict, check_bag,
    check_message,
};
use cowork_msgs::RosMessage;
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::rosgraph_msgs::Clock;
use cowork_msgs::sensor_msgs::{Image, JointState};
use cowork_msgs::std_msgs::{Header, String as RosString};

type TestResult = anyhow::Result<()>;

const S: u64 = 1_000_000_000;
const T0: u64 = 1_700_000_000 * S;

/// 10 joint states at 10 Hz (0.0 … 0.9 s) and 3 speech commands at 0.25, 0.5, 0.75 s.
fn write_bag(path: &Path) -> anyhow::Result<()> {
    let mut w = BagWriter::create(path)?;
    let js = w.add_channel::<JointState>("/joint_states")?;
    let sp = w.add_channel::<RosString>("/speech_command")?;
    for i in 0..10u64 {
        let t = T0 + i * S / 10;
        let msg = JointState {
            header: Header { stamp: Time::from_nanos(t as i64), frame_id: String::new() },
            name: vec!["j".into()],
            position: vec![i as f64],
            ..Default::default()
        };
        w.write(js, t, t, &msg)?;
    }
    for (i, word) in ["teach", "done", "stop"].iter().enumerate() {
        let t = T0 + (i as u64 + 1) * S / 4;
        w.write(sp, t, t, &RosString { data: (*word).into() })?;
    }
    w.finish()?;
    Ok(())
}

fn items(reader: &BagReader, options: PlayOptions, limit: usize) -> anyhow::Result<Vec<PlayItem>> {
    let player = Player::new(reader, options)?;
    let mut out = Vec::new();
    for item in player.take(limit) {
        out.push(item?);
    }
    Ok(out)
}

fn messages(items: &[PlayItem]) -> Vec<(String, u64, Duration)> {
    items
        .iter()
        .filter_map(|i| match i {
            PlayItem::Message { message, due, .. } => {
                Some((message.topic.to_string(), message.log_time_ns, *due))
            }
            PlayItem::Clock { .. } => None,
        })
        .collect()
}

#[test]
fn rate_one_keeps_the_original_timing_and_rate_two_halves_it() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("b.mcap");
    write_bag(&path)?;
    let reader = BagReader::open(&path)?;
    let no_clock = PlayOptions { clock_hz: 0.0, ..Default::default() };
    let one = messages(&items(&reader, no_clock.clone(), 1000)?);
    assert_eq!(one.len(), 13);
    for (_, t, due) in &one {
        assert_eq!(due.as_nanos() as u64, t - T0, "due = bag time since the first message");
    }
    assert!(one.windows(2).all(|w| w[0].2 <= w[1].2), "due order");
    let two = messages(&items(&reader, PlayOptions { rate: Rate::Factor(2.0), ..no_clock.clone() }, 1000)?);
    for ((_, _, d1), (_, _, d2)) in one.iter().zip(&two) {
        assert!(d1.abs_diff(*d2 * 2) <= Duration::from_nanos(2));
    }
    let max = messages(&items(&reader, PlayOptions { rate: Rate::Max, ..no_clock }, 1000)?);
    assert_eq!(max.len(), 13);
    assert!(max.iter().all(|(_, _, d)| d.is_zero()));
    Ok(())
}

#[test]
fn topic_filter_and_start_offset_select_messages() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("b.mcap");
    write_bag(&path)?;
    let reader = BagReader::open(&path)?;
    let opts = PlayOptions {
        topics: vec!["/speech_command".into()],
        start_offset_s: 0.3,
        clock_hz: 0.0,
        ..Default::default()
    };
    let player = Player::new(&reader, opts.clone())?;
    assert_eq!(player.messages_per_pass(), 3);
    let got = messages(&items(&reader, opts, 1000)?);
    let times: Vec<u64> = got.iter().map(|m| m.1 - T0).collect();
    assert_eq!(times, vec![S / 2, 3 * S / 4]);
    assert!(got.iter().all(|m| m.0 == "/speech_command"));
    // The offset is the new origin: the first message after it is due 0.2 s in.
    assert_eq!(got[0].2, Duration::from_millis(200));

    let err = Player::new(&reader, PlayOptions { topics: vec!["/nope".into()], ..Default::default() })
        .expect_err("unknown topic");
    assert!(matches!(err, BagError::UnknownTopic { .. }));
    assert!(err.to_string().contains("/joint_states"), "{err}");
    Ok(())
}

#[test]
fn loop_replays_the_bag_again_after_one_mean_interval() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("b.mcap");
    write_bag(&path)?;
    let reader = BagReader::open(&path)?;
    let opts = PlayOptions { looped: true, clock_hz: 0.0, ..Default::default() };
    let all = items(&reader, opts, 13 * 3)?;
    assert_eq!(all.len(), 39, "a looped player never ends");
    let passes: Vec<u32> = all
        .iter()
        .filter_map(|i| match i {
            PlayItem::Message { pass, .. } => Some(*pass),
            PlayItem::Clock { .. } => None,
        })
        .collect();
    assert_eq!(passes[12], 0);
    assert_eq!(passes[13], 1);
    assert_eq!(passes[38], 2);
    let m = messages(&all);
    // Span 0.9 s over 13 messages: gap 75 ms, so pass 1 starts at 0.975 s.
    assert_eq!(m[13].1, m[0].1, "same bag time again");
    assert_eq!(m[13].2, Duration::from_millis(975));
    assert!(m.windows(2).all(|w| w[0].2 <= w[1].2), "due order across passes");
    Ok(())
}

#[test]
fn clock_ticks_are_generated_at_the_asked_rate_unless_the_bag_has_a_clock() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("b.mcap");
    write_bag(&path)?;
    let reader = BagReader::open(&path)?;
    let all = items(&reader, PlayOptions { clock_hz: 100.0, ..Default::default() }, 10_000)?;
    let ticks: Vec<(u64, Duration)> = all
        .iter()
        .filter_map(|i| match i {
            PlayItem::Clock { time_ns, due } => Some((*time_ns, *due)),
            PlayItem::Message { .. } => None,
        })
        .collect();
    // 0.00 … 0.90 s at 10 ms: 91 ticks, each due at its bag time, before the messages at it.
    assert_eq!(ticks.len(), 91);
    for (k, (t, due)) in ticks.iter().enumerate() {
        assert_eq!(*t, T0 + k as u64 * S / 100);
        assert_eq!(due.as_nanos() as u64, t - T0);
    }
    assert!(matches!(all[0], PlayItem::Clock { .. }));
    assert!(all.windows(2).all(|w| w[0].due() <= w[1].due()));

    // --max: at most one tick per message.
    let max = items(&reader, PlayOptions { rate: Rate::Max, ..Default::default() }, 10_000)?;
    let n_ticks = max.iter().filter(|i| matches!(i, PlayItem::Clock { .. })).count();
    assert!((1..=13).contains(&n_ticks), "{n_ticks}");

    // A bag with its own /clock: no generated ticks, the bag's /clock is replayed.
    let path2 = dir.path().join("clock.mcap");
    let mut w = BagWriter::create(&path2)?;
    let c = w.add_channel::<Clock>("/clock")?;
    for i in 0..5u64 {
        let t = T0 + i * S / 100;
        w.write(c, t, t, &Clock { clock: Time::from_nanos(t as i64) })?;
    }
    w.finish()?;
    let reader2 = BagReader::open(&path2)?;
    let p = Player::new(&reader2, PlayOptions::default())?;
    assert!(!p.generates_clock());
    let got = items(&reader2, PlayOptions::default(), 100)?;
    assert_eq!(got.len(), 5);
    assert!(got.iter().all(|i| matches!(i, PlayItem::Message { .. })));
    Ok(())
}

#[test]
fn a_truncated_bag_replays_its_readable_part_and_names_the_damage() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("big.mcap");
    // Enough image data for several chunks.
    let mut w = BagWriter::create(&path)?;
    let ch = w.add_channel::<Image>("/camera/depth/image_raw")?;
    for i in 0..40u64 {
        let t = T0 + i * S / 30;
        let data: Vec<u8> = (0..640 * 480 * 4).map(|k| ((k as u64 * 2654435761 + i) >> 7) as u8).collect();
        let img = Image {
            header: Header { stamp: Time::from_nanos(t as i64), frame_id: "camera".into() },
            height: 480,
            width: 640,
            encoding: "32FC1".into(),
            is_bigendian: 0,
            step: 640 * 4,
            data,
        };
        w.write(ch, t, t, &img)?;
    }
    w.finish()?;
    let bytes = std::fs::read(&path)?;
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2])?;

    let err = BagReader::open(&cut).expect_err("truncated");
    assert!(matches!(err, BagError::Truncated { .. }), "{err}");
    let reader = BagReader::open_recoverable(&cut)?;
    let damage = reader.damage().map(ToString::to_string).unwrap_or_default();
    assert!(damage.contains("cut.mcap") && damage.contains("byte offset"), "{damage}");
    let got = items(&reader, PlayOptions { clock_hz: 0.0, ..Default::default() }, 1000)?;
    let n = got.len();
    assert!(n > 5 && n < 40, "replayed {n} of 40 frames");
    // Every replayed frame is intact and in order.
    for (k, item) in got.iter().enumerate() {
        let PlayItem::Message { message, .. } = item else { unreachable!("no clock asked") };
        assert_eq!(message.log_time_ns, T0 + k as u64 * S / 30);
        assert_eq!(check_message(message)?, Verdict::Valid);
    }
    Ok(())
}

#[test]
fn bad_input_is_named_per_topic_by_the_checks() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("bad.mcap");
    let mut w = BagWriter::create(&path)?;
    // /joint_states labelled std_msgs/String (a valid String, but not what the graph expects).
    let js = w.add_channel::<RosString>("/joint_states")?;
    w.write(js, T0, T0, &RosString { data: "not a joint state".into() })?;
    // An image whose data is one row short, and one with an unknown encoding.
    let img = w.add_channel::<Image>("/camera/depth/image_raw")?;
    let good = Image { height: 2, width: 3, encoding: "16UC1".into(), step: 6, data: vec![0; 12], ..Default::default() };
    w.write(img, T0 + 1, T0 + 1, &good)?;
    w.write(img, T0 + 2, T0 + 2, &Image { data: vec![0; 6], ..good.clone() })?;
    let odd = w.add_channel::<Image>("/camera/rgb")?;
    w.write(odd, T0 + 3, T0 + 3, &Image { encoding: "yuv422_weird".into(), ..good.clone() })?;
    // A known type whose schema in the bag has other fields.
    w.write_raw(
        "/speech_command",
        "std_msgs/msg/String",
        "int32 data\n",
        T0 + 4,
        T0 + 4,
        &cowork_msgs::to_cdr(&RosString { data: "x".into() }),
    )?;
    // A known type whose payload does not decode.
    w.write_raw(
        "/lwr/gripper_command",
        "std_msgs/msg/String",
        &RosString::ros2msg_definition(),
        T0 + 5,
        T0 + 5,
        &[0, 1, 0, 0, 0xff, 0xff, 0xff, 0x7f],
    )?;
    // A type we do not know: carried, not checked.
    w.write_raw("/other", "acme_msgs/msg/Thing", "uint8 x\n", T0 + 6, T0 + 6, &[0, 1, 0, 0, 7])?;
    w.finish()?;

    let reader = BagReader::open(&path)?;
    let checks = check_bag(&reader);
    let by = |t: &str| checks.iter().find(|c| c.topic == t).cloned().unwrap_or_default();
    let js = by("/joint_states");
    assert_eq!((js.messages, js.bad), (1, 1));
    let e = js.first_error.unwrap_or_default();
    assert!(e.contains("/joint_states") && e.contains("sensor_msgs/msg/JointState"), "{e}");
    let im = by("/camera/depth/image_raw");
    assert_eq!((im.messages, im.bad), (2, 1));
    let e = im.first_error.unwrap_or_default();
    assert!(e.contains("expected step 6 × height 2 = 12 B"), "{e}");
    let e = by("/camera/rgb").first_error.unwrap_or_default();
    assert!(e.contains("yuv422_weird"), "{e}");
    let e = by("/speech_command").first_error.unwrap_or_default();
    assert!(e.contains("schema") && e.contains("int32 data"), "{e}");
    let g = by("/lwr/gripper_command");
    assert_eq!(g.bad, 1, "{g:?}");
    let o = by("/other");
    assert!(o.unknown_type && o.bad == 0);

    // The player still yields every message: what to do with the bad ones is the caller's.
    let all = items(&reader, PlayOptions { rate: Rate::Max, clock_hz: 0.0, ..Default::default() }, 100)?;
    assert_eq!(all.len(), 7);
    Ok(())
}
