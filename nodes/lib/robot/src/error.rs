//! Errors of loading a robot description.
//!
//! Every variant names the URDF file it came from (`urdf`; `<inline URDF>` for
//! [`RobotModel::from_urdf_str`](crate::RobotModel::from_urdf_str)) and the element or field at
//! fault, so a user can find the line to fix. Kinematic queries never fail at run time: inputs
//! are validated once when the model is built.

use std::path::PathBuf;

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// Why a robot description could not be loaded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The URDF file could not be read.
    #[error("cannot read URDF file {}: {source}", urdf.display())]
    Io {
        /// The URDF file.
        urdf: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },

    /// The URDF text is not well-formed XML or does not follow the URDF schema.
    #[error("malformed URDF {}: {message}", path.display())]
    Urdf {
        /// The URDF file.
        path: PathBuf,
        /// What the parser reported.
        message: String,
    },

    /// The kinematic tree has no single root link (a link that is no joint's child).
    #[error("URDF {}: expected exactly one root link, found {roots:?}", urdf.display())]
    Root {
        /// The URDF file.
        urdf: PathBuf,
        /// The root candidates found (empty when the joints form a cycle).
        roots: Vec<String>,
    },

    /// A joint names a parent or child link that the URDF does not define, or a link is the
    /// child of two joints.
    #[error("URDF {}: joint `{joint}` field `{field}` names link `{link}`: {problem}", urdf.display())]
    BadJointLink {
        /// The URDF file.
        urdf: PathBuf,
        /// The joint at fault.
        joint: String,
        /// `parent` or `child`.
        field: &'static str,
        /// The link it names.
        link: String,
        /// What is wrong with it.
        problem: &'static str,
    },

    /// The requested tip link does not exist in the URDF.
    #[error("URDF {}: tip link `{link}` is not defined", urdf.display())]
    UnknownTip {
        /// The URDF file.
        urdf: PathBuf,
        /// The requested link name.
        link: String,
    },

    /// Several leaf links are equally deep, so the tip of the chain is ambiguous; name one.
    #[error("URDF {}: tip link is ambiguous, deepest links are {candidates:?}; name one", urdf.display())]
    AmbiguousTip {
        /// The URDF file.
        urdf: PathBuf,
        /// The equally deep leaf links.
        candidates: Vec<String>,
    },

    /// The chain from the root to the tip does not have the required number of actuated joints.
    #[error(
        "URDF {}: chain `{root}` -> `{tip}` has {found} revolute/continuous joints, {required} required",
        urdf.display()
    )]
    DofMismatch {
        /// The URDF file.
        urdf: PathBuf,
        /// Root link of the chain.
        root: String,
        /// Tip link of the chain.
        tip: String,
        /// Actuated joints found on the chain.
        found: usize,
        /// Actuated joints required ([`DOF`](crate::DOF)).
        required: usize,
    },

    /// The chain has more links than [`MAX_LINKS`](crate::MAX_LINKS).
    #[error("URDF {}: chain has {found} links, at most {max} are supported", urdf.display())]
    TooManyLinks {
        /// The URDF file.
        urdf: PathBuf,
        /// Links on the chain.
        found: usize,
        /// The supported maximum.
        max: usize,
    },

    /// A joint on the chain has a type this crate cannot model (prismatic, planar, floating...).
    #[error("URDF {}: joint `{joint}` has unsupported type `{kind}` on the kinematic chain", urdf.display())]
    UnsupportedJoint {
        /// The URDF file.
        urdf: PathBuf,
        /// The joint at fault.
        joint: String,
        /// Its type attribute.
        kind: String,
    },

    /// A joint limit is NaN, infinite where a finite value is needed, inverted or non-positive.
    #[error("URDF {}: joint `{joint}` <limit {field}=\"{value}\">: {problem}", urdf.display())]
    BadLimit {
        /// The URDF file.
        urdf: PathBuf,
        /// The joint at fault.
        joint: String,
        /// `lower`, `upper` or `velocity`.
        field: &'static str,
        /// The offending value (rad or rad/s).
        value: f64,
        /// What is wrong with it.
        problem: &'static str,
    },

    /// A joint axis is zero or not finite.
    #[error("URDF {}: joint `{joint}` <axis xyz=\"{axis:?}\">: must be finite and non-zero", urdf.display())]
    BadAxis {
        /// The URDF file.
        urdf: PathBuf,
        /// The joint at fault.
        joint: String,
        /// The axis as written.
        axis: [f64; 3],
    },

    /// An `<origin>` (of a joint, visual or collision) or a geometry size is not finite.
    #[error("URDF {}: {element} field `{field}` = {value:?} is not finite", urdf.display())]
    NonFinite {
        /// The URDF file.
        urdf: PathBuf,
        /// The element, e.g. `joint lwr_a1 <origin>` or `link lwr_link_2 <collision> <mesh>`.
        element: String,
        /// The attribute, e.g. `xyz`, `rpy`, `scale`, `radius`.
        field: &'static str,
        /// The values as written.
        value: Vec<f64>,
    },

    /// A mesh file referenced by a link does not exist or cannot be read.
    #[error("URDF {}: link `{link}` mesh `{uri}` -> {}: {source}", urdf.display(), path.display())]
    MissingMesh {
        /// The URDF file.
        urdf: PathBuf,
        /// The link whose geometry names the mesh.
        link: String,
        /// The `filename` attribute as written.
        uri: String,
        /// The file it resolved to.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },

    /// A mesh file exists but is not a usable STL (parse error, unsupported format, no
    /// triangles, non-finite vertices).
    #[error("URDF {}: link `{link}` mesh {}: {message}", urdf.display(), path.display())]
    BadMesh {
        /// The URDF file.
        urdf: PathBuf,
        /// The link whose geometry names the mesh.
        link: String,
        /// The mesh file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
}
