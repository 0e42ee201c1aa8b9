//! Stage 1: the robot in the depth space (eq. 5.14).
//!
//! * [`RobotPointSet`]: the robot points fDED measures from — every mesh vertex (the thesis's
//!   points) plus points on the long triangles so that no edge between points is longer than
//!   `robot_point_spacing` (the LWR meshes have 20 cm edges along the links); built once.
//!   [`transform_points`] moves them to the camera frame and projects them each frame.
//! * [`mark_robot`]: robot removal (|d − d_r| ≤ δ) evaluated at a grid of sample pixels only —
//!   the object lattice, or a small window — by rasterising the link triangles at those
//!   samples: work ∝ samples covered, not image pixels.
//! * [`render_virtual_depth`]: the full-resolution virtual depth with a z-buffer and link
//!   labels, for the baselines and tests (not in the per-frame path).
//!
//! Pixel centres at integer coordinates, top-left image origin, perspective-correct depth.

use crate::cam::Cam;
use crate::layout::{Buffers, NO_LINK, PixelBox, RobotPoint};
use cowork_robot::{LinkPoses, RobotModel};
use nalgebra::{Isometry3, Matrix3, Vector3};

/// The robot's link meshes, flattened: vertices in their link frames (f32, m) and triangles
/// with global vertex indices.
#[derive(Debug, Clone)]
pub struct RobotMeshes {
    /// Per link: the range of its vertices in `vertices` (empty for links without mesh).
    pub link_vertices: Vec<std::ops::Range<usize>>,
    /// All vertices, link frame, m.
    pub vertices: Vec<[f32; 3]>,
    /// Triangles as global vertex indices (counter-clockwise seen from outside).
    pub triangles: Vec<[u32; 3]>,
}

impl RobotMeshes {
    /// Collects the meshes of every link of `model`.
    pub fn from_model(model: &RobotModel) -> Self {
        let mut link_vertices = Vec::with_capacity(model.link_count());
        let mut vertices = Vec::with_capacity(model.mesh_vertex_count());
        let mut triangles = Vec::new();
        for l in 0..model.link_count() {
            let start = vertices.len();
            if let Some(mesh) = model.link_mesh(l) {
                let base = start as u32;
                vertices.extend(
                    mesh.vertices
                        .iter()
                        .map(|p| [p.x as f32, p.y as f32, p.z as f32]),
                );
                triangles.extend(
                    mesh.triangles
                        .iter()
                        .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
                );
            }
            link_vertices.push(start..vertices.len());
        }
        Self {
            link_vertices,
            vertices,
            triangles,
        }
    }

    /// `true` when no link has a mesh.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }
}

/// Moves every mesh vertex into the camera frame (`cam_from_base` · link pose), tagging it
/// with its link index, and projects it (eq. 5.14) into [`Buffers::vertex_uv`] (NaN behind
/// the near plane `near`, m).
pub fn transform_vertices(
    meshes: &RobotMeshes,
    poses: &LinkPoses,
    cam_from_base: &Isometry3<f64>,
    cam: &Cam,
    near: f32,
    out: &mut Buffers,
) {
    let project = |v: &[f32; 4]| if v[2] >= near { cam.project(v) } else { [f32::NAN; 2] };
    to_camera(
        &meshes.link_vertices,
        &meshes.vertices,
        poses,
        cam_from_base,
        &mut out.cam_vertices,
        &mut out.vertex_uv,
        project,
    );
}

/// The shared loop of [`transform_vertices`] and [`transform_points`]: each link's range of
/// `points` (link frame, m) to the camera frame in `cam_out` (`[x, y, z, link index]`), and
/// `project` of it into `uv_out` (px).
fn to_camera(
    link_ranges: &[std::ops::Range<usize>],
    points: &[[f32; 3]],
    poses: &LinkPoses,
    cam_from_base: &Isometry3<f64>,
    cam_out: &mut [RobotPoint],
    uv_out: &mut [[f32; 2]],
    project: impl Fn(&RobotPoint) -> [f32; 2],
) {
    for (l, range) in link_ranges.iter().enumerate() {
        if range.is_empty() {
            continue;
        }
        let t = cam_from_base * poses.get(l);
        let r: Matrix3<f32> = t.rotation.to_rotation_matrix().matrix().cast();
        let p: Vector3<f32> = t.translation.vector.cast();
        let tag = l as f32;
        for ((src, dst), uv) in points[range.clone()]
            .iter()
            .zip(&mut cam_out[range.clone()])
            .zip(&mut uv_out[range.clone()])
        {
            let v = r * Vector3::new(src[0], src[1], src[2]) + p;
            *dst = [v.x, v.y, v.z, tag];
            *uv = project(dst);
        }
    }
}

/// Clears the virtual depth and rasterises every front-facing triangle into it.
pub fn render_virtual_depth(meshes: &RobotMeshes, cam: &Cam, near: f32, out: &mut Buffers) {
    out.virtual_depth.fill(0.0);
    out.labels.fill(NO_LINK);
    let mut bbox = PixelBox::EMPTY;
    let w = cam.width as i32;
    let h = cam.height as i32;
    for tri in &meshes.triangles {
        let a = out.cam_vertices[tri[0] as usize];
        let b = out.cam_vertices[tri[1] as usize];
        let c = out.cam_vertices[tri[2] as usize];
        if a[2] < near || b[2] < near || c[2] < near {
            continue;
        }
        // Back faces of a closed, outward-wound mesh are hidden by its front faces.
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        if n[0] * a[0] + n[1] * a[1] + n[2] * a[2] >= 0.0 {
            continue;
        }
        let label = a[3] as u8;
        let (pa, pb, pc) = (cam.project(&a), cam.project(&b), cam.project(&c));
        let area = edge(pa, pb, pc);
        if area.abs() < 1e-12 {
            continue;
        }
        let u0 = pa[0].min(pb[0]).min(pc[0]).ceil().max(0.0) as i32;
        let u1 = (pa[0].max(pb[0]).max(pc[0]).floor() as i32).min(w - 1);
        let v0 = pa[1].min(pb[1]).min(pc[1]).ceil().max(0.0) as i32;
        let v1 = (pa[1].max(pb[1]).max(pc[1]).floor() as i32).min(h - 1);
        if u0 > u1 || v0 > v1 {
            continue;
        }
        let inv_area = 1.0 / area;
        let (iza, izb, izc) = (1.0 / a[2], 1.0 / b[2], 1.0 / c[2]);
        let mut touched = false;
        for v in v0..=v1 {
            let row = (v * w) as usize;
            let py = v as f32;
            for u in u0..=u1 {
                let p = [u as f32, py];
                let w0 = edge(pb, pc, p) * inv_area;
                let w1 = edge(pc, pa, p) * inv_area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = 1.0 / (w0 * iza + w1 * izb + w2 * izc);
                let i = row + u as usize;
                let cur = out.virtual_depth[i];
                if cur == 0.0 || z < cur {
                    out.virtual_depth[i] = z;
                    out.labels[i] = label;
                    touched = true;
                }
            }
        }
        if touched {
            bbox.u0 = bbox.u0.min(u0 as u32);
            bbox.v0 = bbox.v0.min(v0 as u32);
            bbox.u1 = bbox.u1.max(u1 as u32);
            bbox.v1 = bbox.v1.max(v1 as u32);
        }
    }
    out.robot_box = bbox;
}

/// Twice the signed area of (a, b, p): > 0 when p is left of a→b in image coordinates.
#[inline]
fn edge(a: [f32; 2], b: [f32; 2], p: [f32; 2]) -> f32 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// `⌊x⌋` for |x| < 2³¹ without a libm call (the baseline x86-64 target has no SSE4.1 round).
#[inline(always)]
pub(crate) fn floor_i(x: f32) -> i32 {
    let t = x as i32;
    if (t as f32) > x { t - 1 } else { t }
}

/// `⌈x⌉` for |x| < 2³¹ without a libm call.
#[inline(always)]
pub(crate) fn ceil_i(x: f32) -> i32 {
    let t = x as i32;
    if (t as f32) < x { t + 1 } else { t }
}

/// Triangles per chunk of [`Buffers::chunk_box`]: windows only visit chunks whose pixel box
/// overlaps them.
pub const TRI_CHUNK: usize = 32;

/// The robot points: per link, the mesh vertices and extra points on long triangles, link
/// frame (f32, m).
#[derive(Debug, Clone)]
pub struct RobotPointSet {
    /// Per link: the range of its points in `points`.
    pub link_points: Vec<std::ops::Range<usize>>,
    /// All points, link frame, m.
    pub points: Vec<[f32; 3]>,
}

impl RobotPointSet {
    /// The vertices of every link mesh, then, per triangle longer than `spacing` (m), a grid
    /// along its two edges from the corner between its longest and shortest edge, each edge
    /// cut into pieces of at most `spacing`; exact duplicates dropped.
    pub fn from_meshes(meshes: &RobotMeshes, spacing: f64) -> Self {
        let mut points = Vec::with_capacity(meshes.vertices.len() * 3);
        let mut link_points = Vec::with_capacity(meshes.link_vertices.len());
        let mut seen = std::collections::HashSet::new();
        for range in &meshes.link_vertices {
            let start = points.len();
            seen.clear();
            for v in &meshes.vertices[range.clone()] {
                if seen.insert(v.map(f32::to_bits)) {
                    points.push(*v);
                }
            }
            for tri in meshes.triangles.iter().filter(|t| range.contains(&(t[0] as usize))) {
                let c = tri.map(|i| meshes.vertices[i as usize].map(f64::from));
                let len = |a: &[f64; 3], b: &[f64; 3]| {
                    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
                };
                // Edge k is opposite corner k.
                let e = [len(&c[1], &c[2]), len(&c[2], &c[0]), len(&c[0], &c[1])];
                let long = (0..3).max_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap_or(0);
                if e[long] <= spacing {
                    continue;
                }
                let short = (0..3).filter(|&k| k != long).min_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap_or(0);
                let origin = 3 - long - short;
                let (o, a, b) = (c[origin], c[short], c[long]);
                // o→a is the longest edge (opposite corner `long`), o→b the shortest.
                let (na, nb) = ((len(&o, &a) / spacing).ceil().max(1.0) as u32, (len(&o, &b) / spacing).ceil().max(1.0) as u32);
                for i in 0..=na {
                    for j in 0..=nb {
                        if u64::from(i) * u64::from(nb) + u64::from(j) * u64::from(na) > u64::from(na) * u64::from(nb) {
                            break;
                        }
                        let (s, t) = (f64::from(i) / f64::from(na), f64::from(j) / f64::from(nb));
                        let p = [0, 1, 2].map(|k| (o[k] + s * (a[k] - o[k]) + t * (b[k] - o[k])) as f32);
                        if seen.insert(p.map(f32::to_bits)) {
                            points.push(p);
                        }
                    }
                }
            }
            link_points.push(start..points.len());
        }
        Self { link_points, points }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// `true` when there are none.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

/// Moves the robot points into the camera frame ([`Buffers::cam_points`], tagged with the
/// link) and projects them ([`Buffers::point_uv`]; NaN when behind the near plane `near` or
/// outside the image: such points are not in the depth space).
pub fn transform_points(
    set: &RobotPointSet,
    poses: &LinkPoses,
    cam_from_base: &Isometry3<f64>,
    cam: &Cam,
    near: f32,
    out: &mut Buffers,
) {
    let (umax, vmax) = (cam.width as f32 - 0.5, cam.height as f32 - 0.5);
    let project = |v: &[f32; 4]| {
        let q = if v[2] >= near { cam.project(v) } else { [f32::NAN; 2] };
        if q[0] >= -0.5 && q[0] < umax && q[1] >= -0.5 && q[1] < vmax { q } else { [f32::NAN; 2] }
    };
    to_camera(&set.link_points, &set.points, poses, cam_from_base, &mut out.cam_points, &mut out.point_uv, project);
}

/// Sample pixels `(u0 + i·su, v0 + j·sv)` for `i < nx`, `j < ny`; flags are indexed `j·nx + i`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Grid {
    /// First column, px.
    pub u0: u32,
    /// First row, px.
    pub v0: u32,
    /// Column step, px.
    pub su: u32,
    /// Row step, px.
    pub sv: u32,
    /// Samples per row.
    pub nx: u32,
    /// Rows.
    pub ny: u32,
}

/// Robot removal settings.
#[derive(Debug, Clone, Copy)]
pub struct Removal {
    /// δ, m.
    pub delta: f32,
    /// The triangles are grown by this many pixels (sensor/joint-state misregistration), px.
    pub margin: f32,
}

/// Robot removal at the samples of `grid`: a sample whose real depth d (`depth`, full image
/// of `width` columns) lies within `δ` of the depth d_r of **any** front-facing link triangle
/// covering it (not only the nearest one; triangles grown by `margin` px) gets `flags = 1`. Triangles `tris` (indices into
/// `meshes.triangles`); with `chunk_box`, the pixel box of every chunk of [`TRI_CHUNK`]
/// triangles in `tris` is written too. Samples with d ≤ 0 or NaN are skipped; `drange` bounds
/// the samples' depths (m): triangles whose depth range is farther than δ from it are skipped.
#[allow(clippy::too_many_arguments)]
pub fn mark_robot(
    meshes: &RobotMeshes,
    cam_vertices: &[RobotPoint],
    vertex_uv: &[[f32; 2]],
    tris: std::ops::Range<usize>,
    grid: &Grid,
    depth: &[f32],
    width: usize,
    k: &Removal,
    drange: [f32; 2],
    flags: &mut [u8],
    mut chunk_box: Option<&mut [[f32; 4]]>,
) {
    let m = k.margin;
    let (gu0, gv0, su, sv) = (grid.u0 as f32, grid.v0 as f32, grid.su as f32, grid.sv as f32);
    let (nx, ny) = (grid.nx as f32, grid.ny as f32);
    let (isu, isv) = (1.0 / su, 1.0 / sv);
    let mut cur_chunk = usize::MAX;
    let mut cbox = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
    for t in tris {
        if let Some(cb) = chunk_box.as_deref_mut() {
            let c = t / TRI_CHUNK;
            if c != cur_chunk {
                if cur_chunk != usize::MAX {
                    cb[cur_chunk] = cbox;
                }
                cur_chunk = c;
                cbox = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
            }
        }
        let tri = meshes.triangles[t];
        let (pa, pb, pc) = (vertex_uv[tri[0] as usize], vertex_uv[tri[1] as usize], vertex_uv[tri[2] as usize]);
        if pa[0].is_nan() || pb[0].is_nan() || pc[0].is_nan() {
            continue;
        }
        let umin = pa[0].min(pb[0]).min(pc[0]) - m;
        let umax = pa[0].max(pb[0]).max(pc[0]) + m;
        let vmin = pa[1].min(pb[1]).min(pc[1]) - m;
        let vmax = pa[1].max(pb[1]).max(pc[1]) + m;
        if chunk_box.is_some() {
            cbox = [cbox[0].min(umin), cbox[1].min(vmin), cbox[2].max(umax), cbox[3].max(vmax)];
        }
        // Clamped in float first: far off-screen corners must not overflow the integer casts.
        let i_lo = ceil_i(((umin - gu0) * isu).clamp(-1.0, nx)).max(0);
        let i_hi = floor_i(((umax - gu0) * isu).clamp(-1.0, nx)).min(nx as i32 - 1);
        let j_lo = ceil_i(((vmin - gv0) * isv).clamp(-1.0, ny)).max(0);
        let j_hi = floor_i(((vmax - gv0) * isv).clamp(-1.0, ny)).min(ny as i32 - 1);
        if i_lo > i_hi || j_lo > j_hi {
            continue;
        }
        let (a, b, c) = (
            cam_vertices[tri[0] as usize],
            cam_vertices[tri[1] as usize],
            cam_vertices[tri[2] as usize],
        );
        // Back faces of the closed, outward-wound link meshes lie behind their front faces,
        // which cover the same pixels.
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let nrm = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        if nrm[0] * a[0] + nrm[1] * a[1] + nrm[2] * a[2] >= 0.0 {
            continue;
        }
        let area = edge(pa, pb, pc);
        if area.abs() < 1e-12 {
            continue;
        }
        // With clamped barycentrics the depth stays within the corners' depths.
        let zlo = a[2].min(b[2]).min(c[2]) - k.delta;
        let zhi = a[2].max(b[2]).max(c[2]) + k.delta;
        if zhi < drange[0] || zlo > drange[1] {
            continue;
        }
        let s = area.signum();
        let len = |a: [f32; 2], b: [f32; 2]| ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        // Edge i is opposite corner i; inside (grown) when s · edge ≥ −margin · length.
        let edges = [(pb, pc, m * len(pb, pc)), (pc, pa, m * len(pc, pa)), (pa, pb, m * len(pa, pb))];
        let (iza, izb, izc) = (1.0 / a[2], 1.0 / b[2], 1.0 / c[2]);
        for j in j_lo as u32..=j_hi as u32 {
            let v = grid.v0 + j * grid.sv;
            let py = v as f32;
            let (mut xl, mut xr) = (umin, umax);
            let mut empty = false;
            for &(p, q, tol) in &edges {
                // s · edge(p, q, (x, py)) = alpha · x + beta ≥ −tol
                let alpha = -s * (q[1] - p[1]);
                let beta = s * ((q[0] - p[0]) * (py - p[1]) + (q[1] - p[1]) * p[0]);
                if alpha > 0.0 {
                    xl = xl.max((-tol - beta) / alpha);
                } else if alpha < 0.0 {
                    xr = xr.min((-tol - beta) / alpha);
                } else if beta < -tol {
                    empty = true;
                }
            }
            if empty || xl > xr {
                continue;
            }
            let i0 = ceil_i(((xl - gu0) * isu - 1e-3).clamp(-1.0, nx)).max(i_lo);
            let i1 = floor_i(((xr - gu0) * isu + 1e-3).clamp(-1.0, nx)).min(i_hi);
            let row = v as usize * width;
            if i0 > i1 {
                continue;
            }
            let (i0, i1) = (i0 as u32, i1 as u32);
            for i in i0..=i1 {
                let fi = (j * grid.nx + i) as usize;
                if flags[fi] != 0 {
                    continue;
                }
                let u = grid.u0 + i * grid.su;
                let d = depth[row + u as usize];
                if !(d > 0.0 && d >= zlo && d <= zhi) {
                    continue;
                }
                let p = [u as f32, py];
                let e0 = s * edge(pb, pc, p);
                let e1 = s * edge(pc, pa, p);
                let e2 = s * edge(pa, pb, p);
                if e0 < -edges[0].2 || e1 < -edges[1].2 || e2 < -edges[2].2 {
                    continue;
                }
                let (w0, w1, w2) = (e0.max(0.0), e1.max(0.0), e2.max(0.0));
                let sum = w0 + w1 + w2;
                let z = if sum > 0.0 {
                    sum / (w0 * iza + w1 * izb + w2 * izc)
                } else {
                    3.0 / (iza + izb + izc)
                };
                if (d - z).abs() <= k.delta {
                    flags[fi] = 1;
                }
            }
        }
    }
    if let Some(cb) = chunk_box
        && cur_chunk != usize::MAX
    {
        cb[cur_chunk] = cbox;
    }
}
