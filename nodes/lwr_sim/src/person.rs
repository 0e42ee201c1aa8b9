//! `/lwr/place_object` (cowork_msgs/WorldObject, base frame): a person moves a scene object —
//! takes the bottle, pours, puts it back — as a scripted experiment's person does. Only `name`
//! and `pose` are read; the object goes exactly there (no settling). Refused, with a warning,
//! for an object the scene does not have, the one the gripper holds, or a bad pose; the world
//! is then unchanged. This is a simulator control input, like Gazebo's `set_entity_state`: on a
//! real cell the person just does it.

use cowork_msgs::msg::WorldObject;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};

use crate::LwrSim;

/// Topic of [`LwrSim::on_place_object`].
pub const TOPIC_PLACE_OBJECT: &str = "/lwr/place_object";

impl LwrSim {
    /// A person moved `msg.name` to `msg.pose` (see the module docs). Returns whether it was
    /// applied.
    pub fn on_place_object(&mut self, msg: &WorldObject) -> bool {
        let (p, q) = (&msg.pose.position, &msg.pose.orientation);
        let quat = Quaternion::new(q.w, q.x, q.y, q.z);
        let name = cowork_ros::text_prefix(&msg.name, 80);
        if !(quat.norm().is_finite() && quat.norm() > 1e-6) {
            tracing::warn!("{TOPIC_PLACE_OBJECT}: object {name:?}: orientation is not a rotation; ignored");
            return false;
        }
        let pose = Isometry3::from_parts(Translation3::new(p.x, p.y, p.z), UnitQuaternion::from_quaternion(quat));
        match self.sim.place_object(&msg.name, pose) {
            Ok(()) => true,
            Err(e) => {
                tracing::warn!("{TOPIC_PLACE_OBJECT}: {e}; ignored");
                false
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::LwrSimConfig;
    use cowork_robot::RobotModel;
    use cowork_sim::{Scene, Simulator};

    fn kitchen() -> LwrSim {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let config: LwrSimConfig = cowork_ros::params::load(&root.join("config/lwr_sim.yaml"), "lwr_sim").expect("bundled parameters");
        let model = RobotModel::from_urdf_file(&root.join("config/robot/lwr4plus.urdf")).expect("URDF");
        let scene = Scene::from_file(&root.join("config/scenes/kitchen.yaml")).expect("scene");
        LwrSim::new(Simulator::new(model, scene, config.simulation.clone()).expect("simulator"), config)
    }

    #[test]
    fn placements_move_known_objects_and_refuse_the_rest() {
        let mut lwr = kitchen();
        let mut m = WorldObject { name: "bottle".into(), ..Default::default() };
        m.pose.position.x = 0.9;
        m.pose.position.z = 0.4;
        m.pose.orientation.w = 1.0;
        assert!(lwr.on_place_object(&m));
        let bottle = lwr.sim.objects().iter().find(|o| o.name == "bottle").map(|o| o.pose.translation.vector);
        assert_eq!(bottle.map(|v| (v.x, v.z)), Some((0.9, 0.4)));
        let mut bad = m.clone();
        bad.pose.orientation.w = 0.0;
        bad.pose.position.x = 0.1;
        assert!(!lwr.on_place_object(&bad));
        bad = m.clone();
        bad.pose.position.y = f64::INFINITY;
        assert!(!lwr.on_place_object(&bad));
        bad = m.clone();
        bad.name = "x".repeat(100_000);
        assert!(!lwr.on_place_object(&bad));
        let bottle = lwr.sim.objects().iter().find(|o| o.name == "bottle").map(|o| o.pose.translation.vector);
        assert_eq!(bottle.map(|v| (v.x, v.y, v.z)), Some((0.9, 0.0, 0.4)), "refused placements change nothing");
    }
}
