//! `cowork robot ...`: kinematics of the robot description.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Subcommand;
use cowork_robot::{DOF, Jacobian, JointVector, LinkPoses, RobotModel};
use nalgebra::Point3;
use serde::Serialize;

/// Robot model commands.
#[derive(Debug, Subcommand)]
pub enum RobotCommand {
    /// Forward kinematics and geometric Jacobian of a link, as JSON (base frame; Jacobian at the
    /// link origin, linear rows first).
    Fk {
        /// Joint positions, rad, comma separated (one per joint).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        joints: Vec<f64>,
        /// Link name (the tool link when omitted).
        #[arg(long)]
        link: Option<String>,
        /// Robot description.
        #[arg(long, default_value = "config/robot/lwr4plus.urdf", value_parser = cowork_ros::config::path_arg)]
        urdf: PathBuf,
    },
}

#[derive(Debug, Serialize)]
struct FkOutput {
    link: String,
    position: [f64; 3],
    quaternion_xyzw: [f64; 4],
    jacobian: Vec<Vec<f64>>,
}

/// Runs a robot subcommand.
pub fn run(cmd: RobotCommand) -> Result<()> {
    match cmd {
        RobotCommand::Fk { joints, link, urdf } => {
            let out = fk(&joints, link.as_deref(), &urdf)?;
            println!("{}", serde_json::to_string_pretty(&out)?);
            Ok(())
        }
    }
}

fn fk(joints: &[f64], link: Option<&str>, urdf: &std::path::Path) -> Result<FkOutput> {
    let model = RobotModel::from_urdf_file(cowork_ros::config::resolve(urdf))
        .with_context(|| format!("cannot load robot description {}", urdf.display()))?;
    if joints.len() != DOF {
        bail!("--joints has {} values; the robot has {DOF} joints ({})", joints.len(), model.joint_names().join(", "));
    }
    if let Some((i, v)) = joints.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        bail!("--joints value {i} ({}) is not a finite number", v);
    }
    let link_index = match link {
        None => model.tip_link(),
        Some(name) => model.link_index(name).with_context(|| {
            format!("--link {name:?}: no such link (links: {})", model.link_names().join(", "))
        })?,
    };
    let q = JointVector::from_column_slice(joints);
    let mut poses = LinkPoses::default();
    model.forward_kinematics(&q, &mut poses);
    let mut j = Jacobian::zeros();
    model.jacobian(&poses, link_index, &Point3::origin(), &mut j);
    let pose = poses.get(link_index);
    let t = pose.translation.vector;
    let r = pose.rotation.quaternion();
    Ok(FkOutput {
        link: model.link_names()[link_index].clone(),
        position: [t.x, t.y, t.z],
        quaternion_xyzw: [r.i, r.j, r.k, r.w],
        jacobian: (0..6).map(|row| (0..DOF).map(|c| j[(row, c)]).collect()).collect(),
    })
}
