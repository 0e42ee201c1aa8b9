//! CDR encode/decode cost of the graph's hot messages, and the `uint8[]` bytes adapter
//! against serde's default per-element sequence for a 640x480 32FC1 depth image.

use std::hint::black_box;

use byteorder::LittleEndian;
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Vector3};
use cowork_msgs::msg::{LinkDistance, LinkDistances};
use cowork_msgs::sensor_msgs::{Image, JointState};
use cowork_msgs::std_msgs::Header;
use cowork_msgs::{from_cdr, to_cdr, to_cdr_into};
use criterion::{Criterion, criterion_group, criterion_main};
use serde::{Deserialize, Serialize};

fn joint_state() -> JointState {
    JointState {
        header: Header::new(Time::from_nanos(1_234_567_890), "world"),
        name: (1..=7).map(|i| format!("lwr_joint_{i}")).collect(),
        position: vec![0.1; 7],
        velocity: vec![0.2; 7],
        effort: vec![],
    }
}

fn depth_image() -> Image {
    let (w, h) = (640u32, 480u32);
    let data: Vec<u8> = (0..w * h)
        .flat_map(|i| (1.0f32 + (i % 640) as f32 * 1e-3).to_le_bytes())
        .collect();
    Image {
        header: Header::new(Time::from_nanos(5), "camera_depth_optical_frame"),
        height: h,
        width: w,
        encoding: "32FC1".into(),
        is_bigendian: 0,
        step: w * 4,
        data,
    }
}

fn link_distances() -> LinkDistances {
    let link = |i: usize| LinkDistance {
        link_name: format!("lwr_link_{i}"),
        distance: 0.1 * i as f64,
        robot_point: Point::new(0.1, 0.2, 0.3),
        obstacle_point: Point::new(0.4, 0.5, 0.6),
        normal: Vector3::new(0.0, 0.0, 1.0),
        obstacle_velocity: Vector3::default(),
        valid: true,
    };
    LinkDistances {
        header: Header::new(Time::from_nanos(7), "world"),
        links: (0..8).map(link).collect(),
        min_index: 0,
        processing_time: 0.002,
        backend: "cpu".into(),
    }
}

/// Same wire layout as `Image` but `data` goes through serde's default `Vec<u8>` sequence.
#[derive(Serialize, Deserialize)]
struct ImagePerElement {
    header: Header,
    height: u32,
    width: u32,
    encoding: String,
    is_bigendian: u8,
    step: u32,
    data: Vec<u8>,
}

fn bench(c: &mut Criterion) {
    let js = joint_state();
    let js_bytes = to_cdr(&js);
    let mut buf = Vec::with_capacity(4096);
    c.bench_function("joint_state_7/encode_into", |b| {
        b.iter(|| to_cdr_into(black_box(&js), &mut buf))
    });
    c.bench_function("joint_state_7/decode", |b| {
        b.iter(|| from_cdr::<JointState>(black_box(&js_bytes)))
    });

    let ld = link_distances();
    let ld_bytes = to_cdr(&ld);
    c.bench_function("link_distances_8/encode_into", |b| {
        b.iter(|| to_cdr_into(black_box(&ld), &mut buf))
    });
    c.bench_function("link_distances_8/decode", |b| {
        b.iter(|| from_cdr::<LinkDistances>(black_box(&ld_bytes)))
    });

    let img = depth_image();
    let img_bytes = to_cdr(&img);
    let mut big = Vec::with_capacity(img_bytes.len() + 64);
    let per_element = ImagePerElement {
        header: img.header.clone(),
        height: img.height,
        width: img.width,
        encoding: img.encoding.clone(),
        is_bigendian: img.is_bigendian,
        step: img.step,
        data: img.data.clone(),
    };
    assert_eq!(
        cdr_encoding::to_vec::<_, LittleEndian>(&per_element).expect("encode"),
        img_bytes[4..],
        "adapter and per-element encodings must be identical on the wire"
    );
    let mut group = c.benchmark_group("depth_image_640x480_32FC1");
    group.sample_size(30);
    group.bench_function("encode_into/bytes_adapter", |b| {
        b.iter(|| to_cdr_into(black_box(&img), &mut big))
    });
    group.bench_function("encode/per_element", |b| {
        b.iter(|| cdr_encoding::to_vec::<_, LittleEndian>(black_box(&per_element)))
    });
    group.bench_function("decode/bytes_adapter", |b| {
        b.iter(|| from_cdr::<Image>(black_box(&img_bytes)))
    });
    group.bench_function("decode/per_element", |b| {
        b.iter(|| {
            cdr_encoding::from_bytes::<ImagePerElement, LittleEndian>(black_box(&img_bytes[4..]))
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
