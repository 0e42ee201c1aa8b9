//! Criterion benchmark of one frame through the node (`FdedNode::on_depth`: image decode,
//! fDED, message and marker fill) beside the bare library call on the same frame: fDED's static
//! scene at T_s = 32, S = 16 (thesis Table 5.1 defaults), 640×480, as `32FC1` and `16UC1`, on the
//! CPU and, when a wgpu adapter exists, on the GPU. The difference between `node_*` and
//! `fded_cpu` is the node's own cost per frame; `decode_*` is the image-decoding part of it. On Mesa's lavapipe (a CPU rasteriser behind
//! Vulkan) the `wgpu` figures say nothing about a real GPU; they show the device round trip.

use std::hint::black_box;
use std::path::PathBuf;

use cowork_depth::Encoding;
use cowork_fded::bench::{BenchScene, static_scene};
use cowork_fded::gpu::GpuContext;
use cowork_fded::{Fded, FdedParams};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Quaternion, Transform, TransformStamped, Vector3};
use cowork_msgs::sensor_msgs::{Image, JointState};
use cowork_msgs::std_msgs::Header;
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_robot::RobotModel;
use criterion::{Criterion, criterion_group, criterion_main};
use fded_distance::{FdedNode, Params};

const FRAME: &str = "camera_depth_optical_frame";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A node on `backend` fed the scene's camera info, camera pose and joint state.
fn node(model: &RobotModel, scene: &BenchScene, backend: &str) -> FdedNode {
    let params = Params { backend: backend.into(), fded: FdedParams::default(), ..Params::default() };
    let mut node = FdedNode::new(model.clone(), params).expect("node");
    node.on_camera_info(&scene.intrinsics.to_camera_info(Time::default(), FRAME)).expect("camera info");
    let base = model.link_names()[0].clone();
    let (t, r) = (scene.camera_pose.translation.vector, scene.camera_pose.rotation.quaternion());
    node.on_tf_static(&TFMessage {
        transforms: vec![TransformStamped {
            header: Header::new(Time::default(), base),
            child_frame_id: FRAME.into(),
            transform: Transform {
                translation: Vector3 { x: t.x, y: t.y, z: t.z },
                rotation: Quaternion { x: r.i, y: r.j, z: r.k, w: r.w },
            },
        }],
    })
    .expect("tf_static");
    node.on_joint_state(&JointState {
        header: Header::new(Time::from_secs_f64(scene.stamps[0]), ""),
        name: model.joint_names().to_vec(),
        position: scene.joints[0].to_vec(),
        ..Default::default()
    })
    .expect("joint state");
    node
}

fn bench(c: &mut Criterion) {
    let model = RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("bundled URDF");
    let scene = static_scene(&model, 1, 1).expect("scene");
    let stamp = Time::from_secs_f64(scene.stamps[0]);
    let images: Vec<(&str, Image)> = [("32fc1", Encoding::F32Metres), ("16uc1", Encoding::U16Millimetres)]
        .into_iter()
        .map(|(name, e)| (name, scene.frames[0].to_image_msg(stamp, FRAME, e)))
        .collect();

    let mut cpu = Fded::new(&model, &scene.intrinsics, FdedParams::default()).expect("fded");
    let mut out = cpu.new_output();
    let frame = scene.frame(0);
    c.bench_function("static_ts32_s16_fded_cpu", |b| {
        b.iter(|| {
            cpu.process(black_box(&frame), &mut out).expect("frame");
            black_box(out.closest)
        })
    });

    // The node's own first step, for the breakdown: decoding the message into metres.
    let mut depth = cowork_depth::DepthImage::default();
    for (enc, img) in &images {
        c.bench_function(&format!("static_decode_{enc}"), |b| {
            b.iter(|| depth.read_image_msg(black_box(img)).expect("decodes"))
        });
    }

    let gpu = GpuContext::open().ok().flatten().map(|ctx| ctx.adapter_name().to_owned());
    let mut backends = vec!["cpu"];
    match &gpu {
        Some(adapter) => {
            eprintln!("wgpu adapter: {adapter}");
            backends.push("gpu");
        }
        None => eprintln!("no wgpu adapter: node_wgpu not measured"),
    }
    for backend in backends {
        let mut n = node(&model, &scene, backend);
        let name = n.backend().expect("engine built");
        for (enc, img) in &images {
            c.bench_function(&format!("static_ts32_s16_node_{name}_{enc}"), |b| {
                b.iter(|| black_box(n.on_depth(black_box(img)).expect("frame").min_index))
            });
        }
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(3));
    targets = bench
}
criterion_main!(benches);
