//! Stages 2–7 of the CPU pipeline, each a plain function over [`Buffers`] (see
//! [`layout`](crate::layout) for the buffers). The GPU path shares stages 1–4 and 7 with the
//! CPU (they run on the host) and mirrors 5–6 in `fded.wgsl`.

use crate::cam::Cam;
use crate::layout::{Buffers, LinkBest, RobotPoint};
use crate::raster::{DepthBlocks, Grid, Removal, RobotMeshes, RobotView, Samples, mark_robot};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};

/// The table plane seen from the camera: a pixel's base-frame z is
/// `d · (r20 · ray_x + r21 · ray_y + r22) + t_z` at depth d.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TablePlane {
    /// Last row of the base-from-camera rotation.
    pub r2: [f32; 3],
    /// Camera height in the base frame, m.
    pub tz: f32,
    /// Points below this base-frame z are table (table top + margin), m.
    pub z_limit: f32,
    /// The table top, base-frame z, m: the gray area behind an obstacle ends there.
    pub z_top: f32,
}

/// What makes a valid reading an obstacle candidate: depth range and table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Classify {
    /// Accepted depth range, m.
    pub min_depth: f32,
    /// Accepted depth range, m.
    pub max_depth: f32,
    /// The table, if handled.
    pub table: Option<TablePlane>,
}

impl Classify {
    /// `true` when depth `d` on ray `(rx, ry)` is valid (in range; 0 and NaN are not) and not
    /// the table. Robot removal is separate ([`mark_robot`]).
    #[inline]
    pub fn candidate(&self, d: f32, rx: f32, ry: f32) -> bool {
        if !(d >= self.min_depth && d <= self.max_depth) {
            return false;
        }
        match self.table {
            Some(t) => d * (t.r2[0] * rx + t.r2[1] * ry + t.r2[2]) + t.tz >= t.z_limit,
            None => true,
        }
    }

    /// The largest depth the gray area (eq. 5.17) of an obstacle at depth `d` on ray
    /// `(rx, ry)` may take: where the ray meets the table top (nothing is hidden under the
    /// table), never less than `d`; ∞ without a table or for rays that do not descend.
    #[inline]
    pub fn gray_cap(&self, d: f32, rx: f32, ry: f32) -> f32 {
        match self.table {
            Some(t) => {
                let slope = t.r2[0] * rx + t.r2[1] * ry + t.r2[2];
                if slope < 0.0 { ((t.z_top - t.tz) / slope).max(d) } else { f32::INFINITY }
            }
            None => f32::INFINITY,
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
    /// Gray-area cap ([`Classify::gray_cap`]), m.
    pub cap: &'a [f32],
}

impl Objects<'_> {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.depth.len()
    }
}

/// Eq. 5.15–5.17, squared: the depth-space distance between robot point `r` (camera frame,
/// `r[2] = d_r`) and the object point on ray `(ox, oy)` at depth `od`, whose depth is first
/// raised to d_r when the robot point lies behind it (the gray area, eq. 5.17) — but not
/// beyond `cap`, where the ray meets the table.
#[inline(always)]
pub fn dist2(r: &[f32; 3], ox: f32, oy: f32, od: f32, cap: f32) -> f32 {
    let d = if r[2] > od { r[2] } else { od };
    let d = if d > cap { cap } else { d };
    let vx = ox * d - r[0];
    let vy = oy * d - r[1];
    let vz = d - r[2];
    vx * vx + vy * vy + vz * vz
}

/// The depth the object point on ray `(ox, oy)` at `od` takes against robot depth `dr` (eq.
/// 5.17 with the table cap).
#[inline]
pub fn gray_depth(dr: f32, od: f32, cap: f32) -> f32 {
    let d = if dr > od { dr } else { od };
    if d > cap { cap } else { d }
}

const LANES: usize = 8;

/// The smallest [`dist2`] from `r` to any of `obj` (∞ when empty). Eight independent lanes so
/// the loop vectorises.
#[inline]
pub fn min_dist2(r: &[f32; 3], obj: Objects<'_>) -> f32 {
    let (xc, xt) = obj.ray_x.as_chunks::<LANES>();
    let (yc, yt) = obj.ray_y.as_chunks::<LANES>();
    let (dc, dt) = obj.depth.as_chunks::<LANES>();
    let (cc, ct) = obj.cap.as_chunks::<LANES>();
    let mut m = [f32::INFINITY; LANES];
    for (((x, y), d), c) in xc.iter().zip(yc).zip(dc).zip(cc) {
        for k in 0..LANES {
            let q = dist2(r, x[k], y[k], d[k], c[k]);
            m[k] = if q < m[k] { q } else { m[k] };
        }
    }
    let mut best = f32::INFINITY;
    for (((&x, &y), &d), &c) in xt.iter().zip(yt).zip(dt).zip(ct) {
        let q = dist2(r, x, y, d, c);
        best = if q < best { q } else { best };
    }
    m.iter().fold(best, |a, &b| if b < a { b } else { a })
}

/// Index and value of the smallest [`dist2`] from `r` to `obj` (first on ties); `None` when
/// `obj` is empty.
pub fn argmin_dist2(r: &[f32; 3], obj: Objects<'_>) -> Option<(usize, f32)> {
    let mut best: Option<(usize, f32)> = None;
    for i in 0..obj.len() {
        let q = dist2(r, obj.ray_x[i], obj.ray_y[i], obj.depth[i], obj.cap[i]);
        if best.is_none_or(|(_, b)| q < b) {
            best = Some((i, q));
        }
    }
    best
}

/// Stage 2: the candidate depth of every object lattice sample ([`Buffers::lattice_depth`])
/// and robot removal at those samples ([`Buffers::lattice_robot`]), from the frame's real
/// depth.
pub fn remove_robot_at_lattice(meshes: &RobotMeshes, depth: &[f32], step: (u32, u32), k: &Classify, removal: &Removal, buf: &mut Buffers) {
    let Buffers {
        width,
        ray_x,
        ray_y,
        robot,
        lattice_nx,
        lattice_ny,
        lattice_depth,
        lattice_robot,
        depth_blocks,
        ..
    } = buf;
    let (w, nx) = (*width as usize, *lattice_nx as usize);
    let mut zr = [f32::INFINITY, f32::NEG_INFINITY];
    for (j, out) in lattice_depth.chunks_exact_mut(nx).enumerate() {
        let v = j * step.1 as usize;
        let (row, ry) = (&depth[v * w..(v + 1) * w], ray_y[v]);
        for (i, o) in out.iter_mut().enumerate() {
            let u = i * step.0 as usize;
            let d = row[u];
            *o = if k.candidate(d, ray_x[u], ry) {
                zr = [zr[0].min(d), zr[1].max(d)];
                d
            } else {
                0.0
            };
        }
    }
    let samples = Samples {
        grid: Grid {
            u0: 0,
            v0: 0,
            su: step.0,
            sv: step.1,
            nx: *lattice_nx,
            ny: *lattice_ny,
        },
        depth: lattice_depth,
        stride: nx,
        zrange: zr,
    };
    let view = robot.view(meshes);
    lattice_robot.fill(0);
    mark_robot(&view, &samples, depth_blocks, removal, None, lattice_robot);
}

/// Stage 3: the robot lattice, in one pass over the robot points: each in-image point falls
/// in the (T_s × T_s tile, link) slot of its nearest pixel; per slot the point whose
/// projection is closest to the tile centre (ties: the lowest index) becomes a lattice point,
/// with the slot's point count; slots without points give none. Lattice points come in
/// ascending slot order. The slots' point lists are built later, for the slots that need them
/// ([`gather_slot`], or [`group_slots`] for all).
pub fn robot_lattice(buf: &mut Buffers) {
    let Buffers {
        cam_points,
        point_uv,
        col_slot,
        col_centre,
        row_slot,
        row_centre,
        slot_count,
        slot_best,
        active_slots,
        point_slot,
        ..
    } = buf;
    for &s in active_slots.iter() {
        slot_count[s as usize] = 0;
    }
    active_slots.clear();
    // Slices, not `Vec`s, in the loop: their pointers stay in registers.
    let (col_slot, col_centre, row_slot, row_centre) = (&col_slot[..], &col_centre[..], &row_slot[..], &row_centre[..]);
    let (slot_count, slot_best) = (&mut slot_count[..], &mut slot_best[..]);
    for (i, ((uv, p), ps)) in point_uv.iter().zip(cam_points.iter()).zip(point_slot.iter_mut()).enumerate() {
        if uv[0].is_nan() {
            *ps = u32::MAX;
            continue;
        }
        // Nearest pixel (u ≥ −0.5, so truncation is the floor; < width − 0.5 when not NaN).
        let (pu, pv) = ((uv[0] + 0.5) as i32 as usize, (uv[1] + 0.5) as i32 as usize);
        let slot = row_slot[pv] + col_slot[pu] + p[3] as i32 as u32;
        *ps = slot;
        let d = (uv[0] - col_centre[pu]).powi(2) + (uv[1] - row_centre[pv]).powi(2);
        let (count, best) = (&mut slot_count[slot as usize], &mut slot_best[slot as usize]);
        if *count == 0 {
            active_slots.push(slot);
            *best = (d, i as u32);
        } else if d < best.0 {
            *best = (d, i as u32);
        }
        *count += 1;
    }
    buf.active_slots.sort_unstable();
    buf.robot_lattice.clear();
    buf.robot_lattice_info.clear();
    buf.slot_bounds.clear();
    for &s in &buf.active_slots {
        let best = buf.slot_best[s as usize].1;
        buf.robot_lattice.push(buf.cam_points[best as usize]);
        buf.robot_lattice_info.push([best, s, u32::MAX, buf.slot_count[s as usize]]);
        buf.slot_bounds.push(EMPTY_BOUNDS);
    }
    buf.slot_points.clear();
    buf.slot_x.clear();
    buf.slot_y.clear();
    buf.slot_z.clear();
}

/// The bounds of no point.
const EMPTY_BOUNDS: [f32; 6] = [f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY];

/// `b` grown to hold point `p`.
#[inline]
fn grow(b: [f32; 6], p: &RobotPoint) -> [f32; 6] {
    let lo = |a: f32, x: f32| if x < a { x } else { a };
    let hi = |a: f32, x: f32| if x > a { x } else { a };
    [lo(b[0], p[0]), hi(b[1], p[0]), lo(b[2], p[1]), hi(b[3], p[1]), lo(b[4], p[2]), hi(b[5], p[2])]
}

/// Lists the points of robot lattice entry `entry`'s slot (ascending index) in
/// [`Buffers::slot_points`] and its coordinates, and records where in its info; `points` is
/// the range of the slot's link in the robot point set (all its points are there). No-op when
/// already listed this frame.
pub fn gather_slot(buf: &mut Buffers, entry: usize, points: std::ops::Range<usize>) {
    let [_, slot, first, _] = buf.robot_lattice_info[entry];
    if first != u32::MAX {
        return;
    }
    let start = buf.slot_points.len();
    let mut b = EMPTY_BOUNDS;
    let first = points.start;
    for (k, &s) in buf.point_slot[points].iter().enumerate() {
        if s == slot {
            let (i, p) = (first + k, buf.cam_points[first + k]);
            buf.slot_points.push(i as u32);
            buf.slot_x.push(p[0]);
            buf.slot_y.push(p[1]);
            buf.slot_z.push(p[2]);
            b = grow(b, &p);
        }
    }
    buf.slot_bounds[entry] = b;
    debug_assert_eq!((buf.slot_points.len() - start) as u32, buf.robot_lattice_info[entry][3]);
    buf.robot_lattice_info[entry][2] = start as u32;
}

/// Lists the points of every slot: grouped by slot in lattice order, ascending index within a
/// slot (what the GPU path uploads). Replaces any earlier lists of this frame.
pub fn group_slots(buf: &mut Buffers) {
    buf.slot_points.clear();
    buf.slot_x.clear();
    buf.slot_y.clear();
    buf.slot_z.clear();
    let mut first = 0u32;
    for (e, (info, b)) in buf.robot_lattice_info.iter_mut().zip(buf.slot_bounds.iter_mut()).enumerate() {
        info[2] = first;
        buf.slot_best[info[1] as usize].1 = first;
        buf.slot_entry[info[1] as usize] = e as u32;
        first += info[3];
        *b = EMPTY_BOUNDS;
    }
    buf.slot_points.resize(first as usize, 0);
    buf.slot_x.resize(first as usize, 0.0);
    buf.slot_y.resize(first as usize, 0.0);
    buf.slot_z.resize(first as usize, 0.0);
    // `slot_best[s].1` is the write cursor of slot s from here on.
    for i in 0..buf.point_slot.len() {
        let s = buf.point_slot[i];
        if s == u32::MAX {
            continue;
        }
        let at = buf.slot_best[s as usize].1 as usize;
        buf.slot_best[s as usize].1 += 1;
        let p = buf.cam_points[i];
        let e = buf.slot_entry[s as usize] as usize;
        buf.slot_bounds[e] = grow(buf.slot_bounds[e], &p);
        buf.slot_points[at] = i as u32;
        buf.slot_x[at] = p[0];
        buf.slot_y[at] = p[1];
        buf.slot_z[at] = p[2];
    }
}

/// Stage 4: the object lattice — every `step.0`-th column of every `step.1`-th row whose
/// depth is a candidate ([`Classify::candidate`]) and that robot removal did not take (both
/// from stage 2).
pub fn object_lattice(buf: &mut Buffers, step: (u32, u32), k: &Classify) {
    buf.obj_ray_x.clear();
    buf.obj_ray_y.clear();
    buf.obj_depth.clear();
    buf.obj_cap.clear();
    buf.obj_pixel.clear();
    let w = buf.width as usize;
    let nx = buf.lattice_nx as usize;
    for j in 0..buf.lattice_ny as usize {
        let v = j * step.1 as usize;
        let ry = buf.ray_y[v];
        let flags = &buf.lattice_robot[j * nx..(j + 1) * nx];
        let depths = &buf.lattice_depth[j * nx..(j + 1) * nx];
        for (i, (&f, &d)) in flags.iter().zip(depths).enumerate() {
            if f != 0 || d <= 0.0 {
                continue;
            }
            let u = i * step.0 as usize;
            let rx = buf.ray_x[u];
            buf.obj_ray_x.push(rx);
            buf.obj_ray_y.push(ry);
            buf.obj_depth.push(d);
            buf.obj_cap.push(k.gray_cap(d, rx, ry));
            buf.obj_pixel.push((v * w + u) as u32);
        }
    }
}

/// Stage 5 on robot lattice points `robot` (entries `first..` of the lattice, with `info`)
/// against object points `obj`: lowers `best[link]` for every robot point that comes closer.
pub fn lattice_minimum(
    robot: &[RobotPoint],
    info: &[[u32; 4]],
    first: usize,
    obj: Objects<'_>,
    obj_pixel: &[u32],
    best: &mut [LinkBest],
) {
    for (k, (r, inf)) in robot.iter().zip(info).enumerate() {
        let p = [r[0], r[1], r[2]];
        let l = r[3] as usize;
        let m = min_dist2(&p, obj);
        if m < best[l].dist2
            && let Some((j, q)) = argmin_dist2(&p, obj)
        {
            best[l] = LinkBest {
                dist2: q,
                robot_point: inf[0],
                object_pixel: obj_pixel[j],
                lattice: (first + k) as u32,
            };
        }
    }
}

/// The robot points of one slot as listed by [`gather_slot`] / [`group_slots`]: point
/// indices and camera-frame coordinates (structure of arrays, so the distance loop
/// vectorises).
#[derive(Debug, Clone, Copy)]
pub struct SlotPoints<'a> {
    /// Index of each point in the robot point set.
    pub index: &'a [u32],
    /// x, m.
    pub x: &'a [f32],
    /// y, m.
    pub y: &'a [f32],
    /// z (= d_r), m.
    pub z: &'a [f32],
    /// Their bounding box `[x_min, x_max, y_min, y_max, z_min, z_max]`, m.
    pub bounds: [f32; 6],
}

impl<'a> SlotPoints<'a> {
    /// The points of robot lattice entry `entry` in `buf` (listed).
    pub fn of(buf: &'a Buffers, entry: usize) -> Self {
        let info = buf.robot_lattice_info[entry];
        let r = info[2] as usize..(info[2] + info[3]) as usize;
        Self {
            index: &buf.slot_points[r.clone()],
            x: &buf.slot_x[r.clone()],
            y: &buf.slot_y[r.clone()],
            z: &buf.slot_z[r],
            bounds: buf.slot_bounds[entry],
        }
    }
}

/// The smallest [`dist2`] from the object point on ray `(ox, oy)` at depth `od` (gray-area
/// cap `cap`) to any point of `pts` (∞ when empty). Eight independent lanes so the loop
/// vectorises.
#[inline]
fn min_dist2_points(ox: f32, oy: f32, od: f32, cap: f32, pts: &SlotPoints<'_>) -> f32 {
    let (xc, xt) = pts.x.as_chunks::<LANES>();
    let (yc, yt) = pts.y.as_chunks::<LANES>();
    let (zc, zt) = pts.z.as_chunks::<LANES>();
    let mut m = [f32::INFINITY; LANES];
    for ((x, y), z) in xc.iter().zip(yc).zip(zc) {
        for k in 0..LANES {
            let q = dist2(&[x[k], y[k], z[k]], ox, oy, od, cap);
            m[k] = if q < m[k] { q } else { m[k] };
        }
    }
    let mut best = f32::INFINITY;
    for ((&x, &y), &z) in xt.iter().zip(yt).zip(zt) {
        let q = dist2(&[x, y, z], ox, oy, od, cap);
        best = if q < best { q } else { best };
    }
    m.iter().fold(best, |a, &b| if b < a { b } else { a })
}

/// Stage 6 for one link: every robot point of lattice entry `lattice`'s slot (`pts`) against
/// every object point of `obj`; lowers `best` when a pair comes closer (the closest pair,
/// ties: the first point of the slot, then the first object point). Object points whose
/// distance to the slot's bounding box (with the gray area over the slot's depth range) is
/// already no better than `best` are skipped without visiting the points.
pub fn refine_slot(pts: &SlotPoints<'_>, lattice: u32, obj: Objects<'_>, obj_pixel: &[u32], best: &mut LinkBest) {
    if pts.index.is_empty() {
        return;
    }
    let b = pts.bounds;
    let (bx, by, bz) = ([b[0], b[1]], [b[2], b[3]], [b[4], b[5]]);
    let gap = |lo: f32, hi: f32, b: [f32; 2]| {
        let g = (lo - b[1]).max(b[0] - hi).max(0.0);
        g * g
    };
    let mut found: Option<(f32, usize, usize)> = None;
    for j in 0..obj.len() {
        let (ox, oy, od, cap) = (obj.ray_x[j], obj.ray_y[j], obj.depth[j], obj.cap[j]);
        // The object point's depth against any slot point lies in [dlo, dhi] (eq. 5.17).
        let (dlo, dhi) = (gray_depth(bz[0], od, cap), gray_depth(bz[1], od, cap));
        let (x0, x1) = (ox * dlo, ox * dhi);
        let (y0, y1) = (oy * dlo, oy * dhi);
        let bound = gap(x0.min(x1), x0.max(x1), bx) + gap(y0.min(y1), y0.max(y1), by) + gap(dlo, dhi, bz);
        // Rounding slack: a bound a few ulps above a true distance must not skip it.
        if bound > best.dist2 * (1.0 + 1e-5) {
            continue;
        }
        let m = min_dist2_points(ox, oy, od, cap, pts);
        let tie = found.is_some_and(|f| m == f.0);
        if m < best.dist2 || tie {
            let pos = (0..pts.index.len())
                .find(|&p| dist2(&[pts.x[p], pts.y[p], pts.z[p]], ox, oy, od, cap) == m)
                .unwrap_or(0);
            if !tie || found.is_some_and(|f| pos < f.1) {
                found = Some((m, pos, j));
                best.dist2 = m;
            }
        }
    }
    if let Some((m, pos, j)) = found {
        *best = LinkBest {
            dist2: m,
            robot_point: pts.index[pos],
            object_pixel: obj_pixel[j],
            lattice,
        };
    }
}

/// Classifies the pixels of rectangle `rect = (u0, v0, nw, nh)` of the real `depth` (`width`
/// px per row): `out[j · stride + i]` gets the depth of pixel `(u0 + i, v0 + j)` when `keep(d,
/// ray_x, ray_y)` holds and robot removal does not take it, else 0; `flags` the removal flags.
/// `keep` must imply [`Classify::candidate`]; `focus` as in [`mark_robot`].
#[allow(clippy::too_many_arguments)]
fn classify_into(
    view: &RobotView<'_>,
    depth: &[f32],
    width: usize,
    rays: (&[f32], &[f32]),
    removal: &Removal,
    rect: (u32, u32, u32, u32),
    keep: impl Fn(f32, f32, f32) -> bool,
    focus: Option<[f32; 4]>,
    blocks: &mut DepthBlocks,
    (out, flags, stride): (&mut [f32], &mut [u8], usize),
) {
    let (u0, v0, nw, nh) = (rect.0 as usize, rect.1 as usize, rect.2 as usize, rect.3 as usize);
    if nw == 0 || nh == 0 {
        return;
    }
    // The kept pixels' bounding box (columns, rows) and depth range.
    let (mut cols, mut rows, mut zr) = ([usize::MAX, 0], [usize::MAX, 0], [f32::INFINITY, f32::NEG_INFINITY]);
    for j in 0..nh {
        let (v, at) = (v0 + j, j * stride..j * stride + nw);
        let ry = rays.1[v];
        let row = &depth[v * width + u0..v * width + u0 + nw];
        for (i, ((o, &d), &rx)) in out[at.clone()].iter_mut().zip(row).zip(&rays.0[u0..u0 + nw]).enumerate() {
            *o = if keep(d, rx, ry) {
                cols = [cols[0].min(i), cols[1].max(i)];
                rows = [rows[0].min(j), rows[1].max(j)];
                zr = [zr[0].min(d), zr[1].max(d)];
                d
            } else {
                0.0
            };
        }
        flags[at].fill(0);
    }
    if cols[0] > cols[1] {
        return;
    }
    // Removal needs only the box of the kept pixels.
    let first = rows[0] * stride + cols[0];
    let samples = Samples {
        grid: Grid {
            u0: rect.0 + cols[0] as u32,
            v0: rect.1 + rows[0] as u32,
            su: 1,
            sv: 1,
            nx: (cols[1] - cols[0] + 1) as u32,
            ny: (rows[1] - rows[0] + 1) as u32,
        },
        depth: &out[first..],
        stride,
        zrange: zr,
    };
    if !mark_robot(view, &samples, blocks, removal, focus, &mut flags[first..]) {
        return;
    }
    for j in 0..nh {
        let at = j * stride..j * stride + nw;
        for (o, &r) in out[at.clone()].iter_mut().zip(&flags[at]) {
            if r != 0 {
                *o = 0.0;
            }
        }
    }
}

/// Every pixel of the image classified into [`Buffers::filtered`] (obstacle depth, or 0: no
/// candidate depth, or removed as the robot) and [`Buffers::robot_flags`] — for methods that
/// read every pixel (brute force, Flacco et al.).
pub fn classify_full(meshes: &RobotMeshes, depth: &[f32], k: &Classify, removal: &Removal, buf: &mut Buffers) {
    let Buffers {
        width,
        height,
        ray_x,
        ray_y,
        robot,
        depth_blocks,
        filtered,
        robot_flags,
        ..
    } = buf;
    let view = robot.view(meshes);
    let w = *width as usize;
    let rect = (0, 0, *width, *height);
    let keep = |d, rx, ry| k.candidate(d, rx, ry);
    classify_into(&view, depth, w, (ray_x, ray_y), removal, rect, keep, None, depth_blocks, (filtered, robot_flags, w));
}

/// Classifies the window `win = (u0, v0, nw, nh)` into [`Buffers::window`] (row stride `nw`):
/// the pixels for which `keep(d, ray_x, ray_y)` holds — it must imply
/// [`Classify::candidate`]; callers keep only the pixels that can change their result, which
/// lets robot removal skip every triangle far from them — and that robot removal does not
/// take (`focus` as in [`mark_robot`]).
pub fn classify_window(
    meshes: &RobotMeshes,
    depth: &[f32],
    removal: &Removal,
    win: (u32, u32, u32, u32),
    keep: impl Fn(f32, f32, f32) -> bool,
    focus: Option<[f32; 4]>,
    buf: &mut Buffers,
) {
    let Buffers {
        width,
        ray_x,
        ray_y,
        robot,
        depth_blocks,
        window,
        window_robot,
        ..
    } = buf;
    let view = robot.view(meshes);
    let target = (&mut window[..], &mut window_robot[..], win.2 as usize);
    classify_into(&view, depth, *width as usize, (ray_x, ray_y), removal, win, keep, focus, depth_blocks, target);
}

/// A window of `half` px around pixel `p`, clipped to the image: `(u0, v0, nw, nh)`.
pub fn window_around(p: u32, half: (u32, u32), width: u32, height: u32) -> (u32, u32, u32, u32) {
    let (u, v) = (p % width, p / width);
    let u0 = u.saturating_sub(half.0);
    let v0 = v.saturating_sub(half.1);
    let u1 = (u + half.0).min(width - 1);
    let v1 = (v + half.1).min(height - 1);
    (u0, v0, u1 - u0 + 1, v1 - v0 + 1)
}

/// The `refine_obstacle` addition for one link, after [`classify_window`] classified the
/// window `(u0, v0, nw, nh)` around the best object pixel (±(S − 1) px), keeping the pixels
/// closer to the best robot point than the best pair: the closest of them, then every robot
/// point of the slot (listed by [`gather_slot`]) against the (possibly new) object pixel.
/// `depth` is the frame's depth.
pub fn refine_obstacle(buf: &Buffers, depth: &[f32], k: &Classify, win: (u32, u32, u32, u32), best: &mut LinkBest) {
    if !best.is_some() {
        return;
    }
    let w = buf.width as usize;
    let rp = buf.cam_points[best.robot_point as usize];
    let r = [rp[0], rp[1], rp[2]];
    let (u0, v0, nw, nh) = (win.0 as usize, win.1 as usize, win.2 as usize, win.3 as usize);
    for j in 0..nh {
        let v = v0 + j;
        let ry = buf.ray_y[v];
        for (i, &od) in buf.window[j * nw..(j + 1) * nw].iter().enumerate() {
            if od > 0.0 {
                let u = u0 + i;
                let rx = buf.ray_x[u];
                let q = dist2(&r, rx, ry, od, k.gray_cap(od, rx, ry));
                if q < best.dist2 {
                    best.dist2 = q;
                    best.object_pixel = (v * w + u) as u32;
                }
            }
        }
    }
    let op = best.object_pixel as usize;
    let od = depth[op];
    let (rx, ry) = (buf.ray_x[op % w], buf.ray_y[op / w]);
    let cap = k.gray_cap(od, rx, ry);
    let one = Objects {
        ray_x: std::slice::from_ref(&rx),
        ray_y: std::slice::from_ref(&ry),
        depth: std::slice::from_ref(&od),
        cap: std::slice::from_ref(&cap),
    };
    let pix = [op as u32];
    let lattice = best.lattice;
    refine_slot(&SlotPoints::of(buf, lattice as usize), lattice, one, &pix, best);
}

/// Squared radius around the obstacle point beyond which a pixel's normal-fit weight
/// `exp(−‖p − o‖² / σ²)` is below 10⁻⁶ and the pixel is dropped, m².
pub fn normal_cut2(sigma: f32) -> f32 {
    13.8 * sigma * sigma
}

/// Stage 7: the obstacle normal at camera-frame point `o` (unit, unoriented), from a weighted
/// least-squares plane through the obstacle pixels of the window `(u0, v0, nw, nh)`
/// classified by [`classify_window`] (thesis: L = 1 % of the image's points) — in
/// [`Buffers::window`] with row stride `stride` from index `first` — weights
/// `exp(−‖p − o‖² / σ²)`, pixels beyond [`normal_cut2`] dropped. `None` when fewer than 3
/// points or a degenerate fit.
pub fn obstacle_normal(buf: &Buffers, (stride, first): (usize, usize), win: (u32, u32, u32, u32), o: [f32; 3], sigma: f32) -> Option<Vector3<f32>> {
    let (u0, v0, nw, nh) = (win.0 as usize, win.1 as usize, win.2 as usize, win.3 as usize);
    let inv_s2 = 1.0 / (sigma * sigma);
    let cut = normal_cut2(sigma);
    // Σw, Σw·q, Σw·q·qᵀ (upper triangle), Σ[w > 0], per lane; q = p − o (small, so f32 holds).
    let mut acc = [[0.0f32; LANES]; 11];
    let mut lane = [0.0f32; LANES];
    let mut add = |d: &[f32], x: &[f32], ry: f32| {
        for (k, (&d, &rx)) in d.iter().zip(x).enumerate() {
            let q = [rx * d - o[0], ry * d - o[1], d - o[2]];
            let n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
            let w = exp_neg((-n2 * inv_s2).max(-87.0));
            lane[k] = if (d > 0.0) & (n2 <= cut) { w } else { 0.0 };
        }
        for (k, (&d, &rx)) in d.iter().zip(x).enumerate() {
            let (w, q) = (lane[k], [rx * d - o[0], ry * d - o[1], d - o[2]]);
            let (wx, wy, wz) = (w * q[0], w * q[1], w * q[2]);
            acc[0][k] += w;
            acc[1][k] += wx;
            acc[2][k] += wy;
            acc[3][k] += wz;
            acc[4][k] += wx * q[0];
            acc[5][k] += wx * q[1];
            acc[6][k] += wx * q[2];
            acc[7][k] += wy * q[1];
            acc[8][k] += wy * q[2];
            acc[9][k] += wz * q[2];
            acc[10][k] += if w > 0.0 { 1.0 } else { 0.0 };
        }
    };
    for j in 0..nh {
        let ry = buf.ray_y[v0 + j];
        let row = first + j * stride;
        let (dc, dt) = buf.window[row..row + nw].as_chunks::<LANES>();
        let (xc, xt) = buf.ray_x[u0..u0 + nw].as_chunks::<LANES>();
        for (d, x) in dc.iter().zip(xc) {
            // Whole groups outside the kept set (no candidate, beyond the cut) cost nothing.
            if d.iter().any(|&v| v > 0.0) {
                add(d, x, ry);
            }
        }
        add(dt, xt, ry);
    }
    let sum = |k: usize| acc[k].iter().map(|&x| f64::from(x)).sum::<f64>();
    let (sw, count) = (sum(0), sum(10));
    if count < 3.0 || sw <= 0.0 {
        return None;
    }
    let mean = Vector3::new(sum(1), sum(2), sum(3)) / sw;
    let s2 = Matrix3::new(sum(4), sum(5), sum(6), sum(5), sum(7), sum(8), sum(6), sum(8), sum(9));
    let cov = s2 / sw - mean * mean.transpose();
    let eig = SymmetricEigen::new(cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    // A line-like patch (two tiny eigenvalues) defines no plane.
    if eig.eigenvalues[order[1]] <= 1e-12 {
        return None;
    }
    let n: Vector3<f32> = eig.eigenvectors.column(order[0]).into_owned().cast();
    n.try_normalize(1e-6)
}

/// `e^x` for `x ≤ 0` (relative error < 2·10⁻⁵; 0 below −87) without a libm call.
#[inline(always)]
pub fn exp_neg(x: f32) -> f32 {
    let y = (x * std::f32::consts::LOG2_E).max(-126.0);
    let n = crate::raster::floor_i(y);
    let f = y - n as f32;
    // 2^f on [0, 1): Taylor series of e^(f ln 2) to degree 6.
    let p = 1.0
        + f * (std::f32::consts::LN_2
            + f * (0.240_226_5 + f * (0.055_504_11 + f * (0.009_618_129 + f * (0.001_333_356 + f * 0.000_154_035_3)))));
    f32::from_bits(((n + 127) as u32) << 23) * p
}

/// The camera model's ray tables.
pub fn rays(cam: &Cam, ray_x: &mut [f32], ray_y: &mut [f32], k: &cowork_depth::Intrinsics) {
    debug_assert_eq!(ray_x.len(), cam.width as usize);
    for (u, r) in ray_x.iter_mut().enumerate() {
        *r = ((u as f64 - k.cx) / k.fx) as f32;
    }
    for (v, r) in ray_y.iter_mut().enumerate() {
        *r = ((v as f64 - k.cy) / k.fy) as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::exp_neg;

    #[test]
    fn exp_neg_is_close_to_exp() {
        let mut x = 0.0f32;
        while x > -80.0 {
            let (a, b) = (exp_neg(x), x.exp());
            assert!((a - b).abs() <= 2e-5 * b + 1e-37, "{x}: {a} vs {b}");
            x -= 0.0137;
        }
    }
}
