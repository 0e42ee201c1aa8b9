//! Writes the KUKA LWR IV+ description: `lwr4plus.urdf` and one binary STL per link in
//! `meshes/`, deterministically (same bytes on every run).
//!
//! ```text
//! cargo run -p cowork_robot --example generate_lwr_description -- --out-dir config/robot
//! ```
//!
//! Kinematics (thesis Sec. 5.1.1, A.2; as in the common `kuka_lwr` URDFs): axes z,y,z,y,z,y,z;
//! A1 0.11 m above the base, shoulder (A2) 0.31 m, elbow (A4) +0.40 m, wrist (A6) +0.39 m,
//! flange (A7 frame) +0.078 m; limits ±170/±120 deg alternating; speed limits
//! [100,110,100,130,130,180,180] deg/s. A fixed `lwr_ee_link` sits 0.10 m beyond the flange
//! (gripper TCP).
//!
//! Meshes: segments are rounded cylinders (6–7 cm radius) whose hemispherical ends are centred
//! on the pitch joints (A2, A4, A6), like the real arm's joint housings; 64 segments around and
//! 10 latitude rings per hemisphere give about 4800 vertices in all (the thesis's mesh has 4861).

use anyhow::Context;
use clap::Parser;
use cowork_robot::TriMesh;
use nalgebra::{Isometry3, Translation3, Vector3};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(Debug, Parser)]
struct Args {
    /// Directory receiving `lwr4plus.urdf` and `meshes/` (created if missing).
    #[arg(long)]
    out_dir: PathBuf,
}

const SEGMENTS: usize = 64;
const RINGS: usize = 10;

struct JointSpec {
    name: &'static str,
    parent: &'static str,
    child: &'static str,
    /// Offset along the parent's z axis (m).
    z: f64,
    /// `None` for a fixed joint, else the axis and (limit deg, speed deg/s).
    actuated: Option<([f64; 3], f64, f64)>,
}

const Z: [f64; 3] = [0.0, 0.0, 1.0];
const Y: [f64; 3] = [0.0, 1.0, 0.0];

const JOINTS: [JointSpec; 8] = [
    JointSpec {
        name: "lwr_joint_1",
        parent: "lwr_base_link",
        child: "lwr_link_1",
        z: 0.11,
        actuated: Some((Z, 170.0, 100.0)),
    },
    JointSpec {
        name: "lwr_joint_2",
        parent: "lwr_link_1",
        child: "lwr_link_2",
        z: 0.20,
        actuated: Some((Y, 120.0, 110.0)),
    },
    JointSpec {
        name: "lwr_joint_3",
        parent: "lwr_link_2",
        child: "lwr_link_3",
        z: 0.20,
        actuated: Some((Z, 170.0, 100.0)),
    },
    JointSpec {
        name: "lwr_joint_4",
        parent: "lwr_link_3",
        child: "lwr_link_4",
        z: 0.20,
        actuated: Some((Y, 120.0, 130.0)),
    },
    JointSpec {
        name: "lwr_joint_5",
        parent: "lwr_link_4",
        child: "lwr_link_5",
        z: 0.20,
        actuated: Some((Z, 170.0, 130.0)),
    },
    JointSpec {
        name: "lwr_joint_6",
        parent: "lwr_link_5",
        child: "lwr_link_6",
        z: 0.19,
        actuated: Some((Y, 120.0, 180.0)),
    },
    JointSpec {
        name: "lwr_joint_7",
        parent: "lwr_link_6",
        child: "lwr_link_7",
        z: 0.078,
        actuated: Some((Z, 170.0, 180.0)),
    },
    JointSpec {
        name: "lwr_ee_joint",
        parent: "lwr_link_7",
        child: "lwr_ee_link",
        z: 0.10,
        actuated: None,
    },
];

/// Mesh of each link in its own frame (m).
fn link_mesh(link: &str) -> TriMesh {
    let seg =
        |r, z0, z1, bottom, top| TriMesh::rounded_cylinder(r, z0, z1, bottom, top, SEGMENTS, RINGS);
    match link {
        // Foot plate and column up to A1.
        "lwr_base_link" => TriMesh::revolution(
            &[
                (0.0, 0.0),
                (0.1, 0.0),
                (0.1, 0.015),
                (0.075, 0.03),
                (0.075, 0.11),
                (0.0, 0.11),
            ],
            SEGMENTS,
        ),
        // Yaw links rise from a flat joint face to the housing of the next pitch joint; pitch
        // links rise from their own housing to the next flat face.
        "lwr_link_1" => seg(0.07, 0.0, 0.20, false, true),
        "lwr_link_2" => seg(0.07, 0.0, 0.20, true, false),
        "lwr_link_3" => seg(0.065, 0.0, 0.20, false, true),
        "lwr_link_4" => seg(0.065, 0.0, 0.20, true, false),
        "lwr_link_5" => seg(0.06, 0.0, 0.19, false, true),
        "lwr_link_6" => seg(0.06, 0.0, 0.058, true, false),
        // Flange disc just below the A7 frame.
        "lwr_link_7" => TriMesh::cylinder(0.045, -0.02, 0.0, SEGMENTS),
        // Parallel gripper: body below the flange and two fingers reaching the TCP.
        "lwr_ee_link" => {
            let mut m = TriMesh::cylinder(0.04, -0.1, -0.045, SEGMENTS / 2);
            for side in [-1.0, 1.0] {
                let mut finger = TriMesh::cuboid(Vector3::new(0.0075, 0.01, 0.0225));
                finger.transform(&Isometry3::from_parts(
                    Translation3::new(side * 0.025, 0.0, -0.0225),
                    nalgebra::UnitQuaternion::identity(),
                ));
                m.append(&finger);
            }
            m
        }
        other => unreachable!("no mesh recipe for {other}"),
    }
}

fn links() -> Vec<&'static str> {
    std::iter::once(JOINTS[0].parent)
        .chain(JOINTS.iter().map(|j| j.child))
        .collect()
}

fn urdf_text() -> String {
    let mut s = String::new();
    let _ = writeln!(s, "<?xml version=\"1.0\"?>");
    let _ = writeln!(s, "<!-- KUKA LWR IV+ with a parallel gripper. GENERATED by");
    // No double hyphen may appear inside an XML comment, so the command line is spelled out.
    let _ = writeln!(
        s,
        "     the cowork_robot example generate_lwr_description (out-dir config/robot);"
    );
    let _ = writeln!(
        s,
        "     edit the generator, not this file. Lengths m, angles rad, speeds rad/s."
    );
    let _ = writeln!(s, "     Mesh paths are relative to this file. -->");
    let _ = writeln!(s, "<robot name=\"lwr4plus\">");
    let _ = writeln!(
        s,
        "  <material name=\"lwr_orange\"><color rgba=\"1.0 0.45 0.0 1.0\"/></material>"
    );
    let _ = writeln!(
        s,
        "  <material name=\"lwr_grey\"><color rgba=\"0.6 0.6 0.6 1.0\"/></material>"
    );
    for link in links() {
        let material = if link.starts_with("lwr_link_") && link != "lwr_link_7" {
            "lwr_orange"
        } else {
            "lwr_grey"
        };
        let _ = writeln!(s, "  <link name=\"{link}\">");
        for element in ["visual", "collision"] {
            let _ = writeln!(s, "    <{element}>");
            let _ = writeln!(s, "      <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/>");
            let _ = writeln!(
                s,
                "      <geometry><mesh filename=\"meshes/{link}.stl\"/></geometry>"
            );
            if element == "visual" {
                let _ = writeln!(s, "      <material name=\"{material}\"/>");
            }
            let _ = writeln!(s, "    </{element}>");
        }
        let _ = writeln!(s, "  </link>");
    }
    for j in &JOINTS {
        let kind = if j.actuated.is_some() {
            "revolute"
        } else {
            "fixed"
        };
        let _ = writeln!(s, "  <joint name=\"{}\" type=\"{kind}\">", j.name);
        let _ = writeln!(s, "    <parent link=\"{}\"/>", j.parent);
        let _ = writeln!(s, "    <child link=\"{}\"/>", j.child);
        let _ = writeln!(s, "    <origin xyz=\"0 0 {}\" rpy=\"0 0 0\"/>", j.z);
        if let Some((axis, limit_deg, speed_deg)) = j.actuated {
            let _ = writeln!(s, "    <axis xyz=\"{} {} {}\"/>", axis[0], axis[1], axis[2]);
            let lim = limit_deg.to_radians();
            let _ = writeln!(
                s,
                "    <limit lower=\"{:?}\" upper=\"{:?}\" effort=\"200\" velocity=\"{:?}\"/>",
                -lim,
                lim,
                speed_deg.to_radians()
            );
        }
        let _ = writeln!(s, "  </joint>");
    }
    let _ = writeln!(s, "</robot>");
    s
}

fn run(args: Args) -> anyhow::Result<()> {
    let meshes = args.out_dir.join("meshes");
    std::fs::create_dir_all(&meshes).with_context(|| format!("creating {}", meshes.display()))?;
    let mut total = 0;
    for link in links() {
        let mut mesh = link_mesh(link);
        mesh.weld_f32();
        let path = meshes.join(format!("{link}.stl"));
        let mut file =
            std::fs::File::create(&path).with_context(|| format!("creating {}", path.display()))?;
        mesh.write_stl(&mut file)
            .with_context(|| format!("writing {}", path.display()))?;
        println!(
            "{:>40}: {:5} vertices {:5} triangles",
            path.display(),
            mesh.vertices.len(),
            mesh.triangles.len()
        );
        total += mesh.vertices.len();
    }
    let urdf = args.out_dir.join("lwr4plus.urdf");
    std::fs::write(&urdf, urdf_text()).with_context(|| format!("writing {}", urdf.display()))?;
    println!(
        "{}: {} links, {total} mesh vertices",
        urdf.display(),
        links().len()
    );
    Ok(())
}

fn main() -> anyhow::Result<()> {
    run(Args::parse())
}
