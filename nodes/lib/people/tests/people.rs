//! Crate tests of cowork_people: rigid segments, velocities, determinism, sampling rates,
//! message shape, motions reaching their goals, capsules, bad input.

use cowork_msgs::msg::Skeleton;
use cowork_people::{
    Action, BodySize, GestureKind, GestureSet, GestureSetConfig, GestureStyle, Performer, Room, Sampler, Segment,
    SensorConfig, Side, SkeletonPose, SpanKind, Stance, Timeline, body_capsules, BODY_CAPSULE_COUNT, MessageMeta,
};
use nalgebra::{Point2, Point3, UnitQuaternion, Vector3};

fn visit(body: BodySize, seed: u64) -> Performer {
    let room = Room::default();
    room.visit(1, body, seed, Point3::new(0.35, -0.45, 0.35), (Point3::new(0.1, -0.55, 0.2), Point3::new(0.75, -0.55, 0.2)))
        .expect("visit")
}

fn with_all_gestures(body: BodySize, seed: u64) -> Performer {
    let mut p = Performer::new(3, body, Stance::new(0.2, -1.2, 1.4), seed).expect("performer");
    for kind in GestureKind::ALL {
        p.push(Action::Stand { duration: 0.5 }).expect("stand");
        p.push(Action::Gesture { kind, style: GestureStyle::default() }).expect("gesture");
    }
    p
}

fn timeline(p: Performer) -> Timeline {
    let mut t = Timeline::new();
    t.add(0.0, p).expect("add");
    t
}

fn pos(m: &Skeleton, s: Segment) -> Point3<f64> {
    let p = &m.poses[s.index()].position;
    Point3::new(p.x, p.y, p.z)
}

/// Point pairs on one rigid body (the head moves on the neck, so sternum–head is not one).
const BONES: [(Segment, Segment); 9] = [
    (Segment::Pelvis, Segment::Sternum),
    (Segment::Sternum, Segment::RightShoulder),
    (Segment::RightShoulder, Segment::LeftShoulder),
    (Segment::RightShoulder, Segment::RightElbow),
    (Segment::RightElbow, Segment::RightWrist),
    (Segment::RightWrist, Segment::RightHand),
    (Segment::LeftShoulder, Segment::LeftElbow),
    (Segment::LeftElbow, Segment::LeftWrist),
    (Segment::LeftWrist, Segment::LeftHand),
];

fn bone_lengths(msgs: &[Skeleton]) -> Vec<Vec<f64>> {
    BONES.iter().map(|(a, b)| msgs.iter().map(|m| (pos(m, *a) - pos(m, *b)).norm()).collect()).collect()
}

fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (m, (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n).sqrt())
}

#[test]
fn segments_are_rigid_across_every_motion() {
    for body in BodySize::presets() {
        for p in [visit(body, 3), with_all_gestures(body, 4)] {
            let tl = timeline(p);
            let clean: Vec<Skeleton> = Sampler::new(&tl, SensorConfig::xsens().noiseless(), 1).expect("sampler").collect();
            for (k, lens) in bone_lengths(&clean).iter().enumerate() {
                let (lo, hi) = lens.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
                assert!(hi - lo < 1e-9, "bone {k} of {} m varies by {} m", body.height, hi - lo);
            }
            // With Xsens noise (4 mm per axis) a bone length spreads by about 4·√2 mm.
            let noisy: Vec<Skeleton> = Sampler::new(&tl, SensorConfig::xsens(), 1).expect("sampler").collect();
            for (k, (lens, clean_lens)) in bone_lengths(&noisy).iter().zip(bone_lengths(&clean)).enumerate() {
                let (m, s) = mean_std(lens);
                assert!((m - clean_lens[0]).abs() < 0.002, "bone {k}: mean {m} vs {}", clean_lens[0]);
                assert!(s < 0.008 && s > 0.003, "bone {k}: std {s}");
            }
        }
    }
}

#[test]
fn segment_lengths_follow_the_body_size() {
    for body in BodySize::presets() {
        let p = Performer::new(1, body, Stance::new(0.0, -1.2, 0.0), 1).expect("performer").pose(0.3);
        let l = body.lengths();
        let d = |a, b| (p.position(a) - p.position(b)).norm();
        assert!((d(Segment::RightShoulder, Segment::RightElbow) - 0.186 * body.height).abs() < 1e-9);
        assert!((d(Segment::LeftElbow, Segment::LeftWrist) - 0.146 * body.height).abs() < 1e-9);
        assert!((d(Segment::RightWrist, Segment::RightHand) - 0.5 * l.hand).abs() < 1e-9);
        // Standing: head near 0.935 H above the floor, pelvis near the hip height.
        let head = p.position(Segment::Head).z - p.floor_z;
        assert!((head - 0.935 * body.height).abs() < 0.03, "head at {head} for {}", body.height);
    }
}

#[test]
fn velocities_match_finite_differences() {
    let p = with_all_gestures(BodySize::MEDIUM, 5);
    let q = visit(BodySize::SMALL, 6);
    for perf in [&p, &q] {
        let dt = 1e-3;
        let mut worst_lin: f64 = 0.0;
        let mut worst_ang: f64 = 0.0;
        let mut peak_lin: f64 = 0.0;
        let steps = (perf.duration() / 0.05) as usize;
        for k in 1..steps {
            let t = k as f64 * 0.05;
            let (a, b, c) = (perf.pose(t - dt), perf.pose(t), perf.pose(t + dt));
            for s in Segment::ALL {
                let v = (c.position(s) - a.position(s)) / (2.0 * dt);
                let st = b.segment(s);
                worst_lin = worst_lin.max((v - st.linear_velocity).norm());
                peak_lin = peak_lin.max(v.norm());
                let w = (c.segment(s).orientation * a.segment(s).orientation.inverse()).scaled_axis() / (2.0 * dt);
                worst_ang = worst_ang.max((w - st.angular_velocity).norm());
            }
        }
        assert!(peak_lin > 0.5, "motion too slow to test: {peak_lin}");
        assert!(worst_lin < 0.02, "linear velocity off by {worst_lin} m/s");
        assert!(worst_ang < 0.1, "angular velocity off by {worst_ang} rad/s");
    }
}

#[test]
fn same_seed_same_messages_other_seed_other_noise() {
    let tl = timeline(visit(BodySize::MEDIUM, 9));
    let a: Vec<Skeleton> = Sampler::new(&tl, SensorConfig::depth_tracker(), 11).expect("s").collect();
    let b: Vec<Skeleton> = Sampler::new(&tl, SensorConfig::depth_tracker(), 11).expect("s").collect();
    let c: Vec<Skeleton> = Sampler::new(&tl, SensorConfig::depth_tracker(), 12).expect("s").collect();
    assert_eq!(a, b);
    assert_ne!(a, c);
    // Another sway seed moves the person differently.
    let d: Vec<Skeleton> = Sampler::new(&timeline(visit(BodySize::MEDIUM, 10)), SensorConfig::depth_tracker(), 11).expect("s").collect();
    assert_ne!(a.first().map(|m| &m.poses), d.first().map(|m| &m.poses));
}

#[test]
fn xsens_120_hz_and_depth_tracker_30_hz() {
    let tl = timeline(with_all_gestures(BodySize::TALL, 2));
    let dur = tl.duration();
    let xs: Vec<Skeleton> = Sampler::new(&tl, SensorConfig::xsens(), 1).expect("s").collect();
    assert_eq!(xs.len(), (dur * 120.0).floor() as usize + 1);
    for w in xs.windows(2) {
        let dt = w[1].header.stamp.to_secs_f64() - w[0].header.stamp.to_secs_f64();
        assert!((dt - 1.0 / 120.0).abs() < 2e-9, "xsens period {dt}");
    }
    assert!(xs.iter().all(|m| m.source == Skeleton::SOURCE_XSENS));
    // Noiseless 30 Hz samples are every fourth 120 Hz sample.
    let x120: Vec<Skeleton> = Sampler::new(&tl, SensorConfig::xsens().noiseless(), 1).expect("s").collect();
    let mut cfg30 = SensorConfig::depth_tracker().noiseless();
    cfg30.source = cowork_people::Source::Xsens;
    let x30: Vec<Skeleton> = Sampler::new(&tl, cfg30, 1).expect("s").collect();
    assert_eq!(x30.len(), (dur * 30.0).floor() as usize + 1);
    for (i, m) in x30.iter().enumerate() {
        assert_eq!(m.poses, x120[4 * i].poses);
    }
    // The depth tracker loses frames and jitters, but stays in order and near its grid.
    let dt: Vec<Skeleton> = Sampler::new(&tl, SensorConfig::depth_tracker(), 3).expect("s").collect();
    let frames = (dur * 30.0).floor() as usize + 1;
    assert!(dt.len() < frames && dt.len() > frames * 9 / 10, "{} of {frames}", dt.len());
    let mut off_grid = 0;
    for w in dt.windows(2) {
        let (t0, t1) = (w[0].header.stamp.to_secs_f64(), w[1].header.stamp.to_secs_f64());
        assert!(t1 > t0);
        let k = (t1 * 30.0).round();
        let err = (t1 - k / 30.0).abs();
        assert!(err <= 0.45 / 30.0 + 1e-9);
        if err > 1e-4 {
            off_grid += 1;
        }
    }
    assert!(off_grid > dt.len() / 2, "no jitter seen");
    assert!(dt.iter().all(|m| m.source == Skeleton::SOURCE_DEPTH_TRACKER));
}

#[test]
fn messages_are_well_formed() {
    let tl = timeline(visit(BodySize::MEDIUM, 1));
    for cfg in [SensorConfig::xsens(), SensorConfig::depth_tracker()] {
        for m in Sampler::new(&tl, cfg, 5).expect("s") {
            assert_eq!(m.header.frame_id, "lwr_base_link");
            assert_eq!(m.person_id, 1);
            assert_eq!(m.segment_names, Skeleton::XSENS_SEGMENTS.map(String::from).to_vec());
            assert_eq!(m.poses.len(), 11);
            assert_eq!(m.velocities.len(), 11);
            for p in &m.poses {
                let o = &p.orientation;
                let n = (o.x * o.x + o.y * o.y + o.z * o.z + o.w * o.w).sqrt();
                assert!((n - 1.0).abs() < 1e-9);
                assert!(p.position.x.is_finite() && p.position.y.is_finite() && p.position.z.is_finite());
            }
        }
    }
    // The message survives CDR and converts back to a pose.
    let pose = tl.entries()[0].performer.pose(2.0);
    let meta = MessageMeta {
        stamp: cowork_msgs::builtin_interfaces::Time::from_secs_f64(2.0),
        frame_id: "lwr_base_link",
        source: Skeleton::SOURCE_XSENS,
        person_id: 4,
        with_velocities: false,
    };
    let msg = pose.to_message(&meta);
    assert!(msg.velocities.is_empty());
    let back: Skeleton = cowork_msgs::from_cdr(&cowork_msgs::to_cdr(&msg)).expect("cdr");
    assert_eq!(back, msg);
    let again = SkeletonPose::from_message(&back, BodySize::MEDIUM, -0.75).expect("from_message");
    for s in Segment::ALL {
        assert!((again.position(s) - pose.position(s)).norm() < 1e-12);
    }
}

#[test]
fn walk_in_reaches_the_spot_and_walk_out_leaves() {
    let room = Room::default();
    let p = visit(BodySize::MEDIUM, 8);
    let spans = p.spans();
    assert_eq!(spans.first().map(|s| s.kind), Some(SpanKind::Walk));
    let arrive = p.pose(spans[0].end);
    let pelvis = arrive.position(Segment::Pelvis);
    assert!((Point2::new(pelvis.x, pelvis.y) - room.standing_spot).norm() < 0.03, "arrived at {pelvis}");
    let end = p.pose(p.duration());
    let pe = end.position(Segment::Pelvis);
    assert!((Point2::new(pe.x, pe.y) - room.entry).norm() < 0.03);
    // While walking the feet alternate and stay near the floor.
    let mut lifted = [false, false];
    let mut t = spans[0].start;
    while t < spans[0].end {
        let q = p.pose(t);
        for (i, f) in q.feet.iter().enumerate() {
            let h = f.ankle.z - q.floor_z - q.body.lengths().ankle_height;
            assert!((-1e-9..0.15).contains(&h));
            lifted[i] |= h > 0.05;
        }
        t += 0.02;
    }
    assert_eq!(lifted, [true, true]);
    // Peak speed near the asked-for 1.1 m/s.
    let peak = (0..400)
        .map(|k| p.pose(spans[0].start + (spans[0].end - spans[0].start) * f64::from(k) / 400.0))
        .map(|q| q.segment(Segment::Pelvis).linear_velocity.xy().norm())
        .fold(0.0f64, f64::max);
    assert!((0.95..1.3).contains(&peak), "peak walking speed {peak}");
}

#[test]
fn reach_and_sweep_put_the_hand_on_target() {
    let target = Point3::new(0.35, -0.45, 0.35);
    let p = visit(BodySize::TALL, 2);
    let spans = p.spans();
    let reach = spans.iter().find(|s| s.kind == SpanKind::Reach).expect("reach");
    let mid = 0.5 * (reach.start + reach.end);
    let hand = p.pose(mid).position(Segment::RightHand);
    assert!((hand - target).norm() < 0.03, "hand {hand} target {target}");
    let sweep = spans.iter().find(|s| s.kind == SpanKind::Sweep).expect("sweep");
    let (a, b) = (Point3::new(0.1, -0.55, 0.2), Point3::new(0.75, -0.55, 0.2));
    let line = (b - a).normalize();
    for k in 0..=10 {
        let t = sweep.start + 0.8 + 1.5 * f64::from(k) / 10.0;
        let h = p.pose(t).position(Segment::RightHand);
        let off = (h - a) - (h - a).dot(&line) * line;
        assert!(off.norm() < 0.03, "hand {h} off the sweep line by {}", off.norm());
    }
    // A small person cannot reach as far; the hand gets as close as the arm and a lean allow.
    let far = Performer::new(1, BodySize::SMALL, Stance::new(0.35, -1.1, 1.57), 1)
        .expect("p")
        .then(Action::Reach { side: Side::Right, target: Point3::new(0.3, 0.5, 0.2), duration: 1.0, hold: 0.5 })
        .expect("reach");
    let pose = far.pose(1.2);
    assert!(pose.is_finite());
    let sh = pose.position(Segment::RightShoulder);
    assert!((pose.position(Segment::RightHand) - sh).norm() <= BodySize::SMALL.arm_reach() + 1e-9);
}

fn palm_normal(pose: &SkeletonPose) -> Vector3<f64> {
    pose.segment(Segment::RightHand).orientation * Vector3::x()
}
fn finger_dir(pose: &SkeletonPose) -> Vector3<f64> {
    pose.segment(Segment::RightHand).orientation * -Vector3::z()
}

#[test]
fn gestures_look_like_their_names() {
    let yaw: f64 = 0.7;
    let fwd = Vector3::new(yaw.cos(), yaw.sin(), 0.0);
    for body in BodySize::presets() {
        let perf = |kind| {
            Performer::new(1, body, Stance::new(0.0, -1.2, yaw), 3)
                .expect("p")
                .then(Action::Gesture { kind, style: GestureStyle::default() })
                .expect("g")
        };
        // stop: hand forward at shoulder height, palm out, fingers up.
        let p = perf(GestureKind::Stop);
        let q = p.pose(0.5 * p.duration());
        let rel = q.position(Segment::RightHand) - q.position(Segment::RightShoulder);
        assert!(rel.dot(&fwd) > 0.75 * body.arm_reach(), "stop: hand not forward {rel}");
        assert!(rel.z.abs() < 0.15, "stop: hand height {}", rel.z);
        assert!(palm_normal(&q).dot(&fwd) > 0.8, "stop: palm {}", palm_normal(&q));
        assert!(finger_dir(&q).z > 0.7, "stop: fingers {}", finger_dir(&q));
        // handover: hand forward below the shoulder, palm up.
        let p = perf(GestureKind::HandoverRight);
        let q = p.pose(0.5 * p.duration());
        let rel = q.position(Segment::RightHand) - q.position(Segment::RightShoulder);
        assert!(rel.dot(&fwd) > 0.45 * body.arm_reach() && rel.z < -0.1, "handover: {rel}");
        assert!(palm_normal(&q).z > 0.8, "handover: palm {}", palm_normal(&q));
        // come: palm towards the body, hand moving back and forth.
        let p = perf(GestureKind::Come);
        let d = p.duration();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut t = 0.7 * d / 3.0;
        while t < d - 0.7 {
            let q = p.pose(t);
            let n = palm_normal(&q);
            assert!(n.dot(&fwd) < -0.2, "come: palm {n} at {t}");
            let rel = (q.position(Segment::RightHand) - q.position(Segment::Sternum)).dot(&fwd);
            lo = lo.min(rel);
            hi = hi.max(rel);
            t += 0.02;
        }
        assert!(hi - lo > 0.1, "come: hand moves only {} m", hi - lo);
    }
}

#[test]
fn capsules_cover_the_body_down_to_the_floor() {
    let p = visit(BodySize::MEDIUM, 4);
    let mut t = 0.0;
    while t < p.duration() {
        let pose = p.pose(t);
        let caps = body_capsules(&pose);
        assert_eq!(caps.len(), BODY_CAPSULE_COUNT);
        for c in &caps {
            assert!(c.radius > 0.01 && c.radius < 0.2);
            assert!(c.a.coords.iter().chain(c.b.coords.iter()).all(|v| v.is_finite()));
        }
        // Feet touch the floor (lowest point within 1 cm unless lifted).
        let lowest = caps[12..].iter().step_by(3).map(|c| c.a.z.min(c.b.z) - c.radius).fold(f64::INFINITY, f64::min);
        assert!((lowest - pose.floor_z).abs() < 0.01, "feet at {lowest}");
        // Thigh + shank span the hip-ankle distance (knee IK).
        for k in [10, 13] {
            let (th, sh) = (&caps[k], &caps[k + 1]);
            assert!(((th.b - th.a).norm() - pose.body.lengths().thigh).abs() < 1e-9);
            assert!((th.b - sh.a).norm() < 1e-12);
        }
        // The right hand point is inside the hand capsule.
        assert!(caps[6].signed_distance(&pose.position(Segment::RightHand)) < 0.0);
        t += 0.25;
    }
}

#[test]
fn gesture_set_is_balanced_labelled_and_deterministic() {
    let cfg = GestureSetConfig { count: 12, ..Default::default() };
    let room = Room::default();
    let a = GestureSet::generate(5, &cfg, &room).expect("set");
    let b = GestureSet::generate(5, &cfg, &room).expect("set");
    let c = GestureSet::generate(6, &cfg, &room).expect("set");
    assert_eq!(a.instances, b.instances);
    assert_ne!(a.instances, c.instances);
    for k in GestureKind::ALL {
        assert_eq!(a.instances.iter().filter(|i| i.kind == k).count(), 4);
    }
    let spans = a.timeline().spans();
    for i in &a.instances {
        assert!(i.present_from < i.start && i.start < i.end && i.end < i.present_until);
        assert!(spans.iter().any(|s| s.person_id == i.person_id && s.span.kind == SpanKind::Gesture(i.kind) && (s.span.start - i.start).abs() < 1e-9));
        assert!((room.view_angle(&i.stance.position, i.stance.yaw) - i.view_angle).abs() < 1e-9);
        assert!(i.view_angle.abs() <= 1.05 + 1e-12);
        assert_eq!(GestureKind::from_label(i.label()), Some(i.kind));
    }
    // One person at a time.
    for w in a.instances.windows(2) {
        assert!(w[0].present_until < w[1].present_from);
    }
    let msgs: Vec<Skeleton> = Sampler::new(a.timeline(), SensorConfig::depth_tracker(), 1).expect("s").collect();
    let ids: std::collections::BTreeSet<u32> = msgs.iter().map(|m| m.person_id).collect();
    assert_eq!(ids.len(), 12);
}

#[test]
fn bad_input_is_rejected_with_a_named_error() {
    assert!(BodySize::new(f64::NAN).is_err());
    let p = Performer::new(1, BodySize::MEDIUM, Stance::new(0.0, 0.0, 0.0), 1).expect("p");
    let e = p.clone().then(Action::Stand { duration: -1.0 }).expect_err("negative");
    assert!(e.to_string().contains("stand duration"), "{e}");
    assert!(p.clone().then(Action::Walk { to: Point2::new(f64::NAN, 0.0), speed: 1.0, face_yaw: None }).is_err());
    assert!(p.clone().then(Action::Walk { to: Point2::new(1.0, 0.0), speed: 9.0, face_yaw: None }).is_err());
    let bad_style = GestureStyle { duration_scale: 0.0, ..Default::default() };
    assert!(p.clone().then(Action::Gesture { kind: GestureKind::Come, style: bad_style }).is_err());
    assert!(Performer::new(1, BodySize { height: 5.0 }, Stance::new(0.0, 0.0, 0.0), 1).is_err());
    let tl = timeline(p);
    let mut cfg = SensorConfig::xsens();
    cfg.rate_hz = f64::NAN;
    assert!(Sampler::new(&tl, cfg, 1).is_err());
    let mut cfg = SensorConfig::xsens();
    cfg.drop_probability = 1.0;
    assert!(Sampler::new(&tl, cfg, 1).is_err());
    assert!(GestureSet::generate(1, &GestureSetConfig { height_range: (1.9, 1.5), ..Default::default() }, &Room::default()).is_err());
    // A message missing a segment or with mismatched arrays.
    let mut msg = tl.entries()[0].performer.pose(0.0).to_message(&MessageMeta {
        stamp: Default::default(),
        frame_id: "lwr_base_link",
        source: "xsens",
        person_id: 1,
        with_velocities: true,
    });
    msg.velocities.pop();
    assert!(SkeletonPose::from_message(&msg, BodySize::MEDIUM, -0.75).is_err());
    msg.velocities.clear();
    msg.segment_names[2] = "nose".into();
    let e = SkeletonPose::from_message(&msg, BodySize::MEDIUM, -0.75).expect_err("missing head");
    assert!(e.to_string().contains("head"));
    let _ = UnitQuaternion::<f64>::identity();
}

#[test]
fn body_size_is_measured_from_the_arms_of_a_message() {
    for body in BodySize::presets() {
        let t = timeline(with_all_gestures(body, 5));
        // Noisy Xsens messages through every gesture: the measured height stays within 2 %.
        for msg in Sampler::new(&t, SensorConfig::xsens(), 9).expect("sampler").step_by(37) {
            let pose = SkeletonPose::from_message_measured(&msg, -0.75).expect("from_message_measured");
            let err = (pose.body.height - body.height).abs() / body.height;
            assert!(err < 0.02, "{} m measured as {} m", body.height, pose.body.height);
            assert!(pose.feet.iter().all(|f| (f.ankle.z - (-0.75 + pose.body.lengths().ankle_height)).abs() < 1e-12));
            let capsules = body_capsules(&pose);
            assert_eq!(capsules.len(), BODY_CAPSULE_COUNT);
            assert!(capsules.iter().all(|c| c.validate().is_ok()));
        }
    }
}
