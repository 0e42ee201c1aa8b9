//! Analytic obstacles: parry shapes with a pose and a rigid velocity, all in the robot base
//! frame (m, m/s, rad/s).

use nalgebra::{Isometry3, Point3, Vector3};
use parry3d_f64::shape::SharedShape;

/// One rigid obstacle at one instant.
#[derive(Clone)]
pub struct Obstacle {
    /// Name for logs (e.g. `sphere`, `box.wall+x`, `person.forearm`).
    pub name: &'static str,
    /// Geometry in its local frame.
    pub shape: SharedShape,
    /// Local frame → base frame.
    pub pose: Isometry3<f64>,
    /// Linear velocity of the local origin (m/s, base frame).
    pub velocity: Vector3<f64>,
    /// Angular velocity (rad/s, base frame).
    pub angular_velocity: Vector3<f64>,
    /// Part of a person (for the human–robot distance that drives the speed scaling).
    pub human: bool,
}

impl std::fmt::Debug for Obstacle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Obstacle")
            .field("name", &self.name)
            .field("shape", &self.shape.shape_type())
            .field("pose", &self.pose)
            .field("velocity", &self.velocity)
            .finish_non_exhaustive()
    }
}

impl Obstacle {
    /// A static or translating sphere of `radius` (m) centred at `centre`.
    pub fn sphere(name: &'static str, centre: Point3<f64>, radius: f64, velocity: Vector3<f64>) -> Self {
        Self {
            name,
            shape: SharedShape::ball(radius),
            pose: Isometry3::translation(centre.x, centre.y, centre.z),
            velocity,
            angular_velocity: Vector3::zeros(),
            human: false,
        }
    }

    /// A static axis-aligned box with full side lengths `size` (m) centred at `centre`.
    pub fn cuboid(name: &'static str, centre: Point3<f64>, size: Vector3<f64>) -> Self {
        Self {
            name,
            shape: SharedShape::cuboid(0.5 * size.x, 0.5 * size.y, 0.5 * size.z),
            pose: Isometry3::translation(centre.x, centre.y, centre.z),
            velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
            human: false,
        }
    }

    /// A capsule of `radius` (m) around segment `a`–`b` whose ends move at `va`, `vb` (m/s).
    /// The motion is taken as rigid: the velocity of the midpoint plus the rotation that moves
    /// the ends (the component of `vb − va` across the segment).
    pub fn capsule(
        name: &'static str,
        a: Point3<f64>,
        b: Point3<f64>,
        radius: f64,
        va: Vector3<f64>,
        vb: Vector3<f64>,
    ) -> Self {
        let mid = nalgebra::center(&a, &b);
        let ab = b - a;
        let l2 = ab.norm_squared();
        let angular_velocity = if l2 > 1e-12 { ab.cross(&(vb - va)) / l2 } else { Vector3::zeros() };
        Self {
            name,
            shape: SharedShape::capsule(Point3::from(a - mid), Point3::from(b - mid), radius),
            pose: Isometry3::translation(mid.x, mid.y, mid.z),
            velocity: 0.5 * (va + vb),
            angular_velocity,
            human: true,
        }
    }

    /// Velocity of the obstacle's material point at `p` (m/s): v + ω × (p − origin), eq. 5.8's
    /// ẋ_T + ẋ_A × x̃.
    pub fn point_velocity(&self, p: &Point3<f64>) -> Vector3<f64> {
        self.velocity + self.angular_velocity.cross(&(p.coords - self.pose.translation.vector))
    }
}

/// The open box of Fig. 5.4 as static walls: a floor and four side walls, top open.
/// `centre` is the centre of the outer box, `size` its outer side lengths (m), `wall` the wall
/// thickness (m).
pub fn open_box(centre: Point3<f64>, size: Vector3<f64>, wall: f64) -> Vec<Obstacle> {
    let (hx, hy, hz) = (0.5 * size.x, 0.5 * size.y, 0.5 * size.z);
    let c = centre;
    vec![
        Obstacle::cuboid("box.floor", c + Vector3::new(0.0, 0.0, -hz + 0.5 * wall), Vector3::new(size.x, size.y, wall)),
        Obstacle::cuboid("box.wall-x", c + Vector3::new(-hx + 0.5 * wall, 0.0, 0.0), Vector3::new(wall, size.y, size.z)),
        Obstacle::cuboid("box.wall+x", c + Vector3::new(hx - 0.5 * wall, 0.0, 0.0), Vector3::new(wall, size.y, size.z)),
        Obstacle::cuboid("box.wall-y", c + Vector3::new(0.0, -hy + 0.5 * wall, 0.0), Vector3::new(size.x, wall, size.z)),
        Obstacle::cuboid("box.wall+y", c + Vector3::new(0.0, hy - 0.5 * wall, 0.0), Vector3::new(size.x, wall, size.z)),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn capsule_velocity_is_rigid_motion_of_its_ends() {
        let a = Point3::new(0.0, 0.0, 0.0);
        let b = Point3::new(1.0, 0.0, 0.0);
        // End b swings up at 1 m/s, end a still: a rotation about a.
        let o = Obstacle::capsule("c", a, b, 0.05, Vector3::zeros(), Vector3::new(0.0, 0.0, 1.0));
        assert!((o.point_velocity(&a)).norm() < 1e-12);
        assert!((o.point_velocity(&b) - Vector3::new(0.0, 0.0, 1.0)).norm() < 1e-12);
        let mid = o.point_velocity(&Point3::new(0.5, 0.0, 0.0));
        assert!((mid - Vector3::new(0.0, 0.0, 0.5)).norm() < 1e-12);
    }

    #[test]
    fn open_box_has_floor_and_four_walls_inside_its_outline() {
        let walls = open_box(Point3::new(0.5, 0.0, 0.1), Vector3::new(0.4, 0.35, 0.2), 0.01);
        assert_eq!(walls.len(), 5);
        for w in &walls {
            let aabb = w.shape.compute_aabb(&w.pose);
            assert!(aabb.mins.x >= 0.3 - 1e-12 && aabb.maxs.x <= 0.7 + 1e-12, "{}", w.name);
            assert!(aabb.mins.z >= -1e-12 && aabb.maxs.z <= 0.2 + 1e-12, "{}", w.name);
        }
    }
}
