//! Quick generalisation check while tuning: `cargo run --release -p cowork_observer --example
//! gesture_bench -- TRAIN_COUNT TEST_COUNT NON_GESTURE_S` (the full table is `cowork bench gestures`).

use cowork_observer::LearnConfig;
use cowork_observer::eval::{Evaluation, gesture_stream, learn, non_gesture_stream, recognise};
use cowork_people::SensorConfig;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<f64> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let (train_n, test_n, neg_s) = (args.first().copied().unwrap_or(30.0) as usize, args.get(1).copied().unwrap_or(30.0) as usize, args.get(2).copied().unwrap_or(120.0));
    let depth = SensorConfig::depth_tracker();
    let t0 = std::time::Instant::now();
    let train = gesture_stream(1, train_n, &depth, false)?;
    let neg_train = non_gesture_stream(1, 60.0, &depth)?;
    let model = learn(&[&train, &neg_train], LearnConfig::default())?;
    println!("learned in {:.1} s: {} templates, threshold {:.3}, training {:?}", t0.elapsed().as_secs_f64(), model.templates.len(), model.threshold, model.training);
    for (name, sensor) in [("30 Hz depth tracker", SensorConfig::depth_tracker()), ("120 Hz Xsens", SensorConfig::xsens())] {
        let t0 = std::time::Instant::now();
        let test = gesture_stream(2, test_n, &sensor, false)?;
        let (reports, evals) = recognise(&model, &test)?;
        let e = Evaluation::score(&model.labels, &test, &reports, 1.0, evals);
        let neg = non_gesture_stream(2, neg_s, &sensor)?;
        let (nreports, nevals) = recognise(&model, &neg)?;
        let n = Evaluation::score(&model.labels, &neg, &nreports, 1.0, nevals);
        println!("{name}: {:.1} s\n{}duplicates {}\nnon-gesture {:.0} s: {} false ({:.2}/10 min) {:?}", t0.elapsed().as_secs_f64(), e.table(), e.duplicates, n.duration_s, n.false_reports(), n.false_per_10_min(), nreports.iter().map(|r| (&r.label, r.stamp as i64, (r.distance * 100.0).round() / 100.0)).collect::<Vec<_>>());
        for r in reports.iter().take(0) {
            println!("{r:?}");
        }
    }
    Ok(())
}
