//! Kinematic arm simulator: joint integration, limits, gripper, objects, admittance teaching.
