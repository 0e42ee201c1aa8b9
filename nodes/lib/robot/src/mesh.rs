//! Indexed triangle meshes of links: STL input/output and tessellated primitives.
//!
//! Vertices are in metres in the frame of the link that owns the mesh. Triangles are wound
//! counter-clockwise seen from outside (right-hand normal points out of the solid).

use nalgebra::{Isometry3, Point3, Vector3};
use std::collections::HashMap;
use std::io::{Read, Seek, Write};

/// An indexed triangle mesh (m, in the frame of its link).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions (m).
    pub vertices: Vec<Point3<f64>>,
    /// Triangles as indices into `vertices`, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// An empty mesh.
    pub fn new() -> Self {
        Self::default()
    }

    /// `true` when the mesh has no triangles.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Appends `other`, re-indexing its triangles.
    pub fn append(&mut self, other: &TriMesh) {
        let base = u32::try_from(self.vertices.len()).expect("mesh exceeds u32 vertex indices");
        self.vertices.extend_from_slice(&other.vertices);
        self.triangles.extend(
            other
                .triangles
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
    }

    /// Maps every vertex through `pose` (e.g. a `<collision><origin>` into the link frame).
    pub fn transform(&mut self, pose: &Isometry3<f64>) {
        for v in &mut self.vertices {
            *v = pose * *v;
        }
    }

    /// Scales vertex coordinates per axis (URDF `<mesh scale>`). A scale with an odd number of
    /// negative factors mirrors the mesh, so the winding is flipped to keep normals outward.
    pub fn scale(&mut self, s: &Vector3<f64>) {
        for v in &mut self.vertices {
            v.coords.component_mul_assign(s);
        }
        if s.x * s.y * s.z < 0.0 {
            for t in &mut self.triangles {
                t.swap(1, 2);
            }
        }
    }

    /// Axis-aligned bounding box `(min, max)` (m), `None` for a mesh without vertices.
    pub fn aabb(&self) -> Option<(Point3<f64>, Point3<f64>)> {
        let first = *self.vertices.first()?;
        Some(
            self.vertices
                .iter()
                .fold((first, first), |(lo, hi), v| (lo.inf(v), hi.sup(v))),
        )
    }

    /// Surface of revolution about the link z axis.
    ///
    /// `profile` lists `(radius, z)` pairs (m) from the bottom to the top of the solid; a radius
    /// of zero is a pole (one vertex), so a profile that starts and ends on the axis gives a
    /// closed solid. `segments` (≥ 3) is the number of vertices around each ring.
    pub fn revolution(profile: &[(f64, f64)], segments: usize) -> TriMesh {
        let segments = segments.max(3);
        let mut mesh = TriMesh::new();
        // First vertex index of each ring and whether it is a pole.
        let mut rings: Vec<(u32, bool)> = Vec::with_capacity(profile.len());
        let mut previous: Option<(f64, f64)> = None;
        for &(r, z) in profile {
            // A repeated profile point would only add a band of zero-area triangles.
            if previous == Some((r, z)) {
                continue;
            }
            previous = Some((r, z));
            let start = mesh.vertices.len() as u32;
            if r <= 0.0 {
                mesh.vertices.push(Point3::new(0.0, 0.0, z));
                rings.push((start, true));
            } else {
                for k in 0..segments {
                    let a = std::f64::consts::TAU * k as f64 / segments as f64;
                    mesh.vertices.push(Point3::new(r * a.cos(), r * a.sin(), z));
                }
                rings.push((start, false));
            }
        }
        let n = segments as u32;
        for w in rings.windows(2) {
            let ((lo, lo_pole), (hi, hi_pole)) = (w[0], w[1]);
            for k in 0..n {
                let k1 = (k + 1) % n;
                match (lo_pole, hi_pole) {
                    (true, true) => {}
                    (true, false) => mesh.triangles.push([lo, hi + k1, hi + k]),
                    (false, true) => mesh.triangles.push([lo + k, lo + k1, hi]),
                    (false, false) => {
                        mesh.triangles.push([lo + k, lo + k1, hi + k1]);
                        mesh.triangles.push([lo + k, hi + k1, hi + k]);
                    }
                }
            }
        }
        mesh
    }

    /// Closed cylinder of `radius` along z from `z0` to `z1` (m) with flat caps.
    pub fn cylinder(radius: f64, z0: f64, z1: f64, segments: usize) -> TriMesh {
        Self::revolution(
            &[(0.0, z0), (radius, z0), (radius, z1), (0.0, z1)],
            segments,
        )
    }

    /// Closed cylinder of `radius` along z from `z0` to `z1` whose ends are hemispheres
    /// centred on `z0` (when `round_bottom`) and `z1` (when `round_top`), flat otherwise.
    /// `rings` (≥ 1) is the number of latitude steps per hemisphere.
    pub fn rounded_cylinder(
        radius: f64,
        z0: f64,
        z1: f64,
        round_bottom: bool,
        round_top: bool,
        segments: usize,
        rings: usize,
    ) -> TriMesh {
        let rings = rings.max(1);
        let mut profile = Vec::with_capacity(2 * rings + 4);
        if round_bottom {
            for i in 0..=rings {
                let a = std::f64::consts::FRAC_PI_2 * i as f64 / rings as f64;
                profile.push((radius * a.sin(), z0 - radius * a.cos()));
            }
        } else {
            profile.push((0.0, z0));
            profile.push((radius, z0));
        }
        if round_top {
            for i in (0..=rings).rev() {
                let a = std::f64::consts::FRAC_PI_2 * i as f64 / rings as f64;
                profile.push((radius * a.sin(), z1 + radius * a.cos()));
            }
        } else {
            profile.push((radius, z1));
            profile.push((0.0, z1));
        }
        Self::revolution(&profile, segments)
    }

    /// Sphere of `radius` centred on the origin.
    pub fn sphere(radius: f64, segments: usize, rings: usize) -> TriMesh {
        Self::rounded_cylinder(radius, 0.0, 0.0, true, true, segments, rings)
    }

    /// Box centred on the origin with the given half extents (m).
    pub fn cuboid(half: Vector3<f64>) -> TriMesh {
        let (x, y, z) = (half.x, half.y, half.z);
        let vertices = vec![
            Point3::new(-x, -y, -z),
            Point3::new(x, -y, -z),
            Point3::new(x, y, -z),
            Point3::new(-x, y, -z),
            Point3::new(-x, -y, z),
            Point3::new(x, -y, z),
            Point3::new(x, y, z),
            Point3::new(-x, y, z),
        ];
        let triangles = vec![
            [0, 2, 1],
            [0, 3, 2], // -z
            [4, 5, 6],
            [4, 6, 7], // +z
            [0, 1, 5],
            [0, 5, 4], // -y
            [2, 3, 7],
            [2, 7, 6], // +y
            [1, 2, 6],
            [1, 6, 5], // +x
            [3, 0, 4],
            [3, 4, 7], // -x
        ];
        TriMesh {
            vertices,
            triangles,
        }
    }

    /// Reads an ASCII or binary STL. Identical vertices are merged; coordinates are taken as
    /// written (the STL unit must be metres, or be corrected with a URDF `scale`).
    pub fn read_stl<R: Read + Seek>(reader: &mut R) -> Result<TriMesh, String> {
        let indexed = stl_io::read_stl(reader).map_err(|e| e.to_string())?;
        let vertices: Vec<Point3<f64>> = indexed
            .vertices
            .iter()
            .map(|v| Point3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2])))
            .collect();
        if let Some(i) = vertices
            .iter()
            .position(|v| !v.coords.iter().all(|c| c.is_finite()))
        {
            return Err(format!(
                "vertex {i} is not finite: {:?}",
                vertices[i].coords.as_slice()
            ));
        }
        let n = u32::try_from(vertices.len()).map_err(|_| "too many vertices".to_string())?;
        let mut triangles = Vec::with_capacity(indexed.faces.len());
        for f in &indexed.faces {
            let t = f.vertices.map(|i| i as u32);
            if t.iter().any(|&i| i >= n) {
                return Err("triangle index out of range".into());
            }
            triangles.push(t);
        }
        if triangles.is_empty() {
            return Err("the STL has no triangles".into());
        }
        Ok(TriMesh {
            vertices,
            triangles,
        })
    }

    /// Writes a binary STL (single precision, as the format demands). Normals are computed from
    /// the winding.
    pub fn write_stl<W: Write>(&self, writer: &mut W) -> std::io::Result<()> {
        let to32 = |p: &Point3<f64>| stl_io::Vertex::new([p.x as f32, p.y as f32, p.z as f32]);
        let tris: Vec<stl_io::Triangle> = self
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize]);
                let n = (b - a).cross(&(c - a));
                let n = n.try_normalize(0.0).unwrap_or_else(Vector3::zeros);
                stl_io::Triangle {
                    normal: stl_io::Normal::new([n.x as f32, n.y as f32, n.z as f32]),
                    vertices: [to32(&a), to32(&b), to32(&c)],
                }
            })
            .collect();
        stl_io::write_stl(writer, tris.iter())
    }

    /// Merges vertices with bit-identical coordinates (after the f32 rounding STL applies), so
    /// a generated mesh has the same vertex count before and after an STL round trip.
    pub fn weld_f32(&mut self) {
        let mut index: HashMap<[u32; 3], u32> = HashMap::with_capacity(self.vertices.len());
        let mut remap = Vec::with_capacity(self.vertices.len());
        let mut vertices = Vec::with_capacity(self.vertices.len());
        for v in &self.vertices {
            let key = [v.x as f32, v.y as f32, v.z as f32].map(|c| (c + 0.0).to_bits());
            let next = vertices.len() as u32;
            let i = *index.entry(key).or_insert_with(|| {
                vertices.push(Point3::new(
                    f64::from(v.x as f32),
                    f64::from(v.y as f32),
                    f64::from(v.z as f32),
                ));
                next
            });
            remap.push(i);
        }
        self.vertices = vertices;
        let mut triangles = Vec::with_capacity(self.triangles.len());
        for t in &self.triangles {
            let t = t.map(|i| remap[i as usize]);
            // Degenerate after welding (a pole ring collapsed): drop it.
            if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                triangles.push(t);
            }
        }
        self.triangles = triangles;
    }

    /// Signed volume (m³) by the divergence theorem; positive for a closed, outward-wound mesh.
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize].coords);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_primitives_have_positive_volume_close_to_analytic() {
        let r: f64 = 0.07;
        let cyl = TriMesh::cylinder(r, 0.0, 0.2, 64);
        let exact = std::f64::consts::PI * r * r * 0.2;
        assert!((cyl.signed_volume() - exact).abs() / exact < 0.01);

        let sph = TriMesh::sphere(r, 64, 32);
        let exact = 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
        assert!((sph.signed_volume() - exact).abs() / exact < 0.01);

        let b = TriMesh::cuboid(Vector3::new(0.1, 0.2, 0.3));
        assert!((b.signed_volume() - 0.048).abs() < 1e-12);
    }

    #[test]
    fn stl_round_trip_keeps_topology() {
        let mut m = TriMesh::rounded_cylinder(0.065, 0.0, 0.2, true, false, 24, 6);
        m.weld_f32();
        let mut buf = Vec::new();
        m.write_stl(&mut buf).unwrap();
        let back = TriMesh::read_stl(&mut std::io::Cursor::new(buf)).unwrap();
        assert_eq!(back.vertices.len(), m.vertices.len());
        assert_eq!(back.triangles.len(), m.triangles.len());
        assert!((back.signed_volume() - m.signed_volume()).abs() < 1e-9);
    }

    #[test]
    fn mirroring_scale_keeps_volume_positive() {
        let mut b = TriMesh::cuboid(Vector3::new(0.1, 0.1, 0.1));
        b.scale(&Vector3::new(-1.0, 1.0, 2.0));
        assert!(b.signed_volume() > 0.0);
    }
}
