//! Cost of a pose and of sampling messages (the bag synthesiser samples minutes at 120 Hz).

use std::hint::black_box;

use cowork_people::{BodySize, Room, Sampler, SensorConfig, SpanKind, Timeline, body_capsules};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::Point3;

fn visit() -> cowork_people::Performer {
    Room::default()
        .visit(1, BodySize::MEDIUM, 7, Point3::new(0.35, -0.45, 0.35), (Point3::new(0.1, -0.55, 0.2), Point3::new(0.75, -0.55, 0.2)))
        .expect("visit")
}

fn bench(c: &mut Criterion) {
    let p = visit();
    let spans = p.spans();
    let mid = |k: SpanKind| spans.iter().find(|s| s.kind == k).map_or(0.0, |s| 0.5 * (s.start + s.end));
    let mut g = c.benchmark_group("pose");
    for (name, t) in [("walk", mid(SpanKind::Walk)), ("reach", mid(SpanKind::Reach)), ("stand", mid(SpanKind::Stand))] {
        g.bench_function(name, |b| b.iter(|| black_box(p.pose(black_box(t)))));
    }
    let pose = p.pose(mid(SpanKind::Reach));
    g.bench_function("body_capsules", |b| b.iter(|| black_box(body_capsules(black_box(&pose)))));
    g.finish();

    let mut tl = Timeline::new();
    tl.add(0.0, p).expect("add");
    let n = Sampler::new(&tl, SensorConfig::xsens(), 1).expect("sampler").count() as u64;
    let mut g = c.benchmark_group("sample_visit_xsens_120hz");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n));
    g.bench_function("messages", |b| b.iter(|| Sampler::new(&tl, SensorConfig::xsens(), 1).expect("sampler").count()));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
