//! URDF → [`ChainParts`]: the only module that sees `urdf_rs` types.
//!
//! Steps: parse; index links and joints; find the single root; pick the tip (named, or the
//! deepest leaf); walk the chain; validate joints (type, axis, limits, origins); fold fixed joints
//! into link offsets; load each chain link's collision geometry (visual when it has none).

use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::model::{
    ChainJoint, ChainLink, ChainParts, DOF, JointLimit, MAX_LINKS, origin_to_isometry,
};
use nalgebra::{Isometry3, Unit, Vector3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Tessellation of URDF primitive shapes (segments around, rings per hemisphere).
const PRIMITIVE_SEGMENTS: usize = 24;
const PRIMITIVE_RINGS: usize = 6;

pub(crate) fn load_file(path: &Path, tip: Option<&str>) -> Result<ChainParts> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
        urdf: path.to_path_buf(),
        source,
    })?;
    let dir = path.parent().unwrap_or_else(|| Path::new("."));
    load(&text, path, dir, tip)
}

pub(crate) fn load_str(text: &str, base_dir: &Path, tip: Option<&str>) -> Result<ChainParts> {
    load(text, &base_dir.join("<inline URDF>"), base_dir, tip)
}

fn load(text: &str, urdf: &Path, dir: &Path, tip: Option<&str>) -> Result<ChainParts> {
    let robot = urdf_rs::read_from_string(text).map_err(|e| Error::Urdf {
        path: urdf.to_path_buf(),
        message: e.to_string(),
    })?;
    let cx = Context { urdf, dir };

    let link_by_name: HashMap<&str, &urdf_rs::Link> =
        robot.links.iter().map(|l| (l.name.as_str(), l)).collect();
    if link_by_name.len() != robot.links.len() {
        let mut seen = std::collections::HashSet::new();
        let dup = robot
            .links
            .iter()
            .find(|l| !seen.insert(l.name.as_str()))
            .map(|l| l.name.clone());
        return Err(Error::Urdf {
            path: urdf.to_path_buf(),
            message: format!("link `{}` is defined twice", dup.unwrap_or_default()),
        });
    }
    // The joint whose child a link is.
    let mut parent_joint: HashMap<&str, &urdf_rs::Joint> = HashMap::new();
    for j in &robot.joints {
        for (field, link) in [("parent", &j.parent.link), ("child", &j.child.link)] {
            if !link_by_name.contains_key(link.as_str()) {
                return Err(cx.bad_joint_link(j, field, link, "no such link"));
            }
        }
        if parent_joint.insert(j.child.link.as_str(), j).is_some() {
            return Err(cx.bad_joint_link(
                j,
                "child",
                &j.child.link,
                "link is the child of two joints",
            ));
        }
    }
    let roots: Vec<&str> = robot
        .links
        .iter()
        .map(|l| l.name.as_str())
        .filter(|n| !parent_joint.contains_key(n))
        .collect();
    let [root] = roots[..] else {
        return Err(Error::Root {
            urdf: urdf.to_path_buf(),
            roots: roots.iter().map(|s| s.to_string()).collect(),
        });
    };

    let path_to = |link| path_to_root(&parent_joint, link, robot.links.len());
    let cycle_error = || Error::Root {
        urdf: urdf.to_path_buf(),
        roots: vec![],
    };

    let tip_name: &str = match tip {
        Some(t) => link_by_name
            .get_key_value(t)
            .map(|(k, _)| *k)
            .ok_or_else(|| Error::UnknownTip {
                urdf: urdf.to_path_buf(),
                link: t.to_string(),
            })?,
        None => {
            let has_child: std::collections::HashSet<&str> = robot
                .joints
                .iter()
                .map(|j| j.parent.link.as_str())
                .collect();
            let mut best: Vec<&str> = Vec::new();
            let mut best_depth = 0;
            for l in robot
                .links
                .iter()
                .map(|l| l.name.as_str())
                .filter(|l| !has_child.contains(l))
            {
                let depth = path_to(l).ok_or_else(cycle_error)?.len();
                if depth > best_depth {
                    best_depth = depth;
                    best.clear();
                }
                if depth == best_depth {
                    best.push(l);
                }
            }
            match best[..] {
                [one] => one,
                _ => {
                    return Err(Error::AmbiguousTip {
                        urdf: urdf.to_path_buf(),
                        candidates: best.iter().map(|s| s.to_string()).collect(),
                    });
                }
            }
        }
    };
    let chain = path_to(tip_name).ok_or_else(cycle_error)?;
    debug_assert_eq!(chain.first().copied(), Some(root));

    use urdf_rs::JointType as T;
    for l in &chain[1..] {
        let j = parent_joint[l];
        if !matches!(j.joint_type, T::Revolute | T::Continuous | T::Fixed) {
            return Err(Error::UnsupportedJoint {
                urdf: urdf.to_path_buf(),
                joint: j.name.clone(),
                kind: format!("{:?}", j.joint_type).to_lowercase(),
            });
        }
    }
    let found = chain[1..]
        .iter()
        .filter(|l| {
            matches!(
                parent_joint[*l].joint_type,
                urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous
            )
        })
        .count();
    if found != DOF {
        return Err(Error::DofMismatch {
            urdf: urdf.to_path_buf(),
            root: root.to_string(),
            tip: tip_name.to_string(),
            found,
            required: DOF,
        });
    }

    // Walk the chain. Fixed joints contribute their origin; the link after them is kept as its
    // own frame (tool/flange frames are useful), so "folding" means a constant offset.
    let mut links: Vec<ChainLink> = Vec::with_capacity(chain.len());
    let mut joints: Vec<ChainJoint> = Vec::with_capacity(DOF);
    for (i, &name) in chain.iter().enumerate() {
        let (origin, joint, axis) = if i == 0 {
            (Isometry3::identity(), None, Vector3::z_axis())
        } else {
            let j = parent_joint[name];
            let origin = cx.origin(&format!("joint `{}` <origin>", j.name), &j.origin)?;
            match j.joint_type {
                urdf_rs::JointType::Fixed => (origin, None, Vector3::z_axis()),
                urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => {
                    let axis = cx.axis(j)?;
                    joints.push(ChainJoint {
                        name: j.name.clone(),
                        limit: cx.limit(j)?,
                    });
                    (origin, Some(joints.len() - 1), axis)
                }
                _ => unreachable!("joint types were checked above"),
            }
        };
        let mesh = cx.link_mesh(link_by_name[name])?;
        links.push(ChainLink {
            name: name.to_string(),
            origin,
            joint,
            axis,
            mesh,
        });
    }
    if links.len() > MAX_LINKS {
        return Err(Error::TooManyLinks {
            urdf: urdf.to_path_buf(),
            found: links.len(),
            max: MAX_LINKS,
        });
    }
    let joints: [ChainJoint; DOF] = joints
        .try_into()
        .unwrap_or_else(|_| unreachable!("the chain was checked to have DOF actuated joints"));
    Ok(ChainParts {
        name: robot.name.clone(),
        source: urdf.to_path_buf(),
        links,
        joints,
    })
}

struct Context<'a> {
    urdf: &'a Path,
    dir: &'a Path,
}

impl Context<'_> {
    fn bad_joint_link(
        &self,
        j: &urdf_rs::Joint,
        field: &'static str,
        link: &str,
        problem: &'static str,
    ) -> Error {
        Error::BadJointLink {
            urdf: self.urdf.to_path_buf(),
            joint: j.name.clone(),
            field,
            link: link.to_string(),
            problem,
        }
    }

    fn finite(&self, element: &str, field: &'static str, v: &[f64]) -> Result<()> {
        if v.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(Error::NonFinite {
                urdf: self.urdf.to_path_buf(),
                element: element.to_string(),
                field,
                value: v.to_vec(),
            })
        }
    }

    fn origin(&self, element: &str, pose: &urdf_rs::Pose) -> Result<Isometry3<f64>> {
        self.finite(element, "xyz", &pose.xyz.0)?;
        self.finite(element, "rpy", &pose.rpy.0)?;
        Ok(origin_to_isometry(pose.xyz.0, pose.rpy.0))
    }

    fn axis(&self, j: &urdf_rs::Joint) -> Result<Unit<Vector3<f64>>> {
        let a = j.axis.xyz.0;
        let v = Vector3::from(a);
        if !v.iter().all(|x| x.is_finite()) {
            return Err(Error::BadAxis {
                urdf: self.urdf.to_path_buf(),
                joint: j.name.clone(),
                axis: a,
            });
        }
        Unit::try_new(v, 1e-12).ok_or_else(|| Error::BadAxis {
            urdf: self.urdf.to_path_buf(),
            joint: j.name.clone(),
            axis: a,
        })
    }

    /// Revolute joints need finite `lower < upper`; continuous joints get ±∞. Both need a finite,
    /// positive `velocity` (the simulator saturates at it). urdf-rs reads a missing `<limit>` as
    /// all zeros, which fails here as it should.
    fn limit(&self, j: &urdf_rs::Joint) -> Result<JointLimit> {
        let l = &j.limit;
        let bad = |field, value, problem| Error::BadLimit {
            urdf: self.urdf.to_path_buf(),
            joint: j.name.clone(),
            field,
            value,
            problem,
        };
        let (lower, upper) = if j.joint_type == urdf_rs::JointType::Continuous {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            if !l.lower.is_finite() {
                return Err(bad("lower", l.lower, "must be a finite number (rad)"));
            }
            if !l.upper.is_finite() {
                return Err(bad("upper", l.upper, "must be a finite number (rad)"));
            }
            if l.lower >= l.upper {
                return Err(bad(
                    "lower",
                    l.lower,
                    "must be below `upper` (missing <limit>, or inverted)",
                ));
            }
            (l.lower, l.upper)
        };
        if !(l.velocity.is_finite() && l.velocity > 0.0) {
            return Err(bad(
                "velocity",
                l.velocity,
                "must be a finite positive number (rad/s)",
            ));
        }
        Ok(JointLimit {
            lower,
            upper,
            velocity: l.velocity,
        })
    }

    /// All `<collision>` geometry of a link merged in the link frame; the `<visual>` geometry
    /// when the link has no collision element.
    fn link_mesh(&self, link: &urdf_rs::Link) -> Result<Option<TriMesh>> {
        let (kind, elements): (&str, Vec<(&urdf_rs::Pose, &urdf_rs::Geometry)>) =
            if link.collision.is_empty() {
                (
                    "visual",
                    link.visual
                        .iter()
                        .map(|v| (&v.origin, &v.geometry))
                        .collect(),
                )
            } else {
                (
                    "collision",
                    link.collision
                        .iter()
                        .map(|c| (&c.origin, &c.geometry))
                        .collect(),
                )
            };
        if elements.is_empty() {
            return Ok(None);
        }
        let mut merged = TriMesh::new();
        for (origin, geometry) in elements {
            let element = format!("link `{}` <{kind}>", link.name);
            let pose = self.origin(&format!("{element} <origin>"), origin)?;
            let mut mesh = self.geometry(&link.name, &element, geometry)?;
            mesh.transform(&pose);
            merged.append(&mesh);
        }
        Ok(Some(merged))
    }

    fn geometry(&self, link: &str, element: &str, g: &urdf_rs::Geometry) -> Result<TriMesh> {
        use urdf_rs::Geometry as G;
        let positive = |field: &'static str, v: f64| -> Result<f64> {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(Error::NonFinite {
                    urdf: self.urdf.to_path_buf(),
                    element: element.to_string(),
                    field,
                    value: vec![v],
                })
            }
        };
        Ok(match g {
            G::Box { size } => {
                let s = size.0;
                for v in s {
                    positive("size", v)?;
                }
                TriMesh::cuboid(Vector3::from(s) / 2.0)
            }
            G::Cylinder { radius, length } => {
                let (r, l) = (positive("radius", *radius)?, positive("length", *length)?);
                TriMesh::cylinder(r, -l / 2.0, l / 2.0, PRIMITIVE_SEGMENTS)
            }
            G::Capsule { radius, length } => {
                let (r, l) = (positive("radius", *radius)?, positive("length", *length)?);
                TriMesh::rounded_cylinder(
                    r,
                    -l / 2.0,
                    l / 2.0,
                    true,
                    true,
                    PRIMITIVE_SEGMENTS,
                    PRIMITIVE_RINGS,
                )
            }
            G::Sphere { radius } => TriMesh::sphere(
                positive("radius", *radius)?,
                PRIMITIVE_SEGMENTS,
                PRIMITIVE_RINGS,
            ),
            G::Mesh { filename, scale } => {
                let path = self.resolve_mesh(filename);
                let mut file = std::fs::File::open(&path).map_err(|source| Error::MissingMesh {
                    urdf: self.urdf.to_path_buf(),
                    link: link.to_string(),
                    uri: filename.clone(),
                    path: path.clone(),
                    source,
                })?;
                let bad_mesh = |message: String| Error::BadMesh {
                    urdf: self.urdf.to_path_buf(),
                    link: link.to_string(),
                    path: path.clone(),
                    message,
                };
                let is_stl = path
                    .extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| e.eq_ignore_ascii_case("stl"));
                if !is_stl {
                    return Err(bad_mesh(
                        "unsupported mesh format, only STL (.stl) is read".into(),
                    ));
                }
                let mut mesh = TriMesh::read_stl(&mut file).map_err(bad_mesh)?;
                if let Some(s) = scale {
                    self.finite(&format!("{element} <mesh>"), "scale", &s.0)?;
                    mesh.scale(&Vector3::from(s.0));
                }
                mesh
            }
        })
    }

    /// Mesh URI → file. `file://` and plain paths: absolute as they are, relative against the
    /// URDF's directory. `package://PKG/REST`: `<urdf dir>/REST` when it exists (URDF at the
    /// package root, the layout of `config/robot/`), else `<urdf dir>/../REST` (the ROS
    /// description-package layout with the URDF in `PKG/urdf/`). The package name is not looked
    /// up anywhere: there is no ROS install to ask.
    fn resolve_mesh(&self, uri: &str) -> PathBuf {
        if let Some(rest) = uri.strip_prefix("package://") {
            let rest = rest.split_once('/').map_or("", |(_, r)| r);
            let beside = self.dir.join(rest);
            if beside.exists() {
                return beside;
            }
            let above = self.dir.join("..").join(rest);
            return if above.exists() { above } else { beside };
        }
        let path = uri.strip_prefix("file://").unwrap_or(uri);
        let path = Path::new(path);
        if path.is_absolute() {
            path.to_path_buf()
        } else {
            self.dir.join(path)
        }
    }
}

/// Link names from the root to `link`, root first; `None` when following parents loops.
fn path_to_root<'a>(
    parent_joint: &HashMap<&'a str, &'a urdf_rs::Joint>,
    link: &'a str,
    max: usize,
) -> Option<Vec<&'a str>> {
    let mut chain = vec![link];
    let mut cur = link;
    while let Some(j) = parent_joint.get(cur) {
        cur = j.parent.link.as_str();
        chain.push(cur);
        if chain.len() > max {
            return None;
        }
    }
    chain.reverse();
    Some(chain)
}
