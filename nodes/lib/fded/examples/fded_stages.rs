//! Per-stage times of one configuration on the synthetic static scene and the worst case, and
//! Flacco et al. on the static scene (full-resolution robot removal + spheres) beside them.
//!
//!     cargo run --release -p cowork_fded --example fded_stages -- [TS] [S] [REPS] [SPACING_MM] [NORMAL_FRACTION_x1e4] [--static-only]
//!
//! `--static-only`: fDED on the static scene alone (for a profiler).

use cowork_fded::baseline::{Flacco, FlaccoParams};
use cowork_fded::bench::{static_scene, worst_case};
use cowork_fded::{Fded, FdedParams, StageTimes};
use cowork_robot::RobotModel;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let static_only = std::env::args().any(|a| a == "--static-only");
    let nums: Vec<u32> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let (ts, s, reps) = (nums.first().copied().unwrap_or(32), nums.get(1).copied().unwrap_or(16), nums.get(2).copied().unwrap_or(50));
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../config/robot/lwr4plus.urdf");
    let model = RobotModel::from_urdf_file(path)?;
    let scene = static_scene(&model, 1, 1)?;
    let (wc, _) = worst_case(&model, 1.0)?;
    for (name, sc) in [("static", &scene), ("worst", &wc)] {
        if static_only && name != "static" {
            continue;
        }
        let spacing = nums.get(3).map_or(FdedParams::default().robot_point_spacing, |&mm| f64::from(mm) / 1000.0);
        let params = FdedParams { tile_size: ts, step_x: s, step_y: s, robot_point_spacing: spacing, normal_fraction: nums.get(4).map_or(0.01, |&x| f64::from(x) / 1e4), ..FdedParams::default() };
        let mut f = Fded::new(&model, &sc.intrinsics, params)?;
        let mut out = f.new_output();
        let frame = sc.frame(0);
        f.process(&frame, &mut out)?;
        let mut t: Vec<StageTimes> = Vec::new();
        for _ in 0..reps {
            f.process(&frame, &mut out)?;
            t.push(out.times);
        }
        let m = |g: fn(&StageTimes) -> f64| median(&mut t.iter().map(g).collect::<Vec<_>>());
        let mut distinct: Vec<[i64; 3]> = out.links.iter().filter(|l| l.valid).map(|l| l.obstacle_point.coords.map(|c| (c * 1e5) as i64).into()).collect();
        distinct.sort_unstable();
        distinct.dedup();
        println!(
            "{name} ({} distinct obstacle points) T_s={ts} S={s}: points {} | R {} O {} | median µs: transform {:.0} removal {:.0} lattices {:.0} minimum {:.0} refine {:.0} output {:.0} total {:.0}",
            distinct.len(),
            f.robot_points().len(),
            out.counts.robot_lattice,
            out.counts.object_lattice,
            m(|t| t.virtual_depth_us),
            m(|t| t.filter_us),
            m(|t| t.lattices_us),
            m(|t| t.minimum_us),
            m(|t| t.refine_us),
            m(|t| t.output_us),
            m(|t| t.total_us)
        );
        if name == "static" && !static_only {
            let mut fl = Flacco::new(&model, FlaccoParams::default());
            let mut per_link = Vec::new();
            let (mut removal, mut total) = (Vec::new(), Vec::new());
            for _ in 0..reps {
                let t0 = std::time::Instant::now();
                f.classify_full(&frame)?;
                let t1 = std::time::Instant::now();
                fl.distances_prepared(&f, &frame, &mut per_link);
                let t2 = std::time::Instant::now();
                removal.push((t1 - t0).as_secs_f64() * 1e6);
                total.push((t2 - t0).as_secs_f64() * 1e6);
            }
            let (removal, total) = (median(&mut removal), median(&mut total));
            let fded_total = m(|t| t.total_us);
            println!(
                "static Flacco et al.: median µs: full-resolution removal {removal:.0} spheres {:.0} total {total:.0} | fDED {:.1}× faster",
                total - removal,
                total / fded_total
            );
        }
    }
    Ok(())
}
