//! Stage 1: the virtual depth — the robot's link meshes projected with eq. 5.14 and
//! rasterised with a z-buffer, each pixel labelled with its link.
//!
//! The thesis projects every mesh vertex; vertices alone leave holes between them at
//! 640×480, so the triangles between projected vertices are filled too (perspective-correct
//! depth, pixel centres at integer coordinates, top-left image origin).

use crate::cam::Cam;
use crate::layout::{Buffers, NO_LINK, PixelBox};
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
/// with its link index.
pub fn transform_vertices(
    meshes: &RobotMeshes,
    poses: &LinkPoses,
    cam_from_base: &Isometry3<f64>,
    out: &mut Buffers,
) {
    for (l, range) in meshes.link_vertices.iter().enumerate() {
        if range.is_empty() {
            continue;
        }
        let t = cam_from_base * poses.get(l);
        let r: Matrix3<f32> = t.rotation.to_rotation_matrix().matrix().cast();
        let p: Vector3<f32> = t.translation.vector.cast();
        let tag = l as f32;
        for (src, dst) in meshes.vertices[range.clone()]
            .iter()
            .zip(&mut out.cam_vertices[range.clone()])
        {
            let v = r * Vector3::new(src[0], src[1], src[2]) + p;
            *dst = [v.x, v.y, v.z, tag];
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
