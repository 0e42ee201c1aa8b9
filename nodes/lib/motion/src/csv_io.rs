//! CSV files of `cowork learn`: demonstrations (`t,x0,…,x{n−1}[,v0,…,v{n−1}]`), query points
//! (`x0,…`), rollouts (`t,x0,…,v0,…`), velocities (`v0,…`) and pose trajectories
//! (`t,px,py,pz,qw,qx,qy,qz`, position in m, unit quaternion). Errors name the file, the 1-based
//! row (the header is row 1) and the column.

use std::path::Path;

use nalgebra::{Quaternion, Rotation3, UnitQuaternion, Vector3};

use crate::demo::Demonstration;
use crate::dhb::Poses;
use crate::ds::Trajectory;
use crate::error::{MotionError, Result};

fn csv_err(
    file: &Path,
    row: usize,
    column: impl Into<String>,
    reason: impl Into<String>,
) -> MotionError {
    MotionError::Csv {
        file: file.to_path_buf(),
        row,
        column: column.into(),
        reason: reason.into(),
    }
}

/// A parsed numeric table: header names and rows (all of the header's width).
#[derive(Debug, Clone)]
pub struct Table {
    /// Column names.
    pub header: Vec<String>,
    /// Values, one `Vec` per data row.
    pub rows: Vec<Vec<f64>>,
}

/// Reads a numeric CSV with a header; every cell must parse as a finite number and every row
/// must have the header's width.
pub fn read_table(path: &Path) -> Result<Table> {
    let file = std::fs::File::open(path).map_err(|source| MotionError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    read_table_from(file, path)
}

/// As [`read_table`] from any reader; `path` is only used in error messages.
pub fn read_table_from<R: std::io::Read>(reader: R, path: &Path) -> Result<Table> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(reader);
    let header: Vec<String> = rdr
        .headers()
        .map_err(|e| csv_err(path, 1, "-", e.to_string()))?
        .iter()
        .map(str::to_string)
        .collect();
    if header.is_empty() || header.iter().all(String::is_empty) {
        return Err(csv_err(path, 1, "-", "missing header"));
    }
    let mut rows = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            let row = e.position().map_or(0, |p| p.line() as usize);
            csv_err(path, row, "-", e.to_string())
        })?;
        let row = rec.position().map_or(rows.len() + 2, |p| p.line() as usize);
        if rec.len() != header.len() {
            return Err(csv_err(
                path,
                row,
                format!("{}", rec.len().min(header.len()) + 1),
                format!("row has {} fields, header has {}", rec.len(), header.len()),
            ));
        }
        let mut vals = Vec::with_capacity(rec.len());
        for (c, cell) in rec.iter().enumerate() {
            let v: f64 = cell.parse().map_err(|_| {
                csv_err(
                    path,
                    row,
                    header[c].clone(),
                    format!("`{cell}` is not a number"),
                )
            })?;
            if !v.is_finite() {
                return Err(csv_err(
                    path,
                    row,
                    header[c].clone(),
                    format!("`{cell}` is not finite"),
                ));
            }
            vals.push(v);
        }
        rows.push(vals);
    }
    Ok(Table { header, rows })
}

fn expect_columns(path: &Path, header: &[String], names: &[String], offset: usize) -> Result<()> {
    for (i, n) in names.iter().enumerate() {
        match header.get(offset + i) {
            Some(h) if h == n => {}
            Some(h) => {
                return Err(csv_err(
                    path,
                    1,
                    format!("{}", offset + i + 1),
                    format!("expected column `{n}`, found `{h}`"),
                ));
            }
            None => {
                return Err(csv_err(
                    path,
                    1,
                    format!("{}", offset + i + 1),
                    format!("missing column `{n}`"),
                ));
            }
        }
    }
    Ok(())
}

/// Reads a demonstration: header `t,x0..x{n−1}` with optional `v0..v{n−1}`; velocities by finite
/// differences when absent. Needs at least two rows and strictly increasing `t`.
pub fn read_demonstration(path: &Path) -> Result<Demonstration> {
    let table = read_table(path)?;
    let h = &table.header;
    if h.first().map(String::as_str) != Some("t") {
        return Err(csv_err(path, 1, "1", "first column must be `t`"));
    }
    let n = h.iter().skip(1).take_while(|c| c.starts_with('x')).count();
    if n == 0 {
        return Err(csv_err(path, 1, "2", "no position columns `x0..`"));
    }
    let xs: Vec<String> = (0..n).map(|i| format!("x{i}")).collect();
    expect_columns(path, h, &xs, 1)?;
    let has_v = h.len() > 1 + n;
    if has_v {
        let vs: Vec<String> = (0..n).map(|i| format!("v{i}")).collect();
        expect_columns(path, h, &vs, 1 + n)?;
        if h.len() != 1 + 2 * n {
            return Err(csv_err(
                path,
                1,
                format!("{}", 2 + 2 * n),
                "unexpected extra column",
            ));
        }
    }
    if table.rows.len() < 2 {
        return Err(csv_err(
            path,
            table.rows.len() + 1,
            "t",
            format!("need at least 2 samples, got {}", table.rows.len()),
        ));
    }
    for (i, w) in table.rows.windows(2).enumerate() {
        if w[1][0] <= w[0][0] {
            return Err(csv_err(path, i + 3, "t", "times must increase strictly"));
        }
    }
    let t = table.rows.iter().map(|r| r[0]).collect();
    let pos = table
        .rows
        .iter()
        .flat_map(|r| r[1..1 + n].iter().copied())
        .collect();
    let vel = has_v.then(|| {
        table
            .rows
            .iter()
            .flat_map(|r| r[1 + n..1 + 2 * n].iter().copied())
            .collect()
    });
    Demonstration::new(n, t, pos, vel)
}

/// Reads query points with header `x0..x{n−1}`; returns `(n, row-major values)`.
pub fn read_points(path: &Path) -> Result<(usize, Vec<f64>)> {
    read_points_named(path, "x")
}

/// Reads a table whose header is `{prefix}0..{prefix}{n−1}`; returns `(n, row-major values)`.
pub fn read_points_named(path: &Path, prefix: &str) -> Result<(usize, Vec<f64>)> {
    let table = read_table(path)?;
    let n = table.header.len();
    let xs: Vec<String> = (0..n).map(|i| format!("{prefix}{i}")).collect();
    expect_columns(path, &table.header, &xs, 0)?;
    Ok((n, table.rows.into_iter().flatten().collect()))
}

fn io_err(path: &Path, e: impl std::fmt::Display) -> MotionError {
    MotionError::Io {
        file: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    }
}

/// Writes rows with a header, atomically (temporary file + rename) so a crash leaves no half file.
pub fn write_table(
    path: &Path,
    header: &[String],
    rows: impl Iterator<Item = Vec<f64>>,
    comments: &[String],
) -> Result<()> {
    let tmp = path.with_extension("tmp-write");
    {
        let mut f = std::fs::File::create(&tmp).map_err(|source| MotionError::Io {
            file: tmp.clone(),
            source,
        })?;
        use std::io::Write;
        for c in comments {
            writeln!(f, "# {c}").map_err(|source| MotionError::Io {
                file: tmp.clone(),
                source,
            })?;
        }
        let mut w = csv::Writer::from_writer(f);
        w.write_record(header).map_err(|e| io_err(path, e))?;
        for r in rows {
            w.write_record(r.iter().map(|v| format!("{v:.17e}")))
                .map_err(|e| io_err(path, e))?;
        }
        w.flush().map_err(|source| MotionError::Io {
            file: tmp.clone(),
            source,
        })?;
    }
    std::fs::rename(&tmp, path).map_err(|source| MotionError::Io {
        file: path.to_path_buf(),
        source,
    })
}

/// Writes a rollout as `t,x0..,v0..`.
pub fn write_trajectory(path: &Path, tr: &Trajectory) -> Result<()> {
    let n = tr.dim;
    let mut header = vec!["t".to_string()];
    header.extend((0..n).map(|i| format!("x{i}")));
    header.extend((0..n).map(|i| format!("v{i}")));
    write_table(
        path,
        &header,
        (0..tr.len()).map(|i| {
            let mut r = vec![tr.t[i]];
            r.extend_from_slice(tr.position(i));
            r.extend_from_slice(tr.velocity(i));
            r
        }),
        &[],
    )
}

/// Writes velocities `v0..` (row-major, `n` columns).
pub fn write_velocities(path: &Path, n: usize, v: &[f64]) -> Result<()> {
    let header: Vec<String> = (0..n).map(|i| format!("v{i}")).collect();
    write_table(path, &header, v.chunks(n).map(<[f64]>::to_vec), &[])
}

/// Reads a pose trajectory `t,px,py,pz,qw,qx,qy,qz` (quaternions are normalised; a zero one is
/// an error).
pub fn read_poses(path: &Path) -> Result<(Vec<f64>, Poses)> {
    let table = read_table(path)?;
    let names: Vec<String> = ["t", "px", "py", "pz", "qw", "qx", "qy", "qz"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    expect_columns(path, &table.header, &names, 0)?;
    if table.header.len() != names.len() {
        return Err(csv_err(path, 1, "9", "unexpected extra column"));
    }
    let mut t = Vec::new();
    let mut poses = Poses {
        p: Vec::new(),
        r: Vec::new(),
    };
    for (i, r) in table.rows.iter().enumerate() {
        let q = Quaternion::new(r[4], r[5], r[6], r[7]);
        if q.norm() < 1e-9 {
            return Err(csv_err(path, i + 2, "qw", "quaternion has zero norm"));
        }
        t.push(r[0]);
        poses.p.push(Vector3::new(r[1], r[2], r[3]));
        poses
            .r
            .push(UnitQuaternion::from_quaternion(q).to_rotation_matrix());
    }
    Ok((t, poses))
}

/// Writes a pose trajectory in the format of [`read_poses`].
pub fn write_poses(path: &Path, t: &[f64], poses: &Poses) -> Result<()> {
    let header: Vec<String> = ["t", "px", "py", "pz", "qw", "qx", "qy", "qz"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    write_table(
        path,
        &header,
        poses.p.iter().zip(&poses.r).enumerate().map(|(i, (p, r))| {
            let q = UnitQuaternion::from_rotation_matrix(r);
            vec![
                t.get(i).copied().unwrap_or(i as f64),
                p.x,
                p.y,
                p.z,
                q.w,
                q.i,
                q.j,
                q.k,
            ]
        }),
        &[],
    )
}

/// Rotation from a quaternion `(w, x, y, z)`.
pub fn rotation_from_wxyz(q: [f64; 4]) -> Rotation3<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3])).to_rotation_matrix()
}

/// Column names of a DHB invariant file.
pub const DHB_HEADER: [&str; 7] = [
    "t", "m_l", "theta1_l", "theta2_l", "m_a", "theta1_a", "theta2_a",
];

fn fmt_list(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:.17e}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// Writes position-based DHB invariants with the sample times of the rows (`t_end` is the time
/// of the last reconstructed pose); the initial pose and
/// frames needed to reconstruct go into a `# dhb …` comment line.
pub fn write_dhb(path: &Path, t: &[f64], dhb: &crate::dhb::Dhb) -> Result<()> {
    let q = UnitQuaternion::from_rotation_matrix(&dhb.r0);
    let t_end = t.get(dhb.linear.rows.len()).copied().unwrap_or(f64::NAN);
    let comment = format!(
        "dhb p0={} r0={} linear_frame={} angular_frame={} t_end={:.17e}",
        fmt_list(dhb.p0.as_slice()),
        fmt_list(&[q.w, q.i, q.j, q.k]),
        fmt_list(dhb.linear.frame0.as_slice()),
        fmt_list(dhb.angular.frame0.as_slice()),
        t_end
    );
    let header: Vec<String> = DHB_HEADER.iter().map(|s| s.to_string()).collect();
    let rows = dhb.rows();
    write_table(
        path,
        &header,
        rows.iter().enumerate().map(|(i, r)| {
            let mut v = vec![t.get(i).copied().unwrap_or(i as f64)];
            v.extend_from_slice(r);
            v
        }),
        &[comment],
    )
}

/// Reads a file written by [`write_dhb`]; returns the row times, the end time and the invariants.
pub fn read_dhb(path: &Path) -> Result<(Vec<f64>, f64, crate::dhb::Dhb)> {
    use crate::dhb::{Dhb, DhbKind, VectorInvariants};
    use nalgebra::Matrix3;
    let text = std::fs::read_to_string(path).map_err(|source| MotionError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    let (line_no, line) = text
        .lines()
        .enumerate()
        .find(|(_, l)| l.starts_with("# dhb "))
        .ok_or_else(|| {
            csv_err(
                path,
                1,
                "-",
                "missing `# dhb p0=… r0=… linear_frame=… angular_frame=…` line",
            )
        })?;
    let row = line_no + 1;
    let field = |name: &str, n: usize| -> Result<Vec<f64>> {
        let v = line
            .split_whitespace()
            .find_map(|w| w.strip_prefix(&format!("{name}=")))
            .ok_or_else(|| csv_err(path, row, name, "missing"))?;
        let vals: Vec<f64> = v
            .split(',')
            .map(str::parse)
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| csv_err(path, row, name, "not a list of numbers"))?;
        if vals.len() != n {
            return Err(csv_err(
                path,
                row,
                name,
                format!("expected {n} values, got {}", vals.len()),
            ));
        }
        Ok(vals)
    };
    let p0 = field("p0", 3)?;
    let r0 = field("r0", 4)?;
    let lf = field("linear_frame", 9)?;
    let af = field("angular_frame", 9)?;
    let t_end = field("t_end", 1)?[0];
    let table = read_table_from(text.as_bytes(), path)?;
    let header: Vec<String> = DHB_HEADER.iter().map(|s| s.to_string()).collect();
    expect_columns(path, &table.header, &header, 0)?;
    let lin = table.rows.iter().map(|r| [r[1], r[2], r[3]]).collect();
    let ang = table.rows.iter().map(|r| [r[4], r[5], r[6]]).collect();
    let frame = |v: &[f64]| Matrix3::from_column_slice(v);
    let dhb = Dhb {
        kind: DhbKind::Position,
        linear: VectorInvariants {
            rows: lin,
            frame0: frame(&lf),
        },
        angular: VectorInvariants {
            rows: ang,
            frame0: frame(&af),
        },
        p0: Vector3::new(p0[0], p0[1], p0[2]),
        r0: rotation_from_wxyz([r0[0], r0[1], r0[2], r0[3]]),
    };
    Ok((table.rows.iter().map(|r| r[0]).collect(), t_end, dhb))
}

/// Column names of an EFS invariant file (`cowork learn dhb --kind efs`).
pub const EFS_HEADER: [&str; 7] = ["t", "e1_v", "e2_v", "e3_v", "e1_w", "e2_w", "e3_w"];
/// Column names of a DS invariant file (`cowork learn dhb --kind ds`).
pub const DS_HEADER: [&str; 7] = ["t", "d1_w", "d2_w", "d3_w", "d1_v", "d2_v", "d3_v"];

/// The `# <tag> …` comment line of an invariant file: its 1-based row and text.
fn tagged_line<'a>(path: &Path, text: &'a str, tag: &str) -> Result<(usize, &'a str)> {
    text.lines()
        .enumerate()
        .find(|(_, l)| l.starts_with(&format!("# {tag} ")))
        .map(|(i, l)| (i + 1, l))
        .ok_or_else(|| csv_err(path, 1, "-", format!("missing `# {tag} …` line")))
}

/// `name=v1,v2,…` of a tagged line, with exactly `n` values.
fn tagged_field(path: &Path, row: usize, line: &str, name: &str, n: usize) -> Result<Vec<f64>> {
    let v = line
        .split_whitespace()
        .find_map(|w| w.strip_prefix(&format!("{name}=")))
        .ok_or_else(|| csv_err(path, row, name, "missing"))?;
    let vals: Vec<f64> = v
        .split(',')
        .map(str::parse)
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| csv_err(path, row, name, "not a list of numbers"))?;
    if vals.len() != n || vals.iter().any(|x| !x.is_finite()) {
        return Err(csv_err(
            path,
            row,
            name,
            format!("expected {n} finite values, got {}", vals.len()),
        ));
    }
    Ok(vals)
}

fn write_six(
    path: &Path,
    header: &[&str; 7],
    t: &[f64],
    rows: &[[f64; 6]],
    comment: String,
) -> Result<()> {
    let header: Vec<String> = header.iter().map(|s| s.to_string()).collect();
    write_table(
        path,
        &header,
        rows.iter().enumerate().map(|(i, r)| {
            let mut v = vec![t.get(i).copied().unwrap_or(i as f64)];
            v.extend_from_slice(r);
            v
        }),
        &[comment],
    )
}

/// Rows of a six-invariant file, checked against `header`.
fn read_six(path: &Path, text: &str, header: &[&str; 7]) -> Result<(Vec<f64>, Vec<[f64; 6]>)> {
    let table = read_table_from(text.as_bytes(), path)?;
    let names: Vec<String> = header.iter().map(|s| s.to_string()).collect();
    expect_columns(path, &table.header, &names, 0)?;
    if table.rows.len() < 3 {
        return Err(csv_err(path, 2, "-", "need at least 3 rows of invariants"));
    }
    Ok((
        table.rows.iter().map(|r| r[0]).collect(),
        table
            .rows
            .iter()
            .map(|r| [r[1], r[2], r[3], r[4], r[5], r[6]])
            .collect(),
    ))
}

fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|source| MotionError::Io {
        file: path.to_path_buf(),
        source,
    })
}

fn pose_fields(
    path: &Path,
    row: usize,
    line: &str,
) -> Result<(f64, Vector3<f64>, Rotation3<f64>, f64)> {
    let dt = tagged_field(path, row, line, "dt", 1)?[0];
    if !(dt > 0.0) {
        return Err(csv_err(path, row, "dt", "must be > 0"));
    }
    let p0 = tagged_field(path, row, line, "p0", 3)?;
    let r0 = tagged_field(path, row, line, "r0", 4)?;
    let t_end = tagged_field(path, row, line, "t_end", 1)?[0];
    Ok((
        dt,
        Vector3::new(p0[0], p0[1], p0[2]),
        rotation_from_wxyz([r0[0], r0[1], r0[2], r0[3]]),
        t_end,
    ))
}

fn pose_comment(tag: &str, dt: f64, p0: &Vector3<f64>, r0: &Rotation3<f64>, t_end: f64) -> String {
    let q = UnitQuaternion::from_rotation_matrix(r0);
    format!(
        "{tag} dt={dt:.17e} p0={} r0={} t_end={t_end:.17e}",
        fmt_list(p0.as_slice()),
        fmt_list(&[q.w, q.i, q.j, q.k])
    )
}

/// Writes EFS invariants of a pose trajectory; `t` are the pose times (row `i` gets `t[i]`, the
/// last pose's time is kept for the reconstruction). Initial pose and frames go into a `# efs …`
/// comment line.
pub fn write_efs(path: &Path, t: &[f64], efs: &crate::pose_invariants::EfsPoses) -> Result<()> {
    let rows = efs.rows();
    let t_end = t.get(rows.len()).copied().unwrap_or(f64::NAN);
    let comment = format!(
        "{} linear_frame={} angular_frame={}",
        pose_comment("efs", efs.dt, &efs.p0, &efs.r0, t_end),
        fmt_list(efs.linear.frame0.as_slice()),
        fmt_list(efs.angular.frame0.as_slice())
    );
    write_six(path, &EFS_HEADER, t, &rows, comment)
}

/// Reads a file written by [`write_efs`]: row times, time of the last pose, invariants.
pub fn read_efs(path: &Path) -> Result<(Vec<f64>, f64, crate::pose_invariants::EfsPoses)> {
    use crate::invariants::EfsSignal;
    use nalgebra::Matrix3;
    let text = read_text(path)?;
    let (row, line) = tagged_line(path, &text, "efs")?;
    let (dt, p0, r0, t_end) = pose_fields(path, row, line)?;
    let lf = tagged_field(path, row, line, "linear_frame", 9)?;
    let af = tagged_field(path, row, line, "angular_frame", 9)?;
    let (t, rows) = read_six(path, &text, &EFS_HEADER)?;
    let efs = crate::pose_invariants::EfsPoses {
        dt,
        p0,
        r0,
        linear: EfsSignal {
            rows: rows.iter().map(|r| [r[0], r[1], r[2]]).collect(),
            frame0: Matrix3::from_column_slice(&lf),
        },
        angular: EfsSignal {
            rows: rows.iter().map(|r| [r[3], r[4], r[5]]).collect(),
            frame0: Matrix3::from_column_slice(&af),
        },
    };
    Ok((t, t_end, efs))
}

/// Writes DS invariants of a pose trajectory (as [`write_efs`]; the initial ISA frame goes into
/// a `# ds …` comment line).
pub fn write_ds(path: &Path, t: &[f64], ds: &crate::pose_invariants::DsPoses) -> Result<()> {
    let t_end = t.get(ds.inv.rows.len()).copied().unwrap_or(f64::NAN);
    let comment = format!(
        "{} isa_frame={} isa_origin={}",
        pose_comment("ds", ds.dt, &ds.p0, &ds.r0, t_end),
        fmt_list(ds.inv.frame0.as_slice()),
        fmt_list(ds.inv.origin0.as_slice())
    );
    write_six(path, &DS_HEADER, t, &ds.inv.rows, comment)
}

/// Reads a file written by [`write_ds`]: row times, time of the last pose, invariants.
pub fn read_ds(path: &Path) -> Result<(Vec<f64>, f64, crate::pose_invariants::DsPoses)> {
    use nalgebra::Matrix3;
    let text = read_text(path)?;
    let (row, line) = tagged_line(path, &text, "ds")?;
    let (dt, p0, r0, t_end) = pose_fields(path, row, line)?;
    let f = tagged_field(path, row, line, "isa_frame", 9)?;
    let o = tagged_field(path, row, line, "isa_origin", 3)?;
    let (t, rows) = read_six(path, &text, &DS_HEADER)?;
    let ds = crate::pose_invariants::DsPoses {
        dt,
        p0,
        r0,
        inv: crate::screw::DsInvariants {
            rows,
            frame0: Matrix3::from_column_slice(&f),
            origin0: Vector3::new(o[0], o[1], o[2]),
        },
    };
    Ok((t, t_end, ds))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("cowork_motion_csv_{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let p = dir.join(name);
        std::fs::write(&p, text).expect("write");
        p
    }

    fn err_text(r: Result<Demonstration>) -> String {
        match r {
            Err(e) => e.to_string(),
            Ok(_) => "no error".into(),
        }
    }

    #[test]
    fn reads_demos_with_and_without_velocities() {
        let d =
            read_demonstration(&write("a.csv", "t,x0,x1\n0,0,0\n1,1,2\n2,2,4\n")).expect("demo");
        assert_eq!(d.dim, 2);
        assert_eq!(d.velocity(1), &[1.0, 2.0]);
        let d = read_demonstration(&write("b.csv", "t,x0,v0\n0,0,5\n1,1,6\n")).expect("demo");
        assert_eq!(d.velocity(0), &[5.0]);
    }

    #[test]
    fn bad_files_name_file_row_and_column() {
        let e = err_text(read_demonstration(&write(
            "nan.csv",
            "t,x0,x1\n0,0,0\n1,NaN,2\n",
        )));
        assert!(
            e.contains("nan.csv") && e.contains("row 3") && e.contains("column x0"),
            "{e}"
        );
        let e = err_text(read_demonstration(&write(
            "ragged.csv",
            "t,x0,x1\n0,0,0\n1,1\n",
        )));
        assert!(e.contains("ragged.csv") && e.contains("row 3"), "{e}");
        let e = err_text(read_demonstration(&write("one.csv", "t,x0\n0,0\n")));
        assert!(e.contains("one.csv") && e.contains("at least 2"), "{e}");
        let e = err_text(read_demonstration(&write(
            "hdr.csv",
            "t,x0,y1\n0,0,0\n1,1,1\n",
        )));
        assert!(e.contains("hdr.csv") && e.contains("row 1"), "{e}");
        let e = err_text(read_demonstration(&write("time.csv", "t,x0\n0,0\n0,1\n")));
        assert!(e.contains("row 3") && e.contains("column t"), "{e}");
        let e = err_text(read_demonstration(&write("word.csv", "t,x0\n0,0\n1,abc\n")));
        assert!(e.contains("`abc` is not a number"), "{e}");
    }

    #[test]
    fn dhb_file_round_trip() {
        use crate::dhb::{Dhb, Poses};
        let n = 20;
        let p: Vec<_> = (0..n)
            .map(|i| {
                let t = i as f64 * 0.1;
                Vector3::new(t.cos(), t.sin(), 0.1 * t)
            })
            .collect();
        let r: Vec<_> = (0..n)
            .map(|i| Rotation3::from_euler_angles(0.1 * i as f64, 0.02 * (i * i) as f64, 0.0))
            .collect();
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.1).collect();
        let dhb = Dhb::from_poses(&Poses { p: p.clone(), r }).expect("dhb");
        let path = write("inv.csv", "");
        write_dhb(&path, &t, &dhb).expect("write");
        let (tt, t_end, back) = read_dhb(&path).expect("read");
        // N poses → N − 1 differences → N − 3 rows; the reconstruction has N − 2 poses.
        assert_eq!(tt.len(), n - 3);
        assert!((t_end - t[n - 3]).abs() < 1e-12);
        let rec = back.reconstruct_poses(1.0, &Rotation3::identity(), &Vector3::zeros());
        for (a, b) in rec.p.iter().zip(&p) {
            assert!((a - b).norm() < 1e-12);
        }
        std::fs::write(&path, "t,m_l\n0,1\n").expect("w");
        assert!(read_dhb(&path).is_err());
    }

    #[test]
    fn efs_and_ds_files_round_trip() {
        use crate::pose_invariants::{DsPoses, EfsPoses};
        let n = 200;
        let dt = 0.01;
        let (p, r): (Vec<_>, Vec<_>) = (0..n)
            .map(|i| {
                let t = i as f64 * dt;
                (
                    Vector3::new(t.cos(), t.sin(), 0.1 * t),
                    Rotation3::from_euler_angles(0.5 * t, 0.2 * t * t, 0.1),
                )
            })
            .unzip();
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let poses = Poses { p, r };
        let efs = EfsPoses::from_poses(&poses, dt).expect("efs");
        let path = write("efs.csv", "");
        write_efs(&path, &t, &efs).expect("write");
        let (tt, t_end, back) = read_efs(&path).expect("read");
        assert_eq!(tt.len(), n - 1);
        assert_eq!(t_end, t[n - 1]);
        assert_eq!(back, efs);
        let ds = DsPoses::from_poses(&poses, dt).expect("ds");
        let path = write("ds.csv", "");
        write_ds(&path, &t, &ds).expect("write");
        let (_, _, back) = read_ds(&path).expect("read");
        assert_eq!(back, ds);
        // A DS file is not an EFS file, and a missing field is named.
        assert!(read_efs(&path).is_err());
        let text = std::fs::read_to_string(&path).expect("read");
        std::fs::write(&path, text.replace("isa_origin=", "origin=")).expect("w");
        let e = read_ds(&path)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("isa_origin"), "{e}");
    }

    #[test]
    fn trajectory_round_trip() {
        let tr = Trajectory {
            dim: 1,
            t: vec![0.0, 0.1],
            pos: vec![1.0, 2.0],
            vel: vec![0.5, 0.25],
            reached: false,
        };
        let p = write("out.csv", "");
        write_trajectory(&p, &tr).expect("write");
        let d = read_demonstration(&p).expect("read");
        assert_eq!(d.pos, tr.pos);
        assert_eq!(d.vel, tr.vel);
    }
}
