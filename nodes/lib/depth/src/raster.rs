//! The rasteriser: triangles (z-buffer, exact planar depth) and analytic primitives (ray cast
//! per pixel) into an inverse-depth buffer, one band of rows at a time.
//!
//! All geometry here is in the camera optical frame (m). The buffer holds `1/z` (1/m) with 0 for
//! "nothing yet", so a larger value is nearer; it converts to depth at the end of a band.

use nalgebra::{Point3, Vector3};

use crate::intrinsics::Intrinsics;
use crate::render::Label;

/// Nearest depth that is rendered, m: geometry closer than this is clipped away.
pub(crate) const NEAR_M: f64 = 0.01;

/// A triangle set up for scan conversion: screen-space edge functions and the inverse-depth
/// plane.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ScreenTri {
    /// Edge functions `a x + b y + c ≥ 0` inside (x = u, y = v in px).
    edges: [[f64; 3]; 3],
    /// `1/z = wa u + wb v + wc` (1/m) over the whole plane of the triangle.
    wa: f64,
    wb: f64,
    wc: f64,
    /// Inclusive pixel bounds (already clipped to the image).
    x0: u32,
    x1: u32,
    y0: u32,
    y1: u32,
    label: Label,
}

/// An analytic shape, camera frame, ray cast per pixel inside its screen bounds.
#[derive(Debug, Clone, Copy)]
pub(crate) enum PrimShape {
    Sphere { c: Point3<f64>, r: f64 },
    /// Segment `a`–`b` swept by a sphere of radius `r`.
    Capsule { a: Point3<f64>, b: Point3<f64>, r: f64 },
    /// Flat-capped cylinder with axis `a`–`b`.
    Cylinder { a: Point3<f64>, b: Point3<f64>, r: f64 },
}

#[derive(Debug, Clone, Copy)]
pub(crate) struct Prim {
    shape: PrimShape,
    x0: u32,
    x1: u32,
    y0: u32,
    y1: u32,
    label: Label,
}

/// Everything one frame draws, set up once and then read by every band.
#[derive(Debug, Default)]
pub(crate) struct DrawList {
    pub tris: Vec<ScreenTri>,
    pub prims: Vec<Prim>,
}

impl DrawList {
    pub fn clear(&mut self) {
        self.tris.clear();
        self.prims.clear();
    }

    /// Adds triangle `p` (camera frame, m). With `cull`, a triangle whose vertices run
    /// clockwise seen from the camera (a back face of an outward-wound closed mesh) is skipped.
    pub fn triangle(&mut self, k: &Intrinsics, p: [Point3<f64>; 3], cull: bool, label: Label) {
        let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
        // Plane n·x = d; the camera sits on the front side when d < 0.
        let d = n.dot(&p[0].coords);
        if !(d.is_finite()) || (cull && d >= 0.0) {
            return;
        }
        // Edge-on planes (through the eye) cover no pixel area.
        if d.abs() <= 1e-12 * n.norm() {
            return;
        }
        let inside = p.map(|v| v.z >= NEAR_M);
        match inside.iter().filter(|i| **i).count() {
            0 => {}
            3 => self.push_projected(k, &[p[0], p[1], p[2]], &n, d, label),
            _ => {
                // Sutherland–Hodgman against z = NEAR_M: at most 4 vertices, fanned.
                let mut poly = [Point3::origin(); 4];
                let mut len = 0;
                for i in 0..3 {
                    let (a, b) = (p[i], p[(i + 1) % 3]);
                    let (ina, inb) = (inside[i], inside[(i + 1) % 3]);
                    if ina {
                        poly[len] = a;
                        len += 1;
                    }
                    if ina != inb {
                        poly[len] = clip_near(a, b);
                        len += 1;
                    }
                }
                self.push_projected(k, &poly[..len], &n, d, label);
            }
        }
    }

    /// Projects a convex polygon (all vertices at z ≥ NEAR_M, plane `n·x = d`) and adds it as a
    /// triangle fan.
    fn push_projected(&mut self, k: &Intrinsics, poly: &[Point3<f64>], n: &Vector3<f64>, d: f64, label: Label) {
        // 1/z = n·(xn, yn, 1)/d with xn = (u − cx)/fx, yn = (v − cy)/fy.
        let wa = n.x / (k.fx * d);
        let wb = n.y / (k.fy * d);
        let wc = (n.z - n.x * k.cx / k.fx - n.y * k.cy / k.fy) / d;
        let mut s = [(0.0, 0.0); 4];
        for (i, v) in poly.iter().enumerate() {
            s[i] = (k.fx * v.x / v.z + k.cx, k.fy * v.y / v.z + k.cy);
        }
        for i in 1..poly.len().saturating_sub(1) {
            let tri = [s[0], s[i], s[i + 1]];
            if let Some(t) = setup(k, tri, wa, wb, wc, label) {
                self.tris.push(t);
            }
        }
    }

    /// Adds an analytic shape (camera frame) whose camera-frame bounding box is `lo`–`hi`.
    pub fn prim(&mut self, k: &Intrinsics, shape: PrimShape, lo: Point3<f64>, hi: Point3<f64>, label: Label) {
        if hi.z < NEAR_M || !lo.coords.iter().chain(hi.coords.iter()).all(|c| c.is_finite()) {
            return;
        }
        let (w, h) = (f64::from(k.width), f64::from(k.height));
        let (mut u0, mut u1, mut v0, mut v1) = (-0.5, w - 0.5, -0.5, h - 0.5);
        if lo.z >= NEAR_M {
            // The projection of a box contains the projection of anything inside it.
            let (mut a0, mut a1, mut b0, mut b1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
            for i in 0..8 {
                let c = Point3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                );
                let (u, v) = (k.fx * c.x / c.z + k.cx, k.fy * c.y / c.z + k.cy);
                a0 = a0.min(u);
                a1 = a1.max(u);
                b0 = b0.min(v);
                b1 = b1.max(v);
            }
            (u0, u1, v0, v1) = (a0.max(u0), a1.min(u1), b0.max(v0), b1.min(v1));
        }
        let Some((x0, x1)) = pixel_span(u0, u1, k.width) else { return };
        let Some((y0, y1)) = pixel_span(v0, v1, k.height) else { return };
        self.prims.push(Prim { shape, x0, x1, y0, y1, label });
    }
}

/// The point of segment `a`–`b` on the plane z = NEAR_M. The endpoints are ordered first so the
/// two triangles sharing an edge get bit-identical points.
fn clip_near(a: Point3<f64>, b: Point3<f64>) -> Point3<f64> {
    let (a, b) = if (a.x, a.y, a.z) <= (b.x, b.y, b.z) { (a, b) } else { (b, a) };
    let t = (NEAR_M - a.z) / (b.z - a.z);
    let mut p = a + (b - a) * t;
    p.z = NEAR_M;
    p
}

/// Inclusive range of pixel centres (integers) inside `[lo, hi]`, clipped to `0..n`.
fn pixel_span(lo: f64, hi: f64, n: u32) -> Option<(u32, u32)> {
    let a = lo.ceil().max(0.0);
    let b = hi.floor().min(f64::from(n) - 1.0);
    (a <= b).then(|| (a as u32, b as u32))
}

/// Edge functions and pixel bounds of a screen triangle; `None` when it covers no pixel centre
/// of the image or is degenerate.
fn setup(k: &Intrinsics, mut s: [(f64, f64); 3], wa: f64, wb: f64, wc: f64, label: Label) -> Option<ScreenTri> {
    let area = (s[1].0 - s[0].0) * (s[2].1 - s[0].1) - (s[1].1 - s[0].1) * (s[2].0 - s[0].0);
    if !(area.is_finite()) || area == 0.0 {
        return None;
    }
    if area < 0.0 {
        s.swap(1, 2);
    }
    let (u0, u1) = (s[0].0.min(s[1].0).min(s[2].0), s[0].0.max(s[1].0).max(s[2].0));
    let (v0, v1) = (s[0].1.min(s[1].1).min(s[2].1), s[0].1.max(s[1].1).max(s[2].1));
    let (x0, x1) = pixel_span(u0, u1, k.width)?;
    let (y0, y1) = pixel_span(v0, v1, k.height)?;
    let edge = |(xa, ya): (f64, f64), (xb, yb): (f64, f64)| [ya - yb, xb - xa, xa * yb - xb * ya];
    Some(ScreenTri {
        edges: [edge(s[0], s[1]), edge(s[1], s[2]), edge(s[2], s[0])],
        wa,
        wb,
        wc,
        x0,
        x1,
        y0,
        y1,
        label,
    })
}

/// Per-pixel ray directions: the ray through pixel `(x, y)` is `(xn[x], yn[y], 1)`, so the ray
/// parameter of a hit is its depth.
#[derive(Debug, Clone)]
pub(crate) struct Rays {
    pub xn: Vec<f64>,
    pub yn: Vec<f64>,
}

impl Rays {
    pub fn new(k: &Intrinsics) -> Self {
        Self {
            xn: (0..k.width).map(|x| (f64::from(x) - k.cx) / k.fx).collect(),
            yn: (0..k.height).map(|y| (f64::from(y) - k.cy) / k.fy).collect(),
        }
    }
}

/// Rasterises `list` into rows `y0..y0 + inv.len() / width` of the inverse-depth buffer `inv`
/// (and `labels`), which must hold 0 / `Label::None` on entry.
pub(crate) fn raster_band(list: &DrawList, rays: &Rays, width: usize, y0: usize, inv: &mut [f32], labels: &mut [Label]) {
    let rows = inv.len() / width;
    let y_end = y0 + rows; // exclusive
    for t in &list.tris {
        let (ty0, ty1) = (t.y0 as usize, t.y1 as usize);
        if ty1 < y0 || ty0 >= y_end {
            continue;
        }
        for y in ty0.max(y0)..=ty1.min(y_end - 1) {
            let yf = y as f64;
            let (mut lo, mut hi) = (f64::from(t.x0), f64::from(t.x1));
            let mut empty = false;
            for e in &t.edges {
                let rhs = -(e[1] * yf + e[2]);
                if e[0] > 0.0 {
                    lo = lo.max(rhs / e[0]);
                } else if e[0] < 0.0 {
                    hi = hi.min(rhs / e[0]);
                } else if rhs > 0.0 {
                    empty = true;
                }
            }
            if empty || !(lo <= hi) {
                continue;
            }
            let (xs, xe) = (lo.ceil() as usize, hi.floor() as usize);
            if xs > xe {
                continue;
            }
            let row = (y - y0) * width;
            let w_row = t.wb * yf + t.wc;
            let inv_row = &mut inv[row + xs..=row + xe];
            let lab_row = &mut labels[row + xs..=row + xe];
            let mut xf = xs as f64;
            for (w_px, l) in inv_row.iter_mut().zip(lab_row.iter_mut()) {
                let w = (t.wa * xf + w_row) as f32;
                if w > *w_px {
                    *w_px = w;
                    *l = t.label;
                }
                xf += 1.0;
            }
        }
    }
    for p in &list.prims {
        let (py0, py1) = (p.y0 as usize, p.y1 as usize);
        if py1 < y0 || py0 >= y_end {
            continue;
        }
        for y in py0.max(y0)..=py1.min(y_end - 1) {
            let row = (y - y0) * width;
            let yn = rays.yn[y];
            for x in p.x0 as usize..=p.x1 as usize {
                let d = Vector3::new(rays.xn[x], yn, 1.0);
                let t = match p.shape {
                    PrimShape::Sphere { c, r } => ray_sphere(&d, &c, r),
                    PrimShape::Capsule { a, b, r } => ray_capsule(&d, &a, &b, r),
                    PrimShape::Cylinder { a, b, r } => ray_cylinder(&d, &a, &b, r),
                };
                if t >= NEAR_M && t.is_finite() {
                    let w = (1.0 / t) as f32;
                    if w > inv[row + x] {
                        inv[row + x] = w;
                        labels[row + x] = p.label;
                    }
                }
            }
        }
    }
}

/// Nearest hit ≥ NEAR_M of the ray `t d` (from the camera origin) with a sphere; `INFINITY` when
/// none.
fn ray_sphere(d: &Vector3<f64>, c: &Point3<f64>, r: f64) -> f64 {
    // |t d − c|² = r²  →  (d·d) t² − 2 (d·c) t + c·c − r² = 0.
    let a = d.dot(d);
    let b = d.dot(&c.coords);
    let cc = c.coords.dot(&c.coords) - r * r;
    let h = b * b - a * cc;
    if h < 0.0 {
        return f64::INFINITY;
    }
    let s = h.sqrt();
    let t0 = (b - s) / a;
    if t0 >= NEAR_M {
        return t0;
    }
    let t1 = (b + s) / a;
    if t1 >= NEAR_M { t1 } else { f64::INFINITY }
}

/// Hit of the ray with the infinite cylinder of axis `a`–`b`, radius `r`, restricted to the
/// segment's slab; `INFINITY` when none.
fn ray_tube(d: &Vector3<f64>, a: &Point3<f64>, b: &Point3<f64>, r: f64) -> f64 {
    // Points t d with |perp(t d − a)| = r, perp = component across the axis.
    let ba = b - a;
    let oa = -a.coords;
    let baba = ba.dot(&ba);
    if baba <= 0.0 {
        return f64::INFINITY;
    }
    let bard = ba.dot(d);
    let baoa = ba.dot(&oa);
    let qa = baba * d.dot(d) - bard * bard;
    let qb = baba * oa.dot(d) - baoa * bard;
    let qc = baba * oa.dot(&oa) - baoa * baoa - r * r * baba;
    if qa <= 1e-12 * baba * d.dot(d) {
        return f64::INFINITY; // ray parallel to the axis: only the ends can be hit
    }
    let h = qb * qb - qa * qc;
    if h < 0.0 {
        return f64::INFINITY;
    }
    let s = h.sqrt();
    for t in [(-qb - s) / qa, (-qb + s) / qa] {
        let y = baoa + t * bard;
        if t >= NEAR_M && y >= 0.0 && y <= baba {
            return t;
        }
    }
    f64::INFINITY
}

fn ray_capsule(d: &Vector3<f64>, a: &Point3<f64>, b: &Point3<f64>, r: f64) -> f64 {
    ray_tube(d, a, b, r).min(ray_sphere(d, a, r)).min(ray_sphere(d, b, r))
}

fn ray_cylinder(d: &Vector3<f64>, a: &Point3<f64>, b: &Point3<f64>, r: f64) -> f64 {
    let axis = b - a;
    let mut best = ray_tube(d, a, b, r);
    let dn = axis.dot(d);
    if dn != 0.0 {
        for c in [a, b] {
            // Disc at c with normal along the axis: (t d − c)·axis = 0.
            let t = c.coords.dot(&axis) / dn;
            if t >= NEAR_M && t < best && (d * t - c.coords).norm_squared() <= r * r {
                best = t;
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn analytic_hits() {
        let d = Vector3::new(0.0, 0.0, 1.0);
        assert!((ray_sphere(&d, &Point3::new(0.0, 0.0, 2.0), 0.5) - 1.5).abs() < 1e-12);
        // Capsule across the view at z = 2: hit the tube.
        let (a, b) = (Point3::new(-1.0, 0.0, 2.0), Point3::new(1.0, 0.0, 2.0));
        assert!((ray_capsule(&d, &a, &b, 0.1) - 1.9).abs() < 1e-12);
        // Capsule along the view: hit the near end sphere.
        let (a, b) = (Point3::new(0.0, 0.0, 2.0), Point3::new(0.0, 0.0, 3.0));
        assert!((ray_capsule(&d, &a, &b, 0.1) - 1.9).abs() < 1e-12);
        // Cylinder along the view: hit the near cap.
        assert!((ray_cylinder(&d, &a, &b, 0.1) - 2.0).abs() < 1e-12);
        // Cylinder across: the tube.
        let (a, b) = (Point3::new(-1.0, 0.0, 2.0), Point3::new(1.0, 0.0, 2.0));
        assert!((ray_cylinder(&d, &a, &b, 0.1) - 1.9).abs() < 1e-12);
        // Misses.
        let side = Vector3::new(1.0, 0.0, 1.0);
        assert!(ray_sphere(&side, &Point3::new(0.0, 0.0, 2.0), 0.5).is_infinite());
        // Beyond the end of a cylinder.
        let off = Vector3::new(1.2 / 2.0, 0.0, 1.0);
        assert!(ray_cylinder(&off, &a, &b, 0.1).is_infinite());
        assert!(ray_capsule(&off, &a, &b, 0.1).is_infinite());
    }
}
