//! The three gestures are distinguishable: 1-nearest-neighbour DTW (cowork_motion::dtw) on
//! hand-relative-to-sternum trajectories, templates from one gesture set, queries from another
//! (other people, sizes, speeds, positions, viewing angles, noise), as a 30 Hz depth tracker
//! sees them.

use cowork_motion::dtw::Knn;
use cowork_msgs::msg::Skeleton;
use nalgebra::Vector3;
use cowork_people::{GestureKind, GestureSet, GestureSetConfig, Room, Sampler, SensorConfig, Side, hand_relative_to_sternum, resample_flat};

/// Frames per descriptor: the 50-frame window of thesis Sec. 5.1.3.
const FRAMES: usize = 50;

/// Hand minus sternum in the base frame, not turned into the sternum frame nor scaled: depends on
/// where the person faces. The comparison shows what the sternum frame buys.
fn world_frame(msgs: &[Skeleton]) -> Vec<Vector3<f64>> {
    let p = |m: &Skeleton, name: &str| {
        let q = m.segment(name).map(|p| p.position.clone()).unwrap_or_default();
        Vector3::new(q.x, q.y, q.z)
    };
    msgs.iter().map(|m| p(m, Skeleton::SEGMENT_RIGHT_HAND) - p(m, Skeleton::SEGMENT_STERNUM)).collect()
}

type Descriptors = Vec<(GestureKind, Vec<f64>, Vec<f64>)>;

/// Per instance: (label, sternum-frame descriptor, base-frame descriptor).
fn descriptors(set: &GestureSet, sensor: SensorConfig, seed: u64) -> Descriptors {
    let msgs: Vec<Skeleton> = Sampler::new(set.timeline(), sensor, seed).expect("sampler").collect();
    set.instances
        .iter()
        .map(|i| {
            let window: Vec<Skeleton> = msgs
                .iter()
                .filter(|m| {
                    let t = m.header.stamp.to_secs_f64();
                    m.person_id == i.person_id && t >= i.start && t <= i.end
                })
                .cloned()
                .collect();
            let rows = hand_relative_to_sternum(&window, Side::Right).expect("features");
            assert!(rows.len() > 20, "instance {} has {} frames", i.index, rows.len());
            (i.kind, resample_flat(&rows, FRAMES), resample_flat(&world_frame(&window), FRAMES))
        })
        .collect()
}

#[test]
fn dtw_nearest_neighbour_tells_the_gestures_apart() {
    let room = Room::default();
    let train = GestureSet::generate(100, &GestureSetConfig { count: 30, ..Default::default() }, &room).expect("train set");
    let test = GestureSet::generate(200, &GestureSetConfig { count: 60, ..Default::default() }, &room).expect("test set");
    let templates = descriptors(&train, SensorConfig::depth_tracker(), 1);
    let queries = descriptors(&test, SensorConfig::depth_tracker(), 2);
    let run = |pick: fn(&(GestureKind, Vec<f64>, Vec<f64>)) -> &Vec<f64>| {
        let mut knn = Knn::new(3, Some(10));
        for t in &templates {
            knn.add(t.0.label(), pick(t).clone()).expect("template");
        }
        let mut confusion = [[0usize; 3]; 3];
        for q in &queries {
            let (label, _) = knn.classify(pick(q), 1).expect("classify");
            let got = GestureKind::from_label(&label).expect("label");
            let idx = |k: GestureKind| GestureKind::ALL.iter().position(|g| *g == k).unwrap_or(0);
            confusion[idx(q.0)][idx(got)] += 1;
        }
        let correct: usize = (0..3).map(|i| confusion[i][i]).sum();
        (correct as f64 / queries.len() as f64, confusion)
    };
    let (accuracy, confusion) = run(|d| &d.1);
    let (world, world_confusion) = run(|d| &d.2);
    println!(
        "1-NN DTW accuracy, sternum frame: {accuracy:.3} {confusion:?}; base frame (view-dependent): {world:.3} {world_confusion:?} (rows truth come/stop/handover, {} queries)",
        queries.len()
    );
    assert!(accuracy >= 0.9, "accuracy {accuracy}, confusion {confusion:?}");
    assert!(accuracy >= world, "sternum frame {accuracy} worse than base frame {world}");
}
