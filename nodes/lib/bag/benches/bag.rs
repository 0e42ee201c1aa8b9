//! Throughput of writing and reading a depth bag: 30 frames of 640×480 32FC1 (1.2 MB each,
//! Kinect-like quantised depth with noise) plus 1 kHz joint states over the same second.
//!
//! `cargo bench -p cowork_bag --bench bag`; throughput is reported in bytes of message
//! payload per second.

use std::hint::black_box;
use std::path::Path;

use cowork_bag::{BagReader, BagWriter, check_image};
use cowork_msgs::sensor_msgs::{Image, JointState};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

const FRAMES: u64 = 30;

fn frame(k: u64) -> Image {
    let (w, h) = (640u32, 480u32);
    let mut state = k.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let data = (0..w * h)
        .flat_map(|i| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            // 0.8–3 m with 1 mm quantisation and ±2 mm noise.
            let base = 0.8 + 2.2 * f64::from(i % w) / f64::from(w);
            let noise = ((state % 5) as f64 - 2.0) * 1e-3;
            (((base + noise) * 1000.0).round() as f32 * 1e-3).to_le_bytes()
        })
        .collect();
    Image {
        height: h,
        width: w,
        encoding: "32FC1".into(),
        step: w * 4,
        data,
        ..Default::default()
    }
}

fn write_bag(path: &Path, frames: &[Image]) -> u64 {
    let mut payload = 0u64;
    let run = || -> cowork_bag::Result<()> {
        let mut w = BagWriter::create(path)?;
        let img = w.add_channel::<Image>("/camera/depth/image_raw")?;
        let js = w.add_channel::<JointState>("/joint_states")?;
        let mut state = JointState {
            position: vec![0.0; 7],
            velocity: vec![0.0; 7],
            ..Default::default()
        };
        for (k, f) in frames.iter().enumerate() {
            let t0 = k as u64 * 33_333_333;
            w.write(img, t0, t0, f)?;
            for j in 0..33 {
                state.position[0] = (k * 33 + j) as f64 * 1e-3;
                let t = t0 + j as u64 * 1_000_000;
                w.write(js, t, t, &state)?;
            }
        }
        w.finish()?;
        Ok(())
    };
    if let Err(e) = run() {
        panic!("bench bag: {e}");
    }
    for f in frames {
        payload += f.data.len() as u64;
    }
    payload
}

fn bench(c: &mut Criterion) {
    let frames: Vec<Image> = (0..FRAMES).map(frame).collect();
    let dir = match tempfile::tempdir() {
        Ok(d) => d,
        Err(e) => panic!("tempdir: {e}"),
    };
    let path = dir.path().join("depth.mcap");
    let payload = write_bag(&path, &frames);
    let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    eprintln!(
        "depth bag: {FRAMES} frames + {} joint states, {payload} B of image payload, file {size} B",
        FRAMES * 33
    );

    let mut g = c.benchmark_group("depth_bag_30x640x480");
    g.sample_size(10);
    g.throughput(Throughput::Bytes(payload));
    g.bench_function("write", |b| b.iter(|| write_bag(&path, black_box(&frames))));
    g.bench_function("read_raw", |b| {
        b.iter(|| {
            let reader = BagReader::open(&path).unwrap_or_else(|e| panic!("{e}"));
            reader.messages().filter(|m| m.is_ok()).count()
        })
    });
    g.bench_function("read_decode_check", |b| {
        b.iter(|| {
            let reader = BagReader::open(&path).unwrap_or_else(|e| panic!("{e}"));
            let mut n = 0;
            for m in reader.messages().flatten() {
                if &*m.topic == "/camera/depth/image_raw" {
                    let img: Image = m.decode().unwrap_or_else(|e| panic!("{e}"));
                    check_image(&m.topic, &img).unwrap_or_else(|e| panic!("{e}"));
                    n += 1;
                }
            }
            n
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
