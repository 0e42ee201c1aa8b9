//! `visualization_msgs`: markers for viewers (RViz, Foxglove), e.g. fDED's closest points,
//! the segment between them and the obstacle normals on `/fded/markers`.

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::Duration;
use crate::geometry_msgs::{Point, Pose, Vector3};
use crate::ros_message;
use crate::sensor_msgs::CompressedImage;
use crate::std_msgs::{ColorRGBA, Header};

/// A texture coordinate, each component a ratio of the texture's size in [0, 1].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UVCoordinate {
    /// Horizontal ratio.
    pub u: f32,
    /// Vertical ratio.
    pub v: f32,
}

ros_message!(UVCoordinate = "visualization_msgs" / "UVCoordinate" in "ros_std/visualization_msgs/msg", deps []);

/// A mesh file sent inside a marker.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeshFile {
    /// File name (its extension tells the parser).
    pub filename: String,
    /// Raw file content.
    #[serde(with = "crate::bytes")]
    pub data: Vec<u8>,
}

ros_message!(MeshFile = "visualization_msgs" / "MeshFile" in "ros_std/visualization_msgs/msg", deps []);

/// One shape for a viewer, in `header.frame_id`. Lengths in m.
///
/// `type` is a Rust keyword, so the field is `type_` (serde names it `type`; CDR is positional
/// anyway).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    /// Stamp and frame of `pose` and `points`.
    pub header: Header,
    /// Namespace; (`ns`, `id`) names the marker for later modification or deletion.
    pub ns: String,
    /// Id within the namespace.
    pub id: i32,
    /// Shape: [`Marker::ARROW`], [`Marker::SPHERE`], [`Marker::LINE_LIST`], ...
    #[serde(rename = "type")]
    pub type_: i32,
    /// [`Marker::ADD`] (add or modify), [`Marker::DELETE`] or [`Marker::DELETEALL`].
    pub action: i32,
    /// Pose of the shape in the header's frame.
    pub pose: Pose,
    /// Size (m); its meaning depends on the type (an arrow with two points: shaft diameter,
    /// head diameter, head length).
    pub scale: Vector3,
    /// Colour of the whole marker.
    pub color: ColorRGBA,
    /// Deleted by the viewer this long after it was received; zero means never.
    pub lifetime: Duration,
    /// Re-transform the marker into its frame at every viewer update.
    pub frame_locked: bool,
    /// Points of list and strip types, or start and end of an arrow (in the marker's pose).
    pub points: Vec<Point>,
    /// Per-point colours: empty or as many as `points`.
    pub colors: Vec<ColorRGBA>,
    /// Texture resource URI, or `embedded://name` for `texture`.
    pub texture_resource: String,
    /// Embedded texture.
    pub texture: CompressedImage,
    /// Texture coordinates per vertex.
    pub uv_coordinates: Vec<UVCoordinate>,
    /// Text of a [`Marker::TEXT_VIEW_FACING`] marker.
    pub text: String,
    /// Mesh resource URI, or `embedded://name` for `mesh_file`.
    pub mesh_resource: String,
    /// Embedded mesh.
    pub mesh_file: MeshFile,
    /// Use the mesh file's own materials.
    pub mesh_use_embedded_materials: bool,
}

ros_message!(
    Marker = "visualization_msgs" / "Marker" in "ros_std/visualization_msgs/msg",
    deps [Header, Pose, Vector3, ColorRGBA, Duration, Point, CompressedImage, UVCoordinate, MeshFile],
    consts {
        /// An arrow (from `points[0]` to `points[1]` when given).
        ARROW: i32 = 0,
        /// A box.
        CUBE: i32 = 1,
        /// A sphere (ellipsoid by `scale`).
        SPHERE: i32 = 2,
        /// A cylinder.
        CYLINDER: i32 = 3,
        /// A polyline through `points`.
        LINE_STRIP: i32 = 4,
        /// Segments between consecutive pairs of `points`.
        LINE_LIST: i32 = 5,
        /// A box at every point.
        CUBE_LIST: i32 = 6,
        /// A sphere at every point.
        SPHERE_LIST: i32 = 7,
        /// A square at every point.
        POINTS: i32 = 8,
        /// `text`, facing the viewer.
        TEXT_VIEW_FACING: i32 = 9,
        /// The mesh at `mesh_resource`.
        MESH_RESOURCE: i32 = 10,
        /// Triangles from consecutive triples of `points`.
        TRIANGLE_LIST: i32 = 11,
        /// Arrows along `points` (not implemented by RViz).
        ARROW_STRIP: i32 = 12,
        /// Add or modify.
        ADD: i32 = 0,
        /// Add or modify (same as `ADD`).
        MODIFY: i32 = 0,
        /// Delete the marker (`ns`, `id`).
        DELETE: i32 = 2,
        /// Delete every marker (of `ns` if given).
        DELETEALL: i32 = 3,
    },
);

/// A set of markers published together.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MarkerArray {
    /// The markers.
    pub markers: Vec<Marker>,
}

ros_message!(MarkerArray = "visualization_msgs" / "MarkerArray" in "ros_std/visualization_msgs/msg", deps [Marker]);
