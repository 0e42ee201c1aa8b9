//! Flat buffers shared by the pipeline's stages (and by the GPU path, which mirrors them).
//!
//! Every buffer is a `Vec` of plain `f32`/`u32`/`u8` values or `[f32; 4]` points — all
//! `bytemuck::Pod` — sized once in [`Buffers::new`] for the worst case of the image size and
//! parameters, so that a frame never allocates. Pixel index `i = v · width + u` (row-major,
//! `u` the column, `v` the row, both from the top-left corner). Points are in the **camera
//! optical frame** (x right, y down, z forward; m) until the pipeline's last step moves the
//! per-link results to the robot base frame.
//!
//! Stage order and what each writes:
//! 1. [`virtual_depth`](Buffers::virtual_depth), [`labels`](Buffers::labels): the robot's
//!    triangles rasterised with a z-buffer (eq. 5.14 per vertex); 0 m / [`NO_LINK`] where no
//!    robot.
//! 2. [`filtered`](Buffers::filtered): the real depth with the robot (|d − d_r| ≤ δ), the
//!    table, invalid (0, NaN, out of range) and background pixels set to 0.
//! 3. [`robot_lattice`](Buffers::robot_lattice) + [`robot_lattice_pixel`](Buffers::robot_lattice_pixel):
//!    per T_s × T_s tile and link, the robot pixel closest to the tile centre.
//! 4. object lattice ([`obj_ray_x`](Buffers::obj_ray_x), [`obj_ray_y`](Buffers::obj_ray_y),
//!    [`obj_depth`](Buffers::obj_depth), [`obj_pixel`](Buffers::obj_pixel); structure of
//!    arrays so the distance loop vectorises): every S_x-th column of every S_y-th row of
//!    `filtered` that holds an obstacle.
//! 5. [`link_best`](Buffers::link_best): per link, the closest (robot lattice, object lattice)
//!    pair under eq. 5.15–5.17;
//! 6. refinement: the same minimum over every robot pixel of the winning tile of that link
//!    (and, with `refine_obstacle`, over the real depth around the winning object point);
//! 7. normals by a weighted plane fit around the closest object pixel.

use bytemuck::{Pod, Zeroable};

/// Label of a pixel that no robot link covers.
pub const NO_LINK: u8 = u8::MAX;

/// A robot lattice point: `[x, y, z, link]` — camera-frame position (m; z = d_r, the virtual
/// depth) and the link index as an exact small `f32`.
pub type RobotPoint = [f32; 4];

/// Best pair found for one link: squared distance (m²), robot and object pixel indices, and
/// the tile of the robot point. `dist2 = f32::INFINITY` and indices `u32::MAX` when none.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct LinkBest {
    /// Squared depth-space distance (eq. 5.15 squared), m².
    pub dist2: f32,
    /// Pixel index of the robot point (in the virtual depth).
    pub robot_pixel: u32,
    /// Pixel index of the object point (in the filtered depth).
    pub object_pixel: u32,
    /// Tile index (`ty · tiles_x + tx`) of the robot point.
    pub tile: u32,
}

impl LinkBest {
    /// No pair yet.
    pub const NONE: LinkBest = LinkBest {
        dist2: f32::INFINITY,
        robot_pixel: u32::MAX,
        object_pixel: u32::MAX,
        tile: u32::MAX,
    };

    /// `true` once a pair has been found.
    pub fn is_some(&self) -> bool {
        self.robot_pixel != u32::MAX
    }

    /// The better (smaller distance) of two; ties keep `self`.
    #[inline]
    pub fn min(self, other: LinkBest) -> LinkBest {
        if other.dist2 < self.dist2 { other } else { self }
    }
}

/// Integer bounding box of the robot's pixels, inclusive; empty when `u0 > u1`.
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
    /// Robot mesh vertices in the camera frame, `[x, y, z, link]`, this frame.
    pub cam_vertices: Vec<RobotPoint>,
    /// Virtual depth d_r per pixel (z in the camera frame, m; 0 = no robot).
    pub virtual_depth: Vec<f32>,
    /// Link index per pixel of the virtual depth ([`NO_LINK`] where none).
    pub labels: Vec<u8>,
    /// Bounding box of the robot's pixels this frame.
    pub robot_box: PixelBox,
    /// Real depth with everything that is not an obstacle set to 0, m.
    pub filtered: Vec<f32>,
    /// Per tile and link: `(squared pixel distance to the tile centre · 4, pixel)`;
    /// `u32::MAX` where the tile has no pixel of that link. Reset after each use.
    pub tile_best: Vec<[u32; 2]>,
    /// Robot lattice points (stage 3).
    pub robot_lattice: Vec<RobotPoint>,
    /// Pixel index of each robot lattice point.
    pub robot_lattice_pixel: Vec<u32>,
    /// Object lattice: camera ray x of each point, `(u − c_x)/f_x`.
    pub obj_ray_x: Vec<f32>,
    /// Object lattice: camera ray y, `(v − c_y)/f_y`.
    pub obj_ray_y: Vec<f32>,
    /// Object lattice: measured depth d_o, m.
    pub obj_depth: Vec<f32>,
    /// Object lattice: pixel index.
    pub obj_pixel: Vec<u32>,
    /// Per link: the best pair after stages 5 and 6.
    pub link_best: Vec<LinkBest>,
    /// Per worker thread: per-link partial minima (merged into `link_best`).
    pub partial_best: Vec<Vec<LinkBest>>,
}

impl Buffers {
    /// Buffers for a `width × height` image, `links` robot links, `vertices` mesh vertices and
    /// `threads` workers, for tile sizes ≥ `min_tile` and any object step.
    pub fn new(
        width: u32,
        height: u32,
        links: usize,
        vertices: usize,
        threads: usize,
        min_tile: u32,
    ) -> Self {
        let n = width as usize * height as usize;
        let t = min_tile.max(1);
        let tiles = width.div_ceil(t) as usize * height.div_ceil(t) as usize;
        Self {
            width,
            height,
            ray_x: vec![0.0; width as usize],
            ray_y: vec![0.0; height as usize],
            cam_vertices: vec![[0.0; 4]; vertices],
            virtual_depth: vec![0.0; n],
            labels: vec![NO_LINK; n],
            robot_box: PixelBox::EMPTY,
            filtered: vec![0.0; n],
            tile_best: vec![[u32::MAX; 2]; tiles * links],
            robot_lattice: Vec::with_capacity(tiles * links),
            robot_lattice_pixel: Vec::with_capacity(tiles * links),
            obj_ray_x: Vec::with_capacity(n),
            obj_ray_y: Vec::with_capacity(n),
            obj_depth: Vec::with_capacity(n),
            obj_pixel: Vec::with_capacity(n),
            link_best: vec![LinkBest::NONE; links],
            partial_best: vec![vec![LinkBest::NONE; links]; threads.max(1)],
        }
    }

    /// Number of object lattice points this frame.
    pub fn object_lattice_len(&self) -> usize {
        self.obj_depth.len()
    }
}
