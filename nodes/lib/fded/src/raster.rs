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
/// with global vertex indices, each link's triangles in spatial (Morton) order and grouped in
/// [`TriChunk`]s.
#[derive(Debug, Clone)]
pub struct RobotMeshes {
    /// Per link: the range of its vertices in `vertices` (empty for links without mesh).
    pub link_vertices: Vec<std::ops::Range<usize>>,
    /// All vertices, link frame, m.
    pub vertices: Vec<[f32; 3]>,
    /// Triangles as global vertex indices (counter-clockwise seen from outside).
    pub triangles: Vec<[u32; 3]>,
    /// Groups of at most [`TRI_CHUNK`] neighbouring triangles of one link: the unit robot
    /// removal culls by pixel box, depth range and facing.
    pub chunks: Vec<TriChunk>,
}

/// Up to [`TRI_CHUNK`] neighbouring triangles of one link, with the bounds that let robot
/// removal skip them together: a bounding sphere and a cone holding every face normal, both
/// in the link frame.
#[derive(Debug, Clone, PartialEq)]
pub struct TriChunk {
    /// Link index.
    pub link: usize,
    /// Its triangles in [`RobotMeshes::triangles`].
    pub triangles: std::ops::Range<usize>,
    /// Bounding sphere centre, link frame, m.
    pub centre: [f32; 3],
    /// Bounding sphere radius, m.
    pub radius: f32,
    /// Unit axis of the normal cone (outward), link frame.
    pub axis: [f32; 3],
    /// `[cos θ, sin θ]` of the cone's half-angle θ; `cos θ ≤ 0` (θ ≥ 90°) means the chunk is
    /// never back-facing as a whole.
    pub cone: [f32; 2],
}

impl RobotMeshes {
    /// Collects the meshes of every link of `model`, sorts each link's triangles along a
    /// Morton curve of their centroids and cuts them into chunks of [`TRI_CHUNK`].
    pub fn from_model(model: &RobotModel) -> Self {
        let mut link_vertices = Vec::with_capacity(model.link_count());
        let mut vertices = Vec::with_capacity(model.mesh_vertex_count());
        let mut triangles = Vec::new();
        let mut chunks = Vec::new();
        for l in 0..model.link_count() {
            let start = vertices.len();
            if let Some(mesh) = model.link_mesh(l) {
                let base = start as u32;
                vertices.extend(
                    mesh.vertices
                        .iter()
                        .map(|p| [p.x as f32, p.y as f32, p.z as f32]),
                );
                let first = triangles.len();
                let mut tris: Vec<[u32; 3]> = mesh.triangles.iter().map(|t| [t[0] + base, t[1] + base, t[2] + base]).collect();
                sort_morton(&mut tris, &vertices);
                triangles.extend(tris);
                for lo in (first..triangles.len()).step_by(TRI_CHUNK) {
                    let range = lo..(lo + TRI_CHUNK).min(triangles.len());
                    chunks.push(TriChunk::of(l, range, &triangles, &vertices));
                }
            }
            link_vertices.push(start..vertices.len());
        }
        Self {
            link_vertices,
            vertices,
            triangles,
            chunks,
        }
    }

    /// `true` when no link has a mesh.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }
}

/// Sorts triangles by the Morton code of their centroids (10 bits per axis over their
/// bounding box), so that consecutive triangles are neighbours.
fn sort_morton(tris: &mut [[u32; 3]], vertices: &[[f32; 3]]) {
    let centroid = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0)
    };
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for t in tris.iter() {
        let c = centroid(t);
        for k in 0..3 {
            lo[k] = lo[k].min(c[k]);
            hi[k] = hi[k].max(c[k]);
        }
    }
    let spread = [0, 1, 2].map(|k| (hi[k] - lo[k]).max(1e-9));
    let spread_bits = |x: u32| (0..10).fold(0u32, |acc, b| acc | (((x >> b) & 1) << (3 * b)));
    tris.sort_by_cached_key(|t| {
        let c = centroid(t);
        let q = [0, 1, 2].map(|k| (((c[k] - lo[k]) / spread[k]) * 1023.0).round().clamp(0.0, 1023.0) as u32);
        spread_bits(q[0]) | (spread_bits(q[1]) << 1) | (spread_bits(q[2]) << 2)
    });
}

impl TriChunk {
    /// The chunk of triangles `range` of link `link`.
    fn of(link: usize, range: std::ops::Range<usize>, triangles: &[[u32; 3]], vertices: &[[f32; 3]]) -> Self {
        let mut ids: Vec<u32> = triangles[range.clone()].iter().flatten().copied().collect();
        ids.sort_unstable();
        ids.dedup();
        let p = |i: u32| Vector3::from(vertices[i as usize].map(f64::from));
        let centre = ids.iter().map(|&i| p(i)).sum::<Vector3<f64>>() / ids.len() as f64;
        let radius = ids.iter().map(|&i| (p(i) - centre).norm()).fold(0.0, f64::max);
        // Degenerate faces are never drawn (back-face test n·v ≥ 0 with n = 0), so they do not
        // widen the cone.
        let normals: Vec<Vector3<f64>> = triangles[range.clone()]
            .iter()
            .filter_map(|t| ((p(t[1]) - p(t[0])).cross(&(p(t[2]) - p(t[0])))).try_normalize(1e-12))
            .collect();
        let axis = normals.iter().sum::<Vector3<f64>>().try_normalize(1e-9).unwrap_or_else(Vector3::z);
        let cos = normals.iter().map(|n| n.dot(&axis)).fold(1.0f64, f64::min);
        let cos = if normals.is_empty() { 1.0 } else { cos.clamp(-1.0, 1.0) };
        Self {
            link,
            triangles: range,
            centre: [centre.x as f32, centre.y as f32, centre.z as f32],
            // Rounding slack: the sphere must hold every f32 vertex.
            radius: (radius * (1.0 + 1e-5) + 1e-6) as f32,
            axis: [axis.x as f32, axis.y as f32, axis.z as f32],
            cone: [cos as f32, (1.0 - cos * cos).max(0.0).sqrt() as f32],
        }
    }
}

/// Moves every mesh vertex into the camera frame (`cam_from_base` · link pose), tagging it
/// with its link index, and projects it (eq. 5.14) into [`RobotFrame::vertex_uv`](crate::layout::RobotFrame::vertex_uv) (NaN behind
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
        &mut out.robot.cam_vertices,
        &mut out.robot.vertex_uv,
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
        let a = out.robot.cam_vertices[tri[0] as usize];
        let b = out.robot.cam_vertices[tri[1] as usize];
        let c = out.robot.cam_vertices[tri[2] as usize];
        if a[2] < near || b[2] < near || c[2] < near {
            continue;
        }
        // Back faces of a closed, outward-wound mesh are hidden by its front faces.
        if !faces_camera(&a, &b, &c) {
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

/// `true` when triangle (a, b, c) (camera frame, counter-clockwise seen from outside) turns
/// its outer side towards the camera at the origin; degenerate triangles do not.
#[inline]
fn faces_camera(a: &RobotPoint, b: &RobotPoint, c: &RobotPoint) -> bool {
    let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    n[0] * a[0] + n[1] * a[1] + n[2] * a[2] < 0.0
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

/// Triangles per [`TriChunk`].
pub const TRI_CHUNK: usize = 16;

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

/// Sample pixels `(u0 + i·su, v0 + j·sv)` for `i < nx`, `j < ny`.
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

/// Per chunk this frame ([`RobotFrame::chunk_box`](crate::layout::RobotFrame::chunk_box), [`RobotFrame::chunk_z`](crate::layout::RobotFrame::chunk_z),
/// [`RobotFrame::chunk_sphere`](crate::layout::RobotFrame::chunk_sphere)): its bounding sphere in the camera frame, the sphere's depth
/// range and the pixel box of the sphere's projection grown by `margin` px (the whole image
/// when the sphere reaches the near plane `near`); a chunk whose every face turns away from
/// the camera (normal cone) gets an empty box (`u0 > u1`).
pub fn view_chunks(meshes: &RobotMeshes, poses: &LinkPoses, cam_from_base: &Isometry3<f64>, cam: &Cam, near: f32, margin: f32, out: &mut Buffers) {
    const CULLED: [f32; 4] = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
    let mut link = usize::MAX;
    let (mut r, mut p) = (Matrix3::<f32>::identity(), Vector3::<f32>::zeros());
    out.robot.visible_chunks.clear();
    for (c, ch) in meshes.chunks.iter().enumerate() {
        if ch.link != link {
            link = ch.link;
            let t = cam_from_base * poses.get(link);
            r = t.rotation.to_rotation_matrix().matrix().cast();
            p = t.translation.vector.cast();
        }
        let w = r * Vector3::from(ch.centre) + p;
        out.robot.chunk_sphere[c] = [w.x, w.y, w.z, ch.radius];
        if ch.cone[0] > 0.0 {
            // Every face is back-facing when, for every point x of the sphere and normal n of
            // the cone, n·x ≥ 0 (x from the camera): |w|·cos(φ + θ) ≥ r, φ = ∠(axis, w).
            let a = r * Vector3::from(ch.axis);
            let len = w.norm();
            if len > ch.radius {
                let cos_phi = a.dot(&w) / len;
                let sin_phi = (1.0 - cos_phi * cos_phi).max(0.0).sqrt();
                if cos_phi * ch.cone[0] - sin_phi * ch.cone[1] >= ch.radius / len + 1e-4 {
                    out.robot.chunk_box[c] = CULLED;
                    out.robot.chunk_z[c] = [f32::INFINITY, f32::NEG_INFINITY];
                    continue;
                }
            }
        }
        let rad = ch.radius;
        let (zn, zf) = (w.z - rad, w.z + rad);
        out.robot.chunk_z[c] = [zn, zf];
        out.robot.chunk_box[c] = if zn > near {
            // x / z over the sphere's bounding cube is extreme at its corners.
            let lo = |a: f32| a / if a >= 0.0 { zf } else { zn };
            let hi = |a: f32| a / if a >= 0.0 { zn } else { zf };
            [
                cam.cx + cam.fx * lo(w.x - rad) - margin,
                cam.cy + cam.fy * lo(w.y - rad) - margin,
                cam.cx + cam.fx * hi(w.x + rad) + margin,
                cam.cy + cam.fy * hi(w.y + rad) + margin,
            ]
        } else {
            [f32::NEG_INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::INFINITY]
        };
        out.robot.visible_chunks.push(c as u32);
    }
}

/// The robot as robot removal sees it this frame: meshes, projected vertices and chunk
/// bounds ([`transform_vertices`], [`view_chunks`]).
#[derive(Debug, Clone, Copy)]
pub struct RobotView<'a> {
    /// Meshes and chunks.
    pub meshes: &'a RobotMeshes,
    /// [`RobotFrame::cam_vertices`](crate::layout::RobotFrame::cam_vertices).
    pub cam_vertices: &'a [RobotPoint],
    /// [`RobotFrame::vertex_uv`](crate::layout::RobotFrame::vertex_uv).
    pub vertex_uv: &'a [[f32; 2]],
    /// [`RobotFrame::chunk_box`](crate::layout::RobotFrame::chunk_box).
    pub chunk_box: &'a [[f32; 4]],
    /// [`RobotFrame::chunk_z`](crate::layout::RobotFrame::chunk_z).
    pub chunk_z: &'a [[f32; 2]],
    /// [`RobotFrame::chunk_sphere`](crate::layout::RobotFrame::chunk_sphere).
    pub chunk_sphere: &'a [[f32; 4]],
    /// [`RobotFrame::visible_chunks`](crate::layout::RobotFrame::visible_chunks).
    pub visible: &'a [u32],
}

/// Depth samples on a [`Grid`]: the candidate depth of sample `(i, j)` (m; 0 where the pixel
/// is no obstacle candidate — no return, out of range, table) at `depth[j · stride + i]`.
#[derive(Debug, Clone, Copy)]
pub struct Samples<'a> {
    /// Which pixels.
    pub grid: Grid,
    /// Candidate depths, m.
    pub depth: &'a [f32],
    /// Row stride of `depth` (and of the flags), samples.
    pub stride: usize,
    /// Bounds of the candidate depths, m (`[0, ∞]` when unknown).
    pub zrange: [f32; 2],
}

impl Samples<'_> {
    /// Sample index range `[lo, hi]` along one axis covering pixel coordinates `[a, b]`
    /// (first sample `o`, step `s`, `n` samples); `None` when it holds none.
    #[inline]
    fn span(a: f32, b: f32, o: u32, s: u32, n: u32) -> Option<(u32, u32)> {
        let (o, is, nf) = (o as f32, 1.0 / s as f32, n as f32);
        // Clamped in float first: far off-screen corners must not overflow the integer casts.
        let lo = ceil_i(((a - o) * is).clamp(-1.0, nf)).max(0);
        let hi = floor_i(((b - o) * is).clamp(-1.0, nf)).min(n as i32 - 1);
        (lo <= hi).then_some((lo as u32, hi as u32))
    }

    /// Sample ranges `(i_lo, i_hi, j_lo, j_hi)` inside pixel box `[u0, v0, u1, v1]`.
    #[inline]
    fn in_box(&self, b: &[f32; 4]) -> Option<(u32, u32, u32, u32)> {
        let g = &self.grid;
        let (i_lo, i_hi) = Self::span(b[0], b[2], g.u0, g.su, g.nx)?;
        let (j_lo, j_hi) = Self::span(b[1], b[3], g.v0, g.sv, g.ny)?;
        Some((i_lo, i_hi, j_lo, j_hi))
    }
}

/// Target block side of [`DepthBlocks`], px.
const BLOCK_PX: u32 = 16;

/// The depth range `[min, max]` of the candidate samples in each block of about
/// 16 × 16 px (`BLOCK_PX`) of a [`Samples`] grid: a chunk or triangle whose depth range (± δ) meets
/// no block it covers cannot remove anything there and is skipped.
#[derive(Debug, Clone)]
pub struct DepthBlocks {
    /// Samples per block along a row and a column.
    side: (u32, u32),
    /// Blocks per row.
    nbx: u32,
    /// Per block: `[min, max]` candidate depth, m (`[∞, −∞]` when it holds none).
    range: Vec<[f32; 2]>,
}

impl DepthBlocks {
    /// Blocks for any grid over an image of `width × height` px.
    pub fn new(width: u32, height: u32) -> Self {
        let n = (width.div_ceil(BLOCK_PX / 2) + 1) as usize * (height.div_ceil(BLOCK_PX / 2) + 1) as usize;
        Self {
            side: (1, 1),
            nbx: 0,
            range: Vec::with_capacity(n),
        }
    }

    /// Recomputes the blocks of `s` (no allocation for grids over the image it was built for).
    pub fn build(&mut self, s: &Samples<'_>) {
        let g = &s.grid;
        self.side = ((BLOCK_PX / g.su.max(1)).max(1), (BLOCK_PX / g.sv.max(1)).max(1));
        self.nbx = g.nx.div_ceil(self.side.0);
        let nby = g.ny.div_ceil(self.side.1);
        self.range.clear();
        self.range.resize(self.nbx as usize * nby as usize, [f32::INFINITY, f32::NEG_INFINITY]);
        for j in 0..g.ny as usize {
            let row = &s.depth[j * s.stride..j * s.stride + g.nx as usize];
            let brow = (j / self.side.1 as usize) * self.nbx as usize;
            for (bi, part) in row.chunks(self.side.0 as usize).enumerate() {
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                for &d in part {
                    if d > 0.0 {
                        lo = lo.min(d);
                        hi = hi.max(d);
                    }
                }
                let r = &mut self.range[brow + bi];
                *r = [r[0].min(lo), r[1].max(hi)];
            }
        }
    }

    /// `true` when a block holding samples `[i_lo, i_hi] × [j_lo, j_hi]` has a candidate
    /// depth within `[zlo, zhi]` (a conservative test).
    #[inline]
    fn meets(&self, (i_lo, i_hi, j_lo, j_hi): (u32, u32, u32, u32), zlo: f32, zhi: f32) -> bool {
        for bj in j_lo / self.side.1..=j_hi / self.side.1 {
            let row = &self.range[(bj * self.nbx) as usize..((bj + 1) * self.nbx) as usize];
            for r in &row[(i_lo / self.side.0) as usize..=(i_hi / self.side.0) as usize] {
                if r[1] >= zlo && r[0] <= zhi {
                    return true;
                }
            }
        }
        false
    }
}

/// One front-facing link triangle ready for coverage tests: its projected corners, the
/// orientation sign, the edge tolerances of the growth, inverse corner depths and its depth
/// range widened by δ.
struct TriTest {
    p: [[f32; 2]; 3],
    sgn: f32,
    /// Per edge i (opposite corner i): margin × edge length.
    tol: [f32; 3],
    inv_z: [f32; 3],
    /// Depth range of the corners ± δ, m.
    z: [f32; 2],
    /// Pixel box grown by the margin `[u0, v0, u1, v1]`.
    bbox: [f32; 4],
}

impl TriTest {
    /// The pixel part of the test for triangle `t` (corners, grown box), or `None` when a
    /// corner is behind the near plane; [`finish`](Self::finish) completes it.
    #[inline]
    fn start(view: &RobotView<'_>, t: usize, k: &Removal) -> Option<(Self, [u32; 3])> {
        let m = k.margin;
        let tri = view.meshes.triangles[t];
        let (pa, pb, pc) = (view.vertex_uv[tri[0] as usize], view.vertex_uv[tri[1] as usize], view.vertex_uv[tri[2] as usize]);
        if pa[0].is_nan() || pb[0].is_nan() || pc[0].is_nan() {
            return None;
        }
        let bbox = [
            pa[0].min(pb[0]).min(pc[0]) - m,
            pa[1].min(pb[1]).min(pc[1]) - m,
            pa[0].max(pb[0]).max(pc[0]) + m,
            pa[1].max(pb[1]).max(pc[1]) + m,
        ];
        let t0 = Self {
            p: [pa, pb, pc],
            sgn: 0.0,
            tol: [0.0; 3],
            inv_z: [0.0; 3],
            z: [0.0; 2],
            bbox,
        };
        Some((t0, tri))
    }

    /// `true` when pixel `p` lies in the grown box.
    #[inline]
    fn boxes(&self, p: [f32; 2]) -> bool {
        let b = &self.bbox;
        p[0] >= b[0] && p[0] <= b[2] && p[1] >= b[1] && p[1] <= b[3]
    }

    /// The 3-D part of the test, once the pixel box is known to matter: `None` when the
    /// triangle faces away from the camera or is degenerate in the image.
    #[inline]
    fn finish(mut self, view: &RobotView<'_>, tri: [u32; 3], k: &Removal) -> Option<Self> {
        let (a, b, c) = (
            view.cam_vertices[tri[0] as usize],
            view.cam_vertices[tri[1] as usize],
            view.cam_vertices[tri[2] as usize],
        );
        // Back faces of the closed, outward-wound link meshes lie behind their front faces,
        // which cover the same pixels.
        if !faces_camera(&a, &b, &c) {
            return None;
        }
        let [pa, pb, pc] = self.p;
        let area = edge(pa, pb, pc);
        if area.abs() < 1e-12 {
            return None;
        }
        let len = |a: [f32; 2], b: [f32; 2]| ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let m = k.margin;
        self.sgn = area.signum();
        // Edge i is opposite corner i; inside (grown) when sgn · edge ≥ −margin · length.
        self.tol = [m * len(pb, pc), m * len(pc, pa), m * len(pa, pb)];
        self.inv_z = [1.0 / a[2], 1.0 / b[2], 1.0 / c[2]];
        // With clamped barycentrics the depth stays within the corners' depths.
        self.z = [a[2].min(b[2]).min(c[2]) - k.delta, a[2].max(b[2]).max(c[2]) + k.delta];
        Some(self)
    }

    /// `true` when depth `d` at pixel `p` is within δ of the triangle's depth there (corners'
    /// depths interpolated with clamped barycentrics) and `p` is inside the grown triangle.
    #[inline]
    fn removes(&self, p: [f32; 2], d: f32, delta: f32) -> bool {
        if !(d >= self.z[0] && d <= self.z[1]) {
            return false;
        }
        let [pa, pb, pc] = self.p;
        let e0 = self.sgn * edge(pb, pc, p);
        let e1 = self.sgn * edge(pc, pa, p);
        let e2 = self.sgn * edge(pa, pb, p);
        if e0 < -self.tol[0] || e1 < -self.tol[1] || e2 < -self.tol[2] {
            return false;
        }
        let (w0, w1, w2) = (e0.max(0.0), e1.max(0.0), e2.max(0.0));
        let sum = w0 + w1 + w2;
        let [iza, izb, izc] = self.inv_z;
        let z = if sum > 0.0 { sum / (w0 * iza + w1 * izb + w2 * izc) } else { 3.0 / (iza + izb + izc) };
        (d - z).abs() <= delta
    }
}

/// Chunks whose pixel box holds at most this many samples test their triangles against the
/// candidate samples one by one; larger ones rasterise spans.
const FEW_SAMPLES: usize = 8;

/// Robot removal at the samples of `s`: a candidate sample whose depth d lies within `δ` of
/// the depth d_r of **any** front-facing link triangle covering it (not only the nearest one;
/// triangles grown by `margin` px) gets `flags[j · stride + i] = 1`. Returns whether any did.
///
/// Whole chunks are skipped when their pixel box holds no sample, when every face turns away
/// from the camera, when no candidate depth near theirs lies in the blocks they cover
/// (`blocks`, built from `s` here when first needed), or, with `focus = [x, y, z, r]` (camera
/// frame, m), when their bounding sphere is farther than `r` from that point. A chunk over a
/// few samples tests its triangles at its candidate samples only; a larger one rasterises
/// each triangle at the samples of its box (a span per sample row). The cost is the chunks
/// near candidate samples, not the image's pixels.
pub fn mark_robot(view: &RobotView<'_>, s: &Samples<'_>, blocks: &mut DepthBlocks, k: &Removal, focus: Option<[f32; 4]>, flags: &mut [u8]) -> bool {
    let grid = &s.grid;
    let (gu0, isu, nx) = (grid.u0 as f32, 1.0 / grid.su as f32, grid.nx as f32);
    let extent = [
        grid.u0 as f32,
        grid.v0 as f32,
        (grid.u0 + (grid.nx.max(1) - 1) * grid.su) as f32,
        (grid.v0 + (grid.ny.max(1) - 1) * grid.sv) as f32,
    ];
    let (mut built, mut any) = (false, false);
    // Candidate samples of a small chunk: (flag index, pixel, depth).
    let mut few = [(0usize, [0.0f32; 2], 0.0f32); FEW_SAMPLES];
    for &c in view.visible {
        let (c, ch) = (c as usize, &view.meshes.chunks[c as usize]);
        let cb = &view.chunk_box[c];
        if cb[0] > extent[2] || cb[2] < extent[0] || cb[1] > extent[3] || cb[3] < extent[1] {
            continue;
        }
        if let Some(f) = focus {
            let sp = view.chunk_sphere[c];
            let (dx, dy, dz) = (sp[0] - f[0], sp[1] - f[1], sp[2] - f[2]);
            let reach = f[3] + sp[3];
            if dx * dx + dy * dy + dz * dz > reach * reach {
                continue;
            }
        }
        let cz = view.chunk_z[c];
        let (zlo, zhi) = (cz[0] - k.delta, cz[1] + k.delta);
        if zhi < s.zrange[0] || zlo > s.zrange[1] {
            continue;
        }
        let Some(range) = s.in_box(cb) else { continue };
        let (i_lo, i_hi, j_lo, j_hi) = range;
        if ((i_hi - i_lo + 1) * (j_hi - j_lo + 1)) as usize <= FEW_SAMPLES {
            let mut n = 0;
            for j in j_lo..=j_hi {
                for i in i_lo..=i_hi {
                    let fi = j as usize * s.stride + i as usize;
                    let d = s.depth[fi];
                    if flags[fi] == 0 && d > 0.0 && d >= zlo && d <= zhi {
                        few[n] = (fi, [(grid.u0 + i * grid.su) as f32, (grid.v0 + j * grid.sv) as f32], d);
                        n += 1;
                    }
                }
            }
            if n == 0 {
                continue;
            }
            for t in ch.triangles.clone() {
                let Some((t0, tri)) = TriTest::start(view, t, k) else { continue };
                if !few[..n].iter().any(|&(fi, p, _)| flags[fi] == 0 && t0.boxes(p)) {
                    continue;
                }
                let Some(tt) = t0.finish(view, tri, k) else { continue };
                for &(fi, p, d) in &few[..n] {
                    if flags[fi] == 0 && tt.boxes(p) && tt.removes(p, d, k.delta) {
                        flags[fi] = 1;
                        any = true;
                    }
                }
            }
            continue;
        }
        if !built {
            blocks.build(s);
            built = true;
        }
        if !blocks.meets(range, zlo, zhi) {
            continue;
        }
        for t in ch.triangles.clone() {
            let Some((t0, tri)) = TriTest::start(view, t, k) else { continue };
            if s.in_box(&t0.bbox).is_none() {
                continue;
            }
            let Some(tt) = t0.finish(view, tri, k) else { continue };
            let Some(trange @ (i_lo, i_hi, j_lo, j_hi)) = s.in_box(&tt.bbox) else { continue };
            if !blocks.meets(trange, tt.z[0], tt.z[1]) {
                continue;
            }
            let [pa, pb, pc] = tt.p;
            let edges = [(pb, pc, tt.tol[0]), (pc, pa, tt.tol[1]), (pa, pb, tt.tol[2])];
            for j in j_lo..=j_hi {
                let py = (grid.v0 + j * grid.sv) as f32;
                let (mut xl, mut xr) = (tt.bbox[0], tt.bbox[2]);
                let mut empty = false;
                for &(p, q, tol) in &edges {
                    // sgn · edge(p, q, (x, py)) = alpha · x + beta ≥ −tol
                    let alpha = -tt.sgn * (q[1] - p[1]);
                    let beta = tt.sgn * ((q[0] - p[0]) * (py - p[1]) + (q[1] - p[1]) * p[0]);
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
                let i0 = ceil_i(((xl - gu0) * isu - 1e-3).clamp(-1.0, nx)).max(i_lo as i32);
                let i1 = floor_i(((xr - gu0) * isu + 1e-3).clamp(-1.0, nx)).min(i_hi as i32);
                if i0 > i1 {
                    continue;
                }
                let row = j as usize * s.stride;
                for i in i0 as u32..=i1 as u32 {
                    let fi = row + i as usize;
                    if flags[fi] == 0 && tt.removes([(grid.u0 + i * grid.su) as f32, py], s.depth[fi], k.delta) {
                        flags[fi] = 1;
                        any = true;
                    }
                }
            }
        }
    }
    any
}
