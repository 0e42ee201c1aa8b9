//! Writes a noisy right-hand track of a synthetic person with the truth and the
//! `ConstantVelocityKf` estimates, for the filterpy cross-check
//! (`tests/crosscheck/check_observer.sh`):
//!
//! `kalman_track SEED xsens|depth PROCESS_NOISE MEASUREMENT_NOISE INITIAL_VELOCITY_STD OUT.csv`
//!
//! Columns: `t,zx,zy,zz,tx,ty,tz,tvx,tvy,tvz,px,py,pz,vx,vy,vz` (measurement, truth position
//! and velocity, filtered position and velocity; s, m, m/s).

use std::io::Write;

use cowork_observer::KalmanConfig;
use cowork_observer::eval::{kalman_track, track_rmse};
use cowork_people::SensorConfig;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    if a.len() != 6 {
        return Err("usage: kalman_track SEED xsens|depth PROCESS_NOISE MEASUREMENT_NOISE INITIAL_VELOCITY_STD OUT.csv".into());
    }
    let seed: u64 = a[0].parse()?;
    let sensor = match a[1].as_str() {
        "xsens" => SensorConfig::xsens(),
        "depth" => SensorConfig::depth_tracker(),
        other => return Err(format!("unknown sensor {other:?}").into()),
    };
    let config = KalmanConfig { process_noise: a[2].parse()?, measurement_noise_m: a[3].parse()?, initial_velocity_std: a[4].parse()? };
    let rows = kalman_track(seed, &sensor, config)?;
    let mut f = std::io::BufWriter::new(std::fs::File::create(&a[5])?);
    writeln!(f, "t,zx,zy,zz,tx,ty,tz,tvx,tvy,tvz,px,py,pz,vx,vy,vz")?;
    for r in &rows {
        let v = [
            r.stamp, r.measured.x, r.measured.y, r.measured.z, r.truth.x, r.truth.y, r.truth.z, r.truth_velocity.x, r.truth_velocity.y,
            r.truth_velocity.z, r.filtered.x, r.filtered.y, r.filtered.z, r.filtered_velocity.x, r.filtered_velocity.y, r.filtered_velocity.z,
        ];
        writeln!(f, "{}", v.iter().map(|x| format!("{x:.17e}")).collect::<Vec<_>>().join(","))?;
    }
    f.flush()?;
    let [rp, fp, rv, fv] = track_rmse(&rows, 10);
    println!("{} frames: position RMSE raw {:.4} m, filtered {:.4} m; velocity RMSE raw {:.4} m/s, filtered {:.4} m/s", rows.len(), rp, fp, rv, fv);
    Ok(())
}
