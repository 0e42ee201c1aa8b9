//! The depth renderer: table, scene objects, robot link meshes at joints `q`, and people.

use cowork_robot::{JointVector, LinkPoses, RobotModel};
use cowork_sim::{ObjectState, Scene, Shape};
use nalgebra::{Isometry3, Point3, Vector3};
use rayon::prelude::*;

use crate::capsule::Capsule;
use crate::error::{Error, Result};
use crate::image::DepthImage;
use crate::intrinsics::Intrinsics;
use crate::noise::KinectNoise;
use crate::raster::{DrawList, PrimShape, Rays, raster_band};

/// Rows per band: the unit of parallel work and of noise random streams. Fixed, so results do
/// not depend on the thread count.
const BAND_ROWS: usize = 16;

/// What a pixel shows, from the noise-free render.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Label {
    /// Nothing (no return).
    #[default]
    None,
    /// The table.
    Table,
    /// The floor.
    Floor,
    /// Scene object with this index in the `objects` slice given to
    /// [`DepthRenderer::render`].
    Object(u16),
    /// Robot link with this index (as in [`RobotModel::link_names`]).
    Link(u16),
    /// Person capsule with this index in the `people` slice given to
    /// [`DepthRenderer::render`].
    Person(u16),
}

impl Label {
    /// `true` for robot pixels.
    pub fn is_robot(self) -> bool {
        matches!(self, Label::Link(_))
    }
}

/// A scene object as the renderer sees it: a shape (centred on its pose; cylinders along the
/// pose's z axis, as in [`cowork_sim::Shape`]) and its pose in the base frame.
///
/// Implemented for the simulator's [`ObjectState`] and for `(Shape, Isometry3<f64>)`, so a
/// simulator's object list can be rendered without copying.
pub trait ObjectView {
    /// Geometry, m.
    fn shape(&self) -> Shape;
    /// Pose of the shape's centre, base frame ← object frame.
    fn pose(&self) -> Isometry3<f64>;
}

impl ObjectView for ObjectState {
    fn shape(&self) -> Shape {
        self.shape
    }
    fn pose(&self) -> Isometry3<f64> {
        self.pose
    }
}

impl ObjectView for (Shape, Isometry3<f64>) {
    fn shape(&self) -> Shape {
        self.0
    }
    fn pose(&self) -> Isometry3<f64> {
        self.1
    }
}

impl<T: ObjectView> ObjectView for &T {
    fn shape(&self) -> Shape {
        (*self).shape()
    }
    fn pose(&self) -> Isometry3<f64> {
        (*self).pose()
    }
}

/// Which parts of the world are drawn (all by default). fDED's "virtual depth" is a render with
/// only `robot`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layers {
    /// The table.
    pub table: bool,
    /// The floor (if the renderer has one, see [`DepthRenderer::set_floor`]).
    pub floor: bool,
    /// Scene objects.
    pub objects: bool,
    /// The robot's link meshes.
    pub robot: bool,
    /// People capsules.
    pub people: bool,
}

impl Default for Layers {
    fn default() -> Self {
        Self { table: true, floor: true, objects: true, robot: true, people: true }
    }
}

impl Layers {
    /// Only the robot (fDED's virtual depth).
    pub fn robot_only() -> Self {
        Self { table: false, floor: false, objects: false, robot: true, people: false }
    }
}

/// A box-shaped table: full side lengths (m) and the pose of its centre (base frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Table {
    /// Full side lengths, m.
    pub size: [f64; 3],
    /// Base frame ← table centre.
    pub pose: Isometry3<f64>,
}

/// A horizontal floor: the square `|x|, |y| ≤ half_size` (m, base frame) of the plane
/// `z = height`, seen from above (from below it is culled).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Floor {
    /// Height of the floor in the base frame, m (the robot stands on a table: negative).
    pub height: f64,
    /// Half the side of the square drawn, m.
    pub half_size: f64,
}

impl Floor {
    /// Half side of the floor square by default (m): a room around the robot, beyond the
    /// camera's range.
    pub const DEFAULT_HALF_SIZE: f64 = 6.0;

    /// A floor at `height` (m, base frame) of the default size.
    pub fn at(height: f64) -> Self {
        Self { height, half_size: Self::DEFAULT_HALF_SIZE }
    }
}

/// One robot link's mesh as the renderer keeps it.
#[derive(Debug, Clone)]
struct LinkMesh {
    link: usize,
    vertices: Vec<Point3<f64>>,
    triangles: Vec<[u32; 3]>,
    /// Back faces skipped: the mesh is closed and wound outward (positive volume).
    cull: bool,
}

/// Renders 640×480 (or any size) depth images of a table-top scene with a robot and people.
///
/// Geometry: robot link meshes (from the URDF, posed by forward kinematics at `q`), the table
/// and box objects are triangles drawn with a z-buffer whose depth is interpolated exactly on
/// each triangle's plane; cylinder and sphere objects and people [`Capsule`]s are ray cast
/// exactly per pixel. Every pixel centre samples the nearest surface along its ray; the depth
/// is the optical-frame z (m). Geometry nearer than 1 cm to the camera is clipped.
///
/// Work per frame: forward kinematics, one transform per mesh vertex, one set-up per triangle,
/// then bands of 16 rows rasterised in parallel on the rayon pool (or in turn with
/// [`set_parallel(false)`](Self::set_parallel)). Buffers are kept between frames: after the
/// first frame, rendering allocates nothing (unless the scene grows).
#[derive(Debug)]
pub struct DepthRenderer {
    model: RobotModel,
    intrinsics: Intrinsics,
    /// Base ← optical.
    camera_pose: Isometry3<f64>,
    /// Optical ← base.
    camera_from_base: Isometry3<f64>,
    table: Option<Table>,
    floor: Option<Floor>,
    links: Vec<LinkMesh>,
    layers: Layers,
    parallel: bool,
    noise: Option<KinectNoise>,
    frame: u64,
    rays: Rays,
    poses: LinkPoses,
    scratch: Vec<Point3<f64>>,
    list: DrawList,
    inv: Vec<f32>,
    labels: Vec<Label>,
    clean: DepthImage,
}

impl DepthRenderer {
    /// A renderer for `scene`: the camera's intrinsics and pose (`scene.camera`, base ←
    /// optical), and its table. The model's link meshes are copied.
    pub fn new(model: &RobotModel, scene: &Scene) -> Result<Self> {
        let c = &scene.camera;
        let intrinsics = Intrinsics { width: c.width, height: c.height, fx: c.fx, fy: c.fy, cx: c.cx, cy: c.cy };
        let mut r = Self::with_camera(model, intrinsics, c.pose.isometry())?;
        r.set_table(Some(Table { size: scene.table.size, pose: scene.table.pose.isometry() }))?;
        Ok(r)
    }

    /// A renderer for a camera with `intrinsics` at `camera_pose` (base ← optical frame), with
    /// no table.
    pub fn with_camera(model: &RobotModel, intrinsics: Intrinsics, camera_pose: Isometry3<f64>) -> Result<Self> {
        intrinsics.validate()?;
        check_pose("camera_pose", &camera_pose)?;
        let links = (0..model.link_count())
            .filter_map(|link| {
                let mesh = model.link_mesh(link)?;
                if mesh.is_empty() {
                    return None;
                }
                let volume = mesh.signed_volume();
                let mut triangles = mesh.triangles.clone();
                if volume < 0.0 {
                    for t in &mut triangles {
                        t.swap(1, 2);
                    }
                }
                Some(LinkMesh {
                    link,
                    vertices: mesh.vertices.clone(),
                    triangles,
                    cull: is_closed(&mesh.triangles) && volume != 0.0,
                })
            })
            .collect::<Vec<_>>();
        let max_vertices = links.iter().map(|l| l.vertices.len()).max().unwrap_or(0);
        let n = intrinsics.pixel_count();
        Ok(Self {
            model: model.clone(),
            rays: Rays::new(&intrinsics),
            intrinsics,
            camera_pose,
            camera_from_base: camera_pose.inverse(),
            table: None,
            floor: None,
            links,
            layers: Layers::default(),
            parallel: true,
            noise: None,
            frame: 0,
            poses: LinkPoses::new(),
            scratch: Vec::with_capacity(max_vertices),
            list: DrawList::default(),
            inv: vec![0.0; n],
            labels: vec![Label::None; n],
            clean: DepthImage::new(intrinsics.width, intrinsics.height),
        })
    }

    /// Sets or removes the table.
    pub fn set_table(&mut self, table: Option<Table>) -> Result<()> {
        if let Some(t) = &table {
            for (i, s) in t.size.iter().enumerate() {
                if !(s.is_finite() && *s > 0.0) {
                    return Err(Error::bad_value(format!("table.size[{i}]"), s, "must be finite and > 0 m"));
                }
            }
            check_pose("table.pose", &t.pose)?;
        }
        self.table = table;
        Ok(())
    }

    /// Sets or removes the floor (none by default). People stand on it, so a renderer that
    /// draws people should have one at their floor height.
    pub fn set_floor(&mut self, floor: Option<Floor>) -> Result<()> {
        if let Some(f) = &floor {
            if !f.height.is_finite() {
                return Err(Error::bad_value("floor.height", f.height, "must be finite (m)"));
            }
            if !(f.half_size.is_finite() && f.half_size > 0.0) {
                return Err(Error::bad_value("floor.half_size", f.half_size, "must be finite and > 0 m"));
            }
        }
        self.floor = floor;
        Ok(())
    }

    /// The floor, if any.
    pub fn floor(&self) -> Option<&Floor> {
        self.floor.as_ref()
    }

    /// Moves the camera (base ← optical frame).
    pub fn set_camera_pose(&mut self, camera_pose: Isometry3<f64>) -> Result<()> {
        check_pose("camera_pose", &camera_pose)?;
        self.camera_pose = camera_pose;
        self.camera_from_base = camera_pose.inverse();
        Ok(())
    }

    /// Switches Kinect-like noise on (`Some`) or off (`None`). Turning it on restarts the
    /// noise sequence of the seed.
    pub fn set_noise(&mut self, noise: Option<KinectNoise>) -> Result<()> {
        if let Some(n) = &noise {
            n.validate()?;
        }
        self.noise = noise;
        self.frame = 0;
        Ok(())
    }

    /// Chooses what is drawn.
    pub fn set_layers(&mut self, layers: Layers) {
        self.layers = layers;
    }

    /// Rasterise bands on the rayon pool (`true`, default) or in turn on the calling thread.
    pub fn set_parallel(&mut self, parallel: bool) {
        self.parallel = parallel;
    }

    /// The camera intrinsics.
    pub fn intrinsics(&self) -> &Intrinsics {
        &self.intrinsics
    }

    /// The camera pose, base ← optical frame.
    pub fn camera_pose(&self) -> &Isometry3<f64> {
        &self.camera_pose
    }

    /// The noise model in use, if any.
    pub fn noise(&self) -> Option<&KinectNoise> {
        self.noise.as_ref()
    }

    /// The robot model whose meshes are drawn.
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// Per-pixel labels of the last frame (row-major, as [`DepthImage::data`]), from the
    /// noise-free render: a pixel the noise dropped keeps the label of what is there.
    pub fn labels(&self) -> &[Label] {
        &self.labels
    }

    /// The noise-free depth of the last frame (equal to the output when noise is off).
    pub fn clean_depth(&self) -> &DepthImage {
        &self.clean
    }

    /// Number of triangles that reached scan conversion in the last frame (after culling and
    /// clipping), and of ray-cast shapes.
    pub fn last_frame_counts(&self) -> (usize, usize) {
        (self.list.tris.len(), self.list.prims.len())
    }

    /// Renders the scene with the robot at joint positions `q` (rad), `objects` at their poses
    /// and `people` capsules (base frame) into `out` (resized to the camera's image if needed).
    ///
    /// Labels of objects and people are their indices in these slices. Fails, leaving `out`
    /// untouched, on a non-finite joint position, object pose or size, or bad capsule.
    pub fn render<O: ObjectView>(&mut self, q: &JointVector, objects: &[O], people: &[Capsule], out: &mut DepthImage) -> Result<()> {
        self.render_arms(&[(Isometry3::identity(), *q)], objects, people, out)
    }

    /// [`render`](Self::render) with several arms of the model: each `(base, q)` is an arm
    /// whose base frame is at `base` (in the frame of the camera pose and the objects) at joint
    /// positions `q` (rad). Every arm's pixels are labelled [`Label::Link`] with the link's
    /// model index.
    pub fn render_arms<O: ObjectView>(
        &mut self,
        arms: &[(Isometry3<f64>, JointVector)],
        objects: &[O],
        people: &[Capsule],
        out: &mut DepthImage,
    ) -> Result<()> {
        for (a, (base, q)) in arms.iter().enumerate() {
            let at = |field: String| if arms.len() == 1 { field } else { format!("arms[{a}].{field}") };
            if let Some((i, v)) = q.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(Error::bad_value(at(format!("q[{i}]")), v, "joint position must be finite"));
            }
            if !pose_is_finite(base) {
                return Err(Error::bad_value(at("base".into()), format!("{base:?}"), "must be finite"));
            }
        }
        for (i, c) in people.iter().enumerate() {
            c.validate().map_err(|e| match e {
                Error::BadValue { field, value, reason } => {
                    Error::BadValue { field: format!("people[{i}].{}", field.trim_start_matches("capsule.")), value, reason }
                }
                other => other,
            })?;
        }
        for (i, o) in objects.iter().enumerate() {
            if !pose_is_finite(&o.pose()) {
                return Err(Error::bad_value(format!("objects[{i}].pose"), format!("{:?}", o.pose()), "must be finite"));
            }
            check_shape(i, &o.shape())?;
        }
        if objects.len() > usize::from(u16::MAX) || people.len() > usize::from(u16::MAX) {
            return Err(Error::bad_value("objects/people", objects.len().max(people.len()), "at most 65535 of each"));
        }

        self.build_draw_list(arms, objects, people);
        self.rasterise();
        let (w, h) = (self.intrinsics.width, self.intrinsics.height);
        if out.width != w || out.height != h || out.data.len() != self.clean.data.len() {
            out.reset(w, h);
        }
        match self.noise {
            None => out.data.copy_from_slice(&self.clean.data),
            Some(noise) => {
                let width = w as usize;
                let clean = &self.clean.data;
                let frame = self.frame;
                let band = |(b, chunk): (usize, &mut [f32])| {
                    let mut rng = noise.rng(frame, b as u64);
                    noise.apply_band(clean, width, b * BAND_ROWS, chunk, &mut rng);
                };
                if self.parallel {
                    out.data.par_chunks_mut(width * BAND_ROWS).enumerate().for_each(band);
                } else {
                    out.data.chunks_mut(width * BAND_ROWS).enumerate().for_each(band);
                }
                self.frame += 1;
            }
        }
        Ok(())
    }

    fn build_draw_list<O: ObjectView>(&mut self, arms: &[(Isometry3<f64>, JointVector)], objects: &[O], people: &[Capsule]) {
        let k = self.intrinsics;
        let cam = self.camera_from_base;
        self.list.clear();
        let robot = self.layers.robot;
        for (base, q) in arms.iter().filter(|_| robot) {
            self.model.forward_kinematics(q, &mut self.poses);
            for mesh in &self.links {
                let to_cam = cam * base * self.poses.get(mesh.link);
                self.scratch.clear();
                self.scratch.extend(mesh.vertices.iter().map(|v| to_cam * v));
                let label = Label::Link(mesh.link as u16);
                for t in &mesh.triangles {
                    let p = t.map(|i| self.scratch[i as usize]);
                    self.list.triangle(&k, p, mesh.cull, label);
                }
            }
        }
        if self.layers.table {
            if let Some(t) = self.table {
                push_box(&mut self.list, &k, &(cam * t.pose), t.size, Label::Table);
            }
        }
        if self.layers.floor
            && let Some(f) = self.floor
        {
            let h = f.half_size;
            let c = [(-h, -h), (h, -h), (h, h), (-h, h)].map(|(x, y)| cam * Point3::new(x, y, f.height));
            // Counter-clockwise seen from above: culled from below.
            self.list.triangle(&k, [c[0], c[1], c[2]], true, Label::Floor);
            self.list.triangle(&k, [c[0], c[2], c[3]], true, Label::Floor);
        }
        if self.layers.objects {
            for (i, o) in objects.iter().enumerate() {
                let label = Label::Object(i as u16);
                let pose = cam * o.pose();
                match o.shape() {
                    Shape::Box { size } => push_box(&mut self.list, &k, &pose, size, label),
                    Shape::Sphere { radius } => {
                        let c = Point3::from(pose.translation.vector);
                        let r = Vector3::repeat(radius);
                        self.list.prim(&k, PrimShape::Sphere { c, r: radius }, c - r, c + r, label);
                    }
                    Shape::Cylinder { radius, height } => {
                        let a = pose * Point3::new(0.0, 0.0, -0.5 * height);
                        let b = pose * Point3::new(0.0, 0.0, 0.5 * height);
                        let r = Vector3::repeat(radius);
                        let shape = PrimShape::Cylinder { a, b, r: radius };
                        self.list.prim(&k, shape, a.inf(&b) - r, a.sup(&b) + r, label);
                    }
                }
            }
        }
        if self.layers.people {
            for (i, c) in people.iter().enumerate() {
                let (a, b) = (cam * c.a, cam * c.b);
                let r = Vector3::repeat(c.radius);
                let shape = PrimShape::Capsule { a, b, r: c.radius };
                self.list.prim(&k, shape, a.inf(&b) - r, a.sup(&b) + r, Label::Person(i as u16));
            }
        }
    }

    fn rasterise(&mut self) {
        let width = self.intrinsics.width as usize;
        let chunk = width * BAND_ROWS;
        let list = &self.list;
        let rays = &self.rays;
        let band = |(b, ((inv, labels), depth)): (usize, ((&mut [f32], &mut [Label]), &mut [f32]))| {
            inv.fill(0.0);
            labels.fill(Label::None);
            raster_band(list, rays, width, b * BAND_ROWS, inv, labels);
            for (d, w) in depth.iter_mut().zip(inv.iter()) {
                *d = if *w > 0.0 { 1.0 / *w } else { 0.0 };
            }
        };
        if self.parallel {
            self.inv
                .par_chunks_mut(chunk)
                .zip(self.labels.par_chunks_mut(chunk))
                .zip(self.clean.data.par_chunks_mut(chunk))
                .enumerate()
                .for_each(band);
        } else {
            self.inv
                .chunks_mut(chunk)
                .zip(self.labels.chunks_mut(chunk))
                .zip(self.clean.data.chunks_mut(chunk))
                .enumerate()
                .for_each(band);
        }
    }
}

/// The 12 triangles of a box of full `size` (m) centred on `pose` (camera ← box).
fn push_box(list: &mut DrawList, k: &Intrinsics, pose: &Isometry3<f64>, size: [f64; 3], label: Label) {
    let h = Vector3::from(size) * 0.5;
    let corners: [Point3<f64>; 8] = std::array::from_fn(|i| {
        pose * Point3::new(
            if i & 1 == 0 { -h.x } else { h.x },
            if i & 2 == 0 { -h.y } else { h.y },
            if i & 4 == 0 { -h.z } else { h.z },
        )
    });
    // Corner index bits: x = 1, y = 2, z = 4. Faces wound counter-clockwise seen from outside.
    const FACES: [[usize; 4]; 6] = [
        [0, 2, 3, 1], // −z
        [4, 5, 7, 6], // +z
        [0, 1, 5, 4], // −y
        [2, 6, 7, 3], // +y
        [0, 4, 6, 2], // −x
        [1, 3, 7, 5], // +x
    ];
    for f in FACES {
        list.triangle(k, [corners[f[0]], corners[f[1]], corners[f[2]]], true, label);
        list.triangle(k, [corners[f[0]], corners[f[2]], corners[f[3]]], true, label);
    }
}

/// `true` when every edge of the mesh is shared by exactly two triangles.
fn is_closed(triangles: &[[u32; 3]]) -> bool {
    let mut edges: Vec<(u32, u32)> = triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    edges.chunk_by(|a, b| a == b).all(|run| run.len() == 2)
}

fn pose_is_finite(pose: &Isometry3<f64>) -> bool {
    let t = pose.translation.vector;
    let q = pose.rotation.coords;
    t.iter().chain(q.iter()).all(|v| v.is_finite())
}

fn check_pose(field: &str, pose: &Isometry3<f64>) -> Result<()> {
    if pose_is_finite(pose) {
        Ok(())
    } else {
        Err(Error::bad_value(field, format!("{pose:?}"), "must be finite"))
    }
}

fn check_shape(i: usize, shape: &Shape) -> Result<()> {
    // Field names are only formatted on error: validation runs every frame.
    let positive = |field: std::fmt::Arguments<'_>, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(Error::bad_value(format!("objects[{i}].shape.{field}"), v, "must be finite and > 0 m"))
        }
    };
    match *shape {
        Shape::Box { size } => {
            for (k, s) in size.iter().enumerate() {
                positive(format_args!("size[{k}]"), *s)?;
            }
            Ok(())
        }
        Shape::Cylinder { radius, height } => {
            positive(format_args!("radius"), radius)?;
            positive(format_args!("height"), height)
        }
        Shape::Sphere { radius } => positive(format_args!("radius"), radius),
    }
}
