//! Flat buffers shared by the pipeline's stages (and by the GPU path, which consumes the same
//! host-side lattices).
//!
//! Every buffer is a `Vec` of plain `f32`/`u32`/`u8` values or `[f32; 4]` points — all
//! `bytemuck::Pod` — sized in [`Buffers::new`] for the image size, the robot point set and the
//! parameters, so that a frame never allocates. Pixel index `i = v · width + u` (row-major, `u`
//! the column, `v` the row, both from the top-left corner). Points are in the **camera optical
//! frame** (x right, y down, z forward; m) until the pipeline's last step moves the per-link
//! results to the robot base frame.
//!
//! Work per frame is proportional to the robot points and the lattice samples, never to the
//! image's pixels (thesis Sec. 5.1.2: only lattice points enter the distance computation):
//! 1. [`cam_points`](Buffers::cam_points): the robot point set (mesh vertices, densified) in
//!    the camera frame with its link, [`point_uv`](Buffers::point_uv) its projection (eq. 5.14).
//! 2. [`lattice_robot`](Buffers::lattice_robot): robot removal evaluated at the object lattice
//!    samples only (the link triangles rasterised at those samples, |d − d_r| ≤ δ);
//! 3. robot lattice: the points' (tile, link) slots ([`point_slot`](Buffers::point_slot)),
//!    and per slot the point closest to the tile centre ([`robot_lattice`](Buffers::robot_lattice));
//! 4. object lattice (structure of arrays so the distance loop vectorises): every S_x-th
//!    column of every S_y-th row that holds an obstacle;
//! 5. [`link_best`](Buffers::link_best): per link, the closest (robot, object) pair under eq.
//!    5.15–5.17; 6. refinement over the winning slot's points (listed in
//!    [`slot_points`](Buffers::slot_points)) and the obstacle window;
//! 7. normals from a window of pixels classified on demand ([`window`](Buffers::window)).

use bytemuck::{Pod, Zeroable};

use crate::raster::{DepthBlocks, RobotMeshes, RobotView};

/// Label of a pixel that no robot link covers (full-resolution virtual depth, tests and
/// benchmark only).
pub const NO_LINK: u8 = u8::MAX;

/// A robot point: `[x, y, z, link]` — camera-frame position (m; z = d_r) and the link index as
/// an exact small `f32`.
pub type RobotPoint = [f32; 4];

/// Best pair found for one link: squared distance (m²), robot point and object pixel, and the
/// robot lattice entry whose slot holds the robot point. `dist2 = f32::INFINITY` and indices
/// `u32::MAX` when none.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct LinkBest {
    /// Squared depth-space distance (eq. 5.15 squared), m².
    pub dist2: f32,
    /// Index of the robot point in the robot point set ([`Buffers::cam_points`]).
    pub robot_point: u32,
    /// Pixel index of the object point.
    pub object_pixel: u32,
    /// Index of the robot lattice entry ([`Buffers::robot_lattice`]) of the robot point's slot.
    pub lattice: u32,
}

impl LinkBest {
    /// No pair yet.
    pub const NONE: LinkBest = LinkBest {
        dist2: f32::INFINITY,
        robot_point: u32::MAX,
        object_pixel: u32::MAX,
        lattice: u32::MAX,
    };

    /// `true` once a pair has been found.
    pub fn is_some(&self) -> bool {
        self.robot_point != u32::MAX
    }

    /// The better (smaller distance) of two; ties keep `self`.
    #[inline]
    pub fn min(self, other: LinkBest) -> LinkBest {
        if other.dist2 < self.dist2 { other } else { self }
    }
}

/// Integer bounding box of pixels, inclusive; empty when `u0 > u1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelBox {
    /// First column.
    pub u0: u32,
    /// First row.
    pub v0: u32,
    /// Last column.
    pub u1: u32,
    /// Last row.
    pub v1: u32,
}

impl PixelBox {
    /// The empty box.
    pub const EMPTY: PixelBox = PixelBox {
        u0: u32::MAX,
        v0: u32::MAX,
        u1: 0,
        v1: 0,
    };

    /// `true` when it holds no pixel.
    pub fn is_empty(&self) -> bool {
        self.u0 > self.u1 || self.v0 > self.v1
    }
}

/// All per-frame working memory, sized once. Public for inspection, tests and the GPU path;
/// the pipeline owns and rewrites it every frame.
#[derive(Debug, Clone)]
pub struct Buffers {
    /// Image width, px.
    pub width: u32,
    /// Image height, px.
    pub height: u32,
    /// `(u − c_x) / f_x` per column: a pixel's camera ray x per metre of depth.
    pub ray_x: Vec<f32>,
    /// `(v − c_y) / f_y` per row.
    pub ray_y: Vec<f32>,
    /// The robot's mesh as robot removal sees it this frame.
    pub robot: RobotFrame,
    /// The robot point set in the camera frame, `[x, y, z, link]`, this frame.
    pub cam_points: Vec<RobotPoint>,
    /// Projection `[u, v]` of each robot point, px (NaN when outside the image or behind the
    /// near plane: such points are not in the depth space).
    pub point_uv: Vec<[f32; 2]>,
    /// Per image column: the slot offset of its tile column (`⌊u / T_s⌋ · links`).
    pub col_slot: Vec<u32>,
    /// Per image column: the u of its tile's centre, px.
    pub col_centre: Vec<f32>,
    /// Per image row: the slot offset of its tile row (`⌊v / T_s⌋ · tiles per row · links`).
    pub row_slot: Vec<u32>,
    /// Per image row: the v of its tile's centre, px.
    pub row_centre: Vec<f32>,
    /// Per (tile, link) slot: number of robot points this frame (valid for the active slots).
    pub slot_count: Vec<u32>,
    /// Per slot: (squared pixel distance to the tile centre, index) of its best point this
    /// frame (valid for the active slots; a write cursor in [`group_slots`](crate::stages::group_slots)).
    pub slot_best: Vec<(f32, u32)>,
    /// Per slot: its robot lattice entry (set by [`group_slots`](crate::stages::group_slots)).
    pub slot_entry: Vec<u32>,
    /// Slots holding points this frame, ascending.
    pub active_slots: Vec<u32>,
    /// Slot of each robot point (`u32::MAX` when not in the image).
    pub point_slot: Vec<u32>,
    /// Robot point indices of the listed slots (stage 6 lists the winning ones), each slot's
    /// ascending; where a slot's run starts is in its [`robot_lattice_info`](Self::robot_lattice_info).
    pub slot_points: Vec<u32>,
    /// Camera-frame x of each point of [`slot_points`](Self::slot_points), m.
    pub slot_x: Vec<f32>,
    /// Camera-frame y, m.
    pub slot_y: Vec<f32>,
    /// Camera-frame z (= d_r), m.
    pub slot_z: Vec<f32>,
    /// Per robot lattice entry: the camera-frame bounding box of its slot's points,
    /// `[x_min, x_max, y_min, y_max, z_min, z_max]` (m), once listed.
    pub slot_bounds: Vec<[f32; 6]>,
    /// Robot lattice points (stage 3): per slot the point closest to the tile centre.
    pub robot_lattice: Vec<RobotPoint>,
    /// Per robot lattice point: `[point index, slot, first, count]` — its robot point, its slot,
    /// where the slot's points start in [`slot_points`](Self::slot_points) (`u32::MAX` until
    /// listed) and how many it has.
    pub robot_lattice_info: Vec<[u32; 4]>,
    /// Object lattice grid size: samples per row.
    pub lattice_nx: u32,
    /// Object lattice grid size: rows.
    pub lattice_ny: u32,
    /// Per object lattice sample: its candidate depth (m; 0 where no return, out of range or
    /// the table), `j · lattice_nx + i`.
    pub lattice_depth: Vec<f32>,
    /// Per object lattice sample: 1 where robot removal took it (|d − d_r| ≤ δ).
    pub lattice_robot: Vec<u8>,
    /// Depth ranges per block of the grid robot removal is running on.
    pub depth_blocks: DepthBlocks,
    /// A window of classified pixels (obstacle depth, or 0), row-major, for the obstacle-side
    /// refinement and the normal fit: only the pixels that can change their result are
    /// candidates (see [`classify_window`](crate::stages::classify_window)).
    pub window: Vec<f32>,
    /// Robot removal flags of the window's pixels.
    pub window_robot: Vec<u8>,
    /// Object lattice: camera ray x of each point, `(u − c_x)/f_x`.
    pub obj_ray_x: Vec<f32>,
    /// Object lattice: camera ray y, `(v − c_y)/f_y`.
    pub obj_ray_y: Vec<f32>,
    /// Object lattice: measured depth d_o, m.
    pub obj_depth: Vec<f32>,
    /// Object lattice: the largest depth its gray area may take (the table bounds it), m.
    pub obj_cap: Vec<f32>,
    /// Object lattice: pixel index.
    pub obj_pixel: Vec<u32>,
    /// Per link: the best pair after stages 5 and 6.
    pub link_best: Vec<LinkBest>,
    /// Per worker thread: per-link partial minima (merged into `link_best`).
    pub partial_best: Vec<Vec<LinkBest>>,
    /// Full-resolution virtual depth d_r (m, 0 = no robot), written by
    /// [`Fded::prepare`](crate::Fded::prepare) only (baselines, tests), not per frame.
    pub virtual_depth: Vec<f32>,
    /// Link index per pixel of the full-resolution virtual depth ([`NO_LINK`] where none).
    pub labels: Vec<u8>,
    /// Bounding box of the robot's pixels in the full-resolution virtual depth.
    pub robot_box: PixelBox,
    /// Full-resolution filtered depth (obstacle depth or 0), written by
    /// [`Fded::classify_full`](crate::Fded::classify_full) only (baselines, tests).
    pub filtered: Vec<f32>,
    /// Full-resolution robot removal flags, with [`filtered`](Self::filtered).
    pub robot_flags: Vec<u8>,
}

/// The robot's mesh in the camera frame this frame: what robot removal reads
/// ([`RobotFrame::view`]).
#[derive(Debug, Clone)]
pub struct RobotFrame {
    /// Robot mesh vertices in the camera frame, `[x, y, z, link]`, this frame (triangle corners
    /// for robot removal).
    pub cam_vertices: Vec<RobotPoint>,
    /// Projected mesh vertices `[u, v]`, px (NaN behind the near plane).
    pub vertex_uv: Vec<[f32; 2]>,
    /// Per triangle chunk ([`TriChunk`](crate::raster::TriChunk)): the pixel box
    /// `[u0, v0, u1, v1]` of its vertices grown by the removal margin; empty (`u0 > u1`) when
    /// the chunk is behind the camera or turns every face away from it.
    pub chunk_box: Vec<[f32; 4]>,
    /// Per triangle chunk: camera-frame depth range `[min, max]` of its vertices, m.
    pub chunk_z: Vec<[f32; 2]>,
    /// Per triangle chunk: its bounding sphere in the camera frame, `[x, y, z, radius]`, m.
    pub chunk_sphere: Vec<[f32; 4]>,
    /// The chunks not turned away from the camera this frame, ascending.
    pub visible_chunks: Vec<u32>,
}

impl RobotFrame {
    /// The robot as [`mark_robot`](crate::raster::mark_robot) sees it, with its `meshes`.
    pub fn view<'a>(&'a self, meshes: &'a RobotMeshes) -> RobotView<'a> {
        RobotView {
            meshes,
            cam_vertices: &self.cam_vertices,
            vertex_uv: &self.vertex_uv,
            chunk_box: &self.chunk_box,
            chunk_z: &self.chunk_z,
            chunk_sphere: &self.chunk_sphere,
            visible: &self.visible_chunks,
        }
    }
}

impl Buffers {
    /// Buffers for a `width × height` image, `links` robot links, `vertices` mesh vertices,
    /// `chunks` triangle chunks, `points` robot points and `threads` workers, for tile size
    /// `tile`, object steps `step` and a window of up to `window` pixels.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        width: u32,
        height: u32,
        links: usize,
        vertices: usize,
        chunks: usize,
        points: usize,
        threads: usize,
        tile: u32,
        step: (u32, u32),
        window: usize,
    ) -> Self {
        let n = width as usize * height as usize;
        let t = tile.max(1);
        let tiles = width.div_ceil(t) as usize * height.div_ceil(t) as usize;
        let slots = tiles * links;
        let nx = width.div_ceil(step.0.max(1));
        let ny = height.div_ceil(step.1.max(1));
        let samples = nx as usize * ny as usize;
        Self {
            width,
            height,
            ray_x: vec![0.0; width as usize],
            ray_y: vec![0.0; height as usize],
            robot: RobotFrame {
                cam_vertices: vec![[0.0; 4]; vertices],
                vertex_uv: vec![[0.0; 2]; vertices],
                chunk_box: vec![[0.0; 4]; chunks],
                chunk_z: vec![[0.0; 2]; chunks],
                chunk_sphere: vec![[0.0; 4]; chunks],
                visible_chunks: Vec::with_capacity(chunks),
            },
            cam_points: vec![[0.0; 4]; points],
            point_uv: vec![[0.0; 2]; points],
            col_slot: (0..width).map(|u| (u / t) * links as u32).collect(),
            col_centre: (0..width).map(|u| ((u / t) * t) as f32 + (t as f32 - 1.0) * 0.5).collect(),
            row_slot: (0..height).map(|v| (v / t) * width.div_ceil(t) * links as u32).collect(),
            row_centre: (0..height).map(|v| ((v / t) * t) as f32 + (t as f32 - 1.0) * 0.5).collect(),
            slot_count: vec![0; slots],
            slot_best: vec![(0.0, 0); slots],
            slot_entry: vec![0; slots],
            active_slots: Vec::with_capacity(points.min(slots)),
            point_slot: vec![u32::MAX; points],
            slot_points: Vec::with_capacity(points),
            slot_x: Vec::with_capacity(points),
            slot_y: Vec::with_capacity(points),
            slot_z: Vec::with_capacity(points),
            slot_bounds: Vec::with_capacity(points.min(slots)),
            robot_lattice: Vec::with_capacity(points.min(slots)),
            robot_lattice_info: Vec::with_capacity(points.min(slots)),
            lattice_nx: nx,
            lattice_ny: ny,
            lattice_depth: vec![0.0; samples],
            lattice_robot: vec![0; samples],
            depth_blocks: DepthBlocks::new(width, height),
            window: vec![0.0; window],
            window_robot: vec![0; window],
            obj_ray_x: Vec::with_capacity(samples),
            obj_ray_y: Vec::with_capacity(samples),
            obj_depth: Vec::with_capacity(samples),
            obj_cap: Vec::with_capacity(samples),
            obj_pixel: Vec::with_capacity(samples),
            link_best: vec![LinkBest::NONE; links],
            partial_best: vec![vec![LinkBest::NONE; links]; threads.max(1)],
            virtual_depth: vec![0.0; n],
            labels: vec![NO_LINK; n],
            robot_box: PixelBox::EMPTY,
            filtered: vec![0.0; n],
            robot_flags: vec![0; n],
        }
    }

    /// Number of object lattice points this frame.
    pub fn object_lattice_len(&self) -> usize {
        self.obj_depth.len()
    }
}
