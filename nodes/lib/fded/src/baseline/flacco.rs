//! Flacco et al.'s depth-space distance with sphere-approximated links, as the thesis ran it
//! for its comparison (Sec. 5.1.3).

use crate::error::Result;
use crate::pipeline::{Fded, Frame};
use crate::stages::dist2;
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use nalgebra::{Point3, Vector3};

/// Parameters of the sphere method; defaults are the thesis's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlaccoParams {
    /// Spheres placed along the robot (10).
    pub spheres: usize,
    /// Sphere radius r_s, m (0.12).
    pub radius: f64,
    /// Half-side ρ of the surveillance cube around each sphere centre, m (0.4).
    pub rho: f64,
    /// Depths below this are skipped, m (1.8).
    pub min_depth: f64,
    /// Depths above this are skipped, m (3.5).
    pub max_depth: f64,
    /// Distance reported when no point lies in a sphere's surveillance region, m (0.5).
    pub default_distance: f64,
}

impl Default for FlaccoParams {
    fn default() -> Self {
        Self {
            spheres: 10,
            radius: 0.12,
            rho: 0.4,
            min_depth: 1.8,
            max_depth: 3.5,
            default_distance: 0.5,
        }
    }
}

/// The closest obstacle point of one link's spheres (base frame, m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlaccoHit {
    /// Sphere-surface distance (0 inside), m.
    pub distance: f64,
    /// Point of the sphere's surface towards the obstacle.
    pub robot_point: Point3<f64>,
    /// The obstacle point.
    pub obstacle_point: Point3<f64>,
    /// Unit normal from the obstacle point towards the sphere centre.
    pub normal: Vector3<f64>,
}

/// The sphere model of the robot and the distance query.
#[derive(Debug, Clone)]
pub struct Flacco {
    params: FlaccoParams,
    /// `(link, centre in the link frame, m)`.
    spheres: Vec<(usize, Point3<f64>)>,
    poses: LinkPoses,
}

impl Flacco {
    /// Places `params.spheres` centres evenly along the polyline through the link frame
    /// origins (base to tip) at the zero configuration; each sphere rides on the link whose
    /// segment holds it.
    pub fn new(model: &RobotModel, params: FlaccoParams) -> Self {
        let mut poses = LinkPoses::new();
        model.forward_kinematics(&JointVector::zeros(), &mut poses);
        let origins: Vec<Point3<f64>> = poses
            .as_slice()
            .iter()
            .map(|p| Point3::from(p.translation.vector))
            .collect();
        let seg_len: Vec<f64> = origins.windows(2).map(|s| (s[1] - s[0]).norm()).collect();
        let total: f64 = seg_len.iter().sum();
        let mut spheres = Vec::with_capacity(params.spheres);
        for k in 0..params.spheres {
            let mut s = (k as f64 + 0.5) / params.spheres as f64 * total;
            let mut link = 0;
            while link + 1 < seg_len.len() && s > seg_len[link] {
                s -= seg_len[link];
                link += 1;
            }
            let (a, b) = (origins[link], origins[(link + 1).min(origins.len() - 1)]);
            let along = if seg_len.is_empty() || seg_len[link] <= 0.0 {
                a
            } else {
                a + (b - a) * (s / seg_len[link]).clamp(0.0, 1.0)
            };
            spheres.push((link, poses.get(link).inverse() * along));
        }
        Self {
            params,
            spheres,
            poses,
        }
    }

    /// The sphere centres `(link, centre in the link frame)`.
    pub fn spheres(&self) -> &[(usize, Point3<f64>)] {
        &self.spheres
    }

    /// Classifies every pixel of `frame` with `fded`'s robot removal, table and range
    /// ([`Fded::classify_full`]; the thesis removed the robot the same way for both methods),
    /// then the sphere distances. Fills `per_link` (one per link of the model; `None` for links
    /// without a sphere) with the smallest sphere-surface distance of each link, m.
    pub fn distances(&mut self, fded: &mut Fded, frame: &Frame<'_>, per_link: &mut Vec<Option<f64>>) -> Result<()> {
        fded.classify_full(frame)?;
        self.distances_prepared(fded, frame, per_link);
        Ok(())
    }

    /// [`distances`](Self::distances) on buffers `fded` has already prepared for `frame`.
    pub fn distances_prepared(&mut self, fded: &Fded, frame: &Frame<'_>, per_link: &mut Vec<Option<f64>>) {
        self.query(fded, frame, per_link, None);
    }

    /// Like [`distances`](Self::distances), with the closest pair of each link for a
    /// controller: `hits[link]` is `None` when no sphere of the link saw a point in its
    /// surveillance region (no obstacle, not the default distance), else the sphere-surface
    /// distance, the sphere's surface point towards the obstacle, the obstacle point and the
    /// unit normal from the obstacle towards the robot (base frame, m).
    pub fn closest(&mut self, fded: &mut Fded, frame: &Frame<'_>, hits: &mut Vec<Option<FlaccoHit>>) -> Result<()> {
        fded.classify_full(frame)?;
        let mut per_link = Vec::new();
        self.query(fded, frame, &mut per_link, Some(hits));
        Ok(())
    }

    fn query(
        &mut self,
        fded: &Fded,
        frame: &Frame<'_>,
        per_link: &mut Vec<Option<f64>>,
        mut hits: Option<&mut Vec<Option<FlaccoHit>>>,
    ) {
        let model = fded.model();
        let mut q = JointVector::zeros();
        if let Some(j) = frame.joints {
            q.copy_from_slice(j);
        }
        model.forward_kinematics(&q, &mut self.poses);
        per_link.clear();
        per_link.resize(model.link_count(), None);
        if let Some(h) = hits.as_deref_mut() {
            h.clear();
            h.resize(model.link_count(), None);
        }
        let base_from_cam = *frame.camera_pose;
        let cam_from_base = frame.camera_pose.inverse();
        let buf = fded.buffers();
        let k = fded.intrinsics();
        let (w, h) = (buf.width as i64, buf.height as i64);
        let p = &self.params;
        let (rho, lo, hi) = (p.rho, p.min_depth as f32, p.max_depth as f32);
        for &(link, centre) in &self.spheres {
            let c: Vector3<f64> = (cam_from_base * (self.poses.get(link) * centre)).coords;
            let mut best = f32::INFINITY;
            let mut best_point = [0.0f32; 3];
            if c.z > 1e-3 {
                // Pixel rectangle of the cube's projection (corners at z = c.z ± ρ, clipped).
                let z_near = (c.z - rho).max(1e-3);
                let z_far = c.z + rho;
                let mut umin = f64::INFINITY;
                let mut umax = f64::NEG_INFINITY;
                let mut vmin = f64::INFINITY;
                let mut vmax = f64::NEG_INFINITY;
                for z in [z_near, z_far] {
                    for x in [c.x - rho, c.x + rho] {
                        let u = k.fx * x / z + k.cx;
                        umin = umin.min(u);
                        umax = umax.max(u);
                    }
                    for y in [c.y - rho, c.y + rho] {
                        let v = k.fy * y / z + k.cy;
                        vmin = vmin.min(v);
                        vmax = vmax.max(v);
                    }
                }
                let u0 = (umin.ceil() as i64).clamp(0, w);
                let u1 = (umax.floor() as i64 + 1).clamp(0, w);
                let v0 = (vmin.ceil() as i64).clamp(0, h);
                let v1 = (vmax.floor() as i64 + 1).clamp(0, h);
                let r = [c.x as f32, c.y as f32, c.z as f32];
                let (dlo, dhi) = ((c.z - rho) as f32, (c.z + rho) as f32);
                for v in v0..v1 {
                    let row = (v * w) as usize;
                    let ry = buf.ray_y[v as usize];
                    for u in u0..u1 {
                        let d = buf.filtered[row + u as usize];
                        if d <= 0.0 || d < lo || d > hi || d < dlo || d > dhi {
                            continue;
                        }
                        let q = dist2(&r, buf.ray_x[u as usize], ry, d, f32::INFINITY);
                        if q < best {
                            best = q;
                            // The point dist2 measured to (the gray area raises it to the sphere's depth).
                            let dd = if r[2] > d { r[2] } else { d };
                            best_point = [buf.ray_x[u as usize] * dd, ry * dd, dd];
                        }
                    }
                }
            }
            let dist = if best.is_finite() {
                (f64::from(best).sqrt() - p.radius).max(0.0)
            } else {
                p.default_distance
            };
            let slot = &mut per_link[link];
            *slot = Some(slot.map_or(dist, |s: f64| s.min(dist)));
            if let Some(h) = hits.as_deref_mut()
                && best.is_finite()
                && h[link].is_none_or(|old| dist < old.distance)
            {
                let centre = base_from_cam * Point3::from(c);
                let obstacle = base_from_cam * Point3::new(f64::from(best_point[0]), f64::from(best_point[1]), f64::from(best_point[2]));
                let away = centre - obstacle;
                let normal = if away.norm() > 1e-9 { away.normalize() } else { Vector3::z() };
                h[link] = Some(FlaccoHit {
                    distance: dist,
                    robot_point: centre - normal * p.radius,
                    obstacle_point: obstacle,
                    normal,
                });
            }
        }
    }
}
