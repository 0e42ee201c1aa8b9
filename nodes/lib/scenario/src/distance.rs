//! Exact per-link robot–obstacle distances, in the form the DS controller gets from fDED
//! ([`cowork_ds::Distances`]): for each link, the closest obstacle point, the closest link point,
//! the obstacle's outward normal there and the obstacle point's velocity.
//!
//! Each moving link is the convex hull of its URDF mesh (the LWR links are convex up to the
//! gripper fingers, so the hull is a tight, conservative stand-in); distances and normals come
//! from parry's GJK/EPA contact query against the obstacle shapes, negative when they overlap.

use cowork_ds::{Distances, LinkDistance};
use cowork_robot::{LinkPoses, RobotModel};
use nalgebra::Point3;
use parry3d_f64::query;
use parry3d_f64::shape::{ConvexPolyhedron, Shape};

use crate::error::{Error, Result};
use crate::obstacle::Obstacle;

/// Convex hulls of the moving links of one robot.
#[derive(Clone)]
pub struct LinkGeometry {
    /// (link index, hull in the link frame, bounding-sphere centre in the link frame, radius).
    links: Vec<(usize, ConvexPolyhedron, Point3<f64>, f64)>,
    count: usize,
    /// Obstacles farther than this from a link are reported as absent (m).
    range: f64,
}

impl std::fmt::Debug for LinkGeometry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LinkGeometry")
            .field("links", &self.links.iter().map(|l| l.0).collect::<Vec<_>>())
            .field("range", &self.range)
            .finish()
    }
}

/// Closest approach found in one evaluation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    /// Smallest link–obstacle distance (m), ∞ when nothing is within range.
    pub distance: f64,
    /// Smallest link–person distance (m), ∞ when none.
    pub human_distance: f64,
    /// Link of the smallest distance.
    pub link: Option<usize>,
}

impl LinkGeometry {
    /// Hulls of every link moved by a joint (the fixed base is left out); obstacles farther
    /// than `range` (m) are ignored.
    pub fn new(model: &RobotModel, range: f64) -> Result<Self> {
        let first = model.joint_link(0);
        let mut links = Vec::new();
        for l in first..model.link_count() {
            let Some(mesh) = model.link_mesh(l) else { continue };
            if mesh.vertices.is_empty() {
                continue;
            }
            let hull = ConvexPolyhedron::from_convex_hull(&mesh.vertices).ok_or_else(|| {
                Error::DegenerateLink { link: l, name: model.link_names()[l].clone() }
            })?;
            let bs = hull.compute_local_bounding_sphere();
            links.push((l, hull, bs.center, bs.radius));
        }
        Ok(Self { links, count: model.link_count(), range })
    }

    /// Per-link distances at link `poses` to `obstacles`, stamped `stamp` (s), and the closest
    /// approach overall.
    pub fn distances(&self, poses: &LinkPoses, obstacles: &[Obstacle], stamp: f64) -> (Distances, Closest) {
        let mut d = Distances::clear(stamp);
        d.count = self.count;
        let mut closest = Closest { distance: f64::INFINITY, human_distance: f64::INFINITY, link: None };
        for (l, hull, centre, radius) in &self.links {
            let pose = poses.get(*l);
            let c = pose * centre;
            let mut best = LinkDistance::NONE;
            for o in obstacles {
                let bs = o.shape.compute_bounding_sphere(&o.pose);
                let lower = (bs.center - c).norm() - bs.radius - radius;
                if lower > self.range {
                    continue;
                }
                // Convex–convex: GJK/EPA always answers (Unsupported cannot happen for these shapes).
                let Ok(Some(k)) = query::contact(pose, hull as &dyn Shape, &o.pose, &*o.shape, self.range)
                else {
                    continue;
                };
                if o.human {
                    closest.human_distance = closest.human_distance.min(k.dist);
                }
                if k.dist < closest.distance {
                    closest.distance = k.dist;
                    closest.link = Some(*l);
                }
                if !best.valid || k.dist < best.distance {
                    best = LinkDistance {
                        valid: true,
                        distance: k.dist,
                        robot_point: k.point1,
                        obstacle_point: k.point2,
                        normal: k.normal2.into_inner(),
                        obstacle_velocity: o.point_velocity(&k.point2),
                    };
                }
            }
            d.links[*l] = best;
        }
        (d, closest)
    }
}
