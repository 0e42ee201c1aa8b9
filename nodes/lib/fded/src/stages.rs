//! Stages 2–7 of the CPU pipeline, each a plain function over [`Buffers`] so the GPU path can
//! mirror them one by one (see [`layout`](crate::layout) for the buffers).

use crate::cam::Cam;
use crate::layout::{Buffers, LinkBest, NO_LINK, RobotPoint};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};

/// Constants of the filtering stage (robot removal, table, depth range).
#[derive(Debug, Clone, Copy)]
pub struct FilterConsts {
    /// δ, m.
    pub delta: f32,
    /// Accepted depth range, m.
    pub min_depth: f32,
    /// Accepted depth range, m.
    pub max_depth: f32,
    /// `Some([r20, r21, r22, t_z, z_limit])`: a pixel at depth d is table when
    /// `d · (r20 · ray_x + r21 · ray_y + r22) + t_z < z_limit` (its base-frame z), where
    /// `r2·` is the last row of the base-from-camera rotation.
    pub table: Option<[f32; 5]>,
}

/// Stage 2 for rows `v0..v0 + rows` (`out` holds those rows of `filtered`): keeps the real
/// depth d only where it is an obstacle — valid (`min_depth ≤ d ≤ max_depth`; 0 and NaN are
/// not), not the robot (`|d − d_r| > δ` or no robot there) and not the table.
pub fn filter_rows(
    depth: &[f32],
    virtual_depth: &[f32],
    ray_x: &[f32],
    ray_y: &[f32],
    k: &FilterConsts,
    v0: usize,
    out: &mut [f32],
) {
    let w = ray_x.len();
    for (r, out_row) in out.chunks_exact_mut(w).enumerate() {
        let v = v0 + r;
        let start = v * w;
        let d_row = &depth[start..start + w];
        let vd_row = &virtual_depth[start..start + w];
        match k.table {
            Some([r20, r21, r22, tz, zlim]) => {
                let row_c = r21 * ray_y[v] + r22;
                for (((o, &d), &dr), &rx) in out_row.iter_mut().zip(d_row).zip(vd_row).zip(ray_x) {
                    let ok = d >= k.min_depth && d <= k.max_depth;
                    let robot = dr > 0.0 && (d - dr).abs() <= k.delta;
                    let table = d * (r20 * rx + row_c) + tz < zlim;
                    *o = if ok && !robot && !table { d } else { 0.0 };
                }
            }
            None => {
                for ((o, &d), &dr) in out_row.iter_mut().zip(d_row).zip(vd_row) {
                    let ok = d >= k.min_depth && d <= k.max_depth;
                    let robot = dr > 0.0 && (d - dr).abs() <= k.delta;
                    *o = if ok && !robot { d } else { 0.0 };
                }
            }
        }
    }
}

/// Stage 3: the robot lattice. For every T_s × T_s tile and link, the robot pixel closest to
/// the tile centre (ties: the first in row-major order) becomes a lattice point; tiles without
/// robot pixels give none.
pub fn robot_lattice(buf: &mut Buffers, tile: u32, links: usize) {
    buf.robot_lattice.clear();
    buf.robot_lattice_pixel.clear();
    let b = buf.robot_box;
    if b.is_empty() {
        return;
    }
    let w = buf.width as usize;
    let t = tile as usize;
    let tiles_x = buf.width.div_ceil(tile) as usize;
    for v in b.v0 as usize..=b.v1 as usize {
        let ty = v / t;
        // Doubled coordinates keep the tile centre (T − 1)/2 integral.
        let dy = (2 * v) as i64 - (2 * ty * t + t - 1) as i64;
        let dy2 = (dy * dy) as u32;
        let row = v * w;
        for u in b.u0 as usize..=b.u1 as usize {
            let l = buf.labels[row + u];
            if l == NO_LINK {
                continue;
            }
            let tx = u / t;
            let dx = (2 * u) as i64 - (2 * tx * t + t - 1) as i64;
            let d2 = (dx * dx) as u32 + dy2;
            let slot = &mut buf.tile_best[(ty * tiles_x + tx) * links + l as usize];
            if d2 < slot[0] {
                *slot = [d2, (row + u) as u32];
            }
        }
    }
    for ty in b.v0 as usize / t..=b.v1 as usize / t {
        for tx in b.u0 as usize / t..=b.u1 as usize / t {
            let base = (ty * tiles_x + tx) * links;
            for l in 0..links {
                let slot = &mut buf.tile_best[base + l];
                if slot[0] == u32::MAX {
                    continue;
                }
                let p = slot[1] as usize;
                *slot = [u32::MAX; 2];
                let d = buf.virtual_depth[p];
                buf.robot_lattice
                    .push([buf.ray_x[p % w] * d, buf.ray_y[p / w] * d, d, l as f32]);
                buf.robot_lattice_pixel.push(p as u32);
            }
        }
    }
}

/// Stage 4: the object lattice — every `step_x`-th column of every `step_y`-th row of
/// `filtered` that holds an obstacle.
pub fn object_lattice(buf: &mut Buffers, step_x: u32, step_y: u32) {
    buf.obj_ray_x.clear();
    buf.obj_ray_y.clear();
    buf.obj_depth.clear();
    buf.obj_pixel.clear();
    let w = buf.width as usize;
    for v in (0..buf.height as usize).step_by(step_y as usize) {
        let row = v * w;
        for u in (0..w).step_by(step_x as usize) {
            let d = buf.filtered[row + u];
            if d > 0.0 {
                buf.obj_ray_x.push(buf.ray_x[u]);
                buf.obj_ray_y.push(buf.ray_y[v]);
                buf.obj_depth.push(d);
                buf.obj_pixel.push((row + u) as u32);
            }
        }
    }
}

/// Object points as a structure of arrays (a sub-range of the object lattice, or any set).
#[derive(Debug, Clone, Copy)]
pub struct Objects<'a> {
    /// `(u − c_x)/f_x` per point.
    pub ray_x: &'a [f32],
    /// `(v − c_y)/f_y` per point.
    pub ray_y: &'a [f32],
    /// Measured depth d_o, m.
    pub depth: &'a [f32],
}

impl<'a> Objects<'a> {
    /// The object lattice of `buf`, points `range`.
    pub fn of(buf: &'a Buffers, range: std::ops::Range<usize>) -> Self {
        Self {
            ray_x: &buf.obj_ray_x[range.clone()],
            ray_y: &buf.obj_ray_y[range.clone()],
            depth: &buf.obj_depth[range],
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.depth.len()
    }

    /// `true` when there are none.
    pub fn is_empty(&self) -> bool {
        self.depth.is_empty()
    }
}

/// Eq. 5.15–5.17, squared: the depth-space distance between robot point `r` (camera frame,
/// `r[2] = d_r`) and the object point on ray `(ox, oy)` at depth `od`, whose depth is first
/// raised to d_r when the robot point lies behind it (the gray area, eq. 5.17).
#[inline(always)]
pub fn dist2(r: &[f32; 3], ox: f32, oy: f32, od: f32) -> f32 {
    let d = if r[2] > od { r[2] } else { od };
    let vx = ox * d - r[0];
    let vy = oy * d - r[1];
    let vz = d - r[2];
    vx * vx + vy * vy + vz * vz
}

const LANES: usize = 8;

/// The smallest [`dist2`] from `r` to any of `obj` (∞ when empty). Eight independent lanes so
/// the loop vectorises.
#[inline]
pub fn min_dist2(r: &[f32; 3], obj: Objects<'_>) -> f32 {
    let (xc, xt) = obj.ray_x.as_chunks::<LANES>();
    let (yc, yt) = obj.ray_y.as_chunks::<LANES>();
    let (dc, dt) = obj.depth.as_chunks::<LANES>();
    let mut m = [f32::INFINITY; LANES];
    for ((x, y), d) in xc.iter().zip(yc).zip(dc) {
        for k in 0..LANES {
            let q = dist2(r, x[k], y[k], d[k]);
            m[k] = if q < m[k] { q } else { m[k] };
        }
    }
    let mut best = f32::INFINITY;
    for ((&x, &y), &d) in xt.iter().zip(yt).zip(dt) {
        let q = dist2(r, x, y, d);
        best = if q < best { q } else { best };
    }
    m.iter().fold(best, |a, &b| if b < a { b } else { a })
}

/// Index and value of the smallest [`dist2`] from `r` to `obj` (first on ties); `None` when
/// `obj` is empty.
pub fn argmin_dist2(r: &[f32; 3], obj: Objects<'_>) -> Option<(usize, f32)> {
    let mut best: Option<(usize, f32)> = None;
    for i in 0..obj.len() {
        let q = dist2(r, obj.ray_x[i], obj.ray_y[i], obj.depth[i]);
        if best.is_none_or(|(_, b)| q < b) {
            best = Some((i, q));
        }
    }
    best
}

/// Stage 5 on a slice of robot lattice points against object points `obj` (the lattice
/// sub-range starting at `obj_offset`): lowers `best[link]` for every robot point that comes
/// closer.
pub fn lattice_minimum(
    robot: &[RobotPoint],
    robot_pixel: &[u32],
    obj: Objects<'_>,
    obj_pixel: &[u32],
    tile_of: impl Fn(u32) -> u32,
    best: &mut [LinkBest],
) {
    for (r, &rp) in robot.iter().zip(robot_pixel) {
        let p = [r[0], r[1], r[2]];
        let l = r[3] as usize;
        let m = min_dist2(&p, obj);
        if m < best[l].dist2
            && let Some((j, q)) = argmin_dist2(&p, obj)
        {
            best[l] = LinkBest {
                dist2: q,
                robot_pixel: rp,
                object_pixel: obj_pixel[j],
                tile: tile_of(rp),
            };
        }
    }
}

/// Stage 6 for one link: every robot pixel of `link` in tile `tile` against `obj`; lowers
/// `best` when one comes closer.
#[allow(clippy::too_many_arguments)]
pub fn refine_tile(
    buf_vd: &[f32],
    labels: &[u8],
    ray_x: &[f32],
    ray_y: &[f32],
    cam: &Cam,
    tile_size: u32,
    tile: u32,
    link: u8,
    obj: Objects<'_>,
    obj_pixel: &[u32],
    best: &mut LinkBest,
) {
    let w = cam.width as usize;
    let t = tile_size as usize;
    let tiles_x = cam.width.div_ceil(tile_size) as usize;
    let (tx, ty) = (tile as usize % tiles_x, tile as usize / tiles_x);
    let u1 = ((tx + 1) * t).min(w);
    let v1 = ((ty + 1) * t).min(cam.height as usize);
    for v in ty * t..v1 {
        let row = v * w;
        for u in tx * t..u1 {
            let i = row + u;
            if labels[i] != link {
                continue;
            }
            let d = buf_vd[i];
            let p = [ray_x[u] * d, ray_y[v] * d, d];
            let m = min_dist2(&p, obj);
            if m < best.dist2
                && let Some((j, q)) = argmin_dist2(&p, obj)
            {
                *best = LinkBest {
                    dist2: q,
                    robot_pixel: i as u32,
                    object_pixel: obj_pixel[j],
                    tile,
                };
            }
        }
    }
}

/// The `refine_obstacle` addition for one link: every obstacle pixel of the real depth within
/// `±(step − 1)` px of the best object pixel against the best robot point, then every robot
/// pixel of the tile against the (possibly new) object pixel.
pub fn refine_obstacle(buf: &Buffers, cam: &Cam, tile_size: u32, step: (u32, u32), link: u8, best: &mut LinkBest) {
    if !best.is_some() {
        return;
    }
    let w = cam.width as usize;
    let h = cam.height as usize;
    let rp = best.robot_pixel as usize;
    let d = buf.virtual_depth[rp];
    let r = [buf.ray_x[rp % w] * d, buf.ray_y[rp / w] * d, d];
    let op = best.object_pixel as usize;
    let (ou, ov) = (op % w, op / w);
    let (sx, sy) = (step.0 as usize - 1, step.1 as usize - 1);
    for v in ov.saturating_sub(sy)..(ov + sy + 1).min(h) {
        let row = v * w;
        for u in ou.saturating_sub(sx)..(ou + sx + 1).min(w) {
            let od = buf.filtered[row + u];
            if od > 0.0 {
                let q = dist2(&r, buf.ray_x[u], buf.ray_y[v], od);
                if q < best.dist2 {
                    best.dist2 = q;
                    best.object_pixel = (row + u) as u32;
                }
            }
        }
    }
    let op = best.object_pixel as usize;
    let (ou, ov) = (op % w, op / w);
    let one = Objects {
        ray_x: std::slice::from_ref(&buf.ray_x[ou]),
        ray_y: std::slice::from_ref(&buf.ray_y[ov]),
        depth: std::slice::from_ref(&buf.filtered[op]),
    };
    let pix = [op as u32];
    refine_tile(
        &buf.virtual_depth,
        &buf.labels,
        &buf.ray_x,
        &buf.ray_y,
        cam,
        tile_size,
        best.tile,
        link,
        one,
        &pix,
        best,
    );
}

/// Stage 7: the obstacle normal at pixel `object_pixel` (camera frame, unit), from a weighted
/// least-squares plane through the obstacle pixels of a square window of about `window_points`
/// pixels around it (thesis: L = 1 % of the image), weights `exp(−‖p − o‖² / σ²)`; oriented
/// towards `toward` (the robot point). `None` when fewer than 3 points or a degenerate fit.
pub fn obstacle_normal(
    buf: &Buffers,
    object_pixel: u32,
    window_points: usize,
    sigma: f32,
    toward: &Vector3<f32>,
) -> Option<Vector3<f32>> {
    let w = buf.width as usize;
    let h = buf.height as usize;
    let op = object_pixel as usize;
    let (ou, ov) = (op % w, op / w);
    let d0 = buf.filtered[op];
    if d0 <= 0.0 {
        return None;
    }
    let o = Vector3::new(buf.ray_x[ou] * d0, buf.ray_y[ov] * d0, d0);
    let half = ((window_points as f64).sqrt() / 2.0).ceil() as usize;
    let inv_s2 = 1.0 / (sigma * sigma);
    let mut sw = 0.0f64;
    let mut s1 = Vector3::<f64>::zeros();
    let mut s2 = Matrix3::<f64>::zeros();
    let mut count = 0usize;
    for v in ov.saturating_sub(half)..(ov + half + 1).min(h) {
        let row = v * w;
        let ry = buf.ray_y[v];
        for u in ou.saturating_sub(half)..(ou + half + 1).min(w) {
            let d = buf.filtered[row + u];
            if d <= 0.0 {
                continue;
            }
            let p = Vector3::new(buf.ray_x[u] * d, ry * d, d);
            let q = p - o;
            let wgt = (-q.norm_squared() * inv_s2).exp();
            if wgt < 1e-6 {
                continue;
            }
            let (wgt, q) = (f64::from(wgt), q.cast::<f64>());
            sw += wgt;
            s1 += q * wgt;
            s2 += q * q.transpose() * wgt;
            count += 1;
        }
    }
    if count < 3 || sw <= 0.0 {
        return None;
    }
    let mean = s1 / sw;
    let cov = s2 / sw - mean * mean.transpose();
    let eig = SymmetricEigen::new(cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    // A line-like patch (two tiny eigenvalues) defines no plane.
    if eig.eigenvalues[order[1]] <= 1e-12 {
        return None;
    }
    let n: Vector3<f32> = eig.eigenvectors.column(order[0]).into_owned().cast();
    let n = n.try_normalize(1e-6)?;
    Some(if n.dot(&(toward - o)) < 0.0 { -n } else { n })
}
