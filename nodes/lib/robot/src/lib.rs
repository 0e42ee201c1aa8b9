//! Robot description (URDF + link meshes) and allocation-free kinematics for 7-DoF serial arms.
