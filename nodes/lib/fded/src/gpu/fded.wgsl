// fDED on the GPU (thesis Sec. 5.1.2): the stages of the CPU reference (raster.rs, stages.rs),
// one entry point per stage, all sharing one bind group. Every arithmetic expression is written
// in the CPU's order so that, up to fused multiply-adds, the numbers are the same; every
// reduction breaks ties the way the single-threaded CPU loop does (see each entry point), so
// the result does not depend on the order in which the GPU runs its threads.

struct Params {
    width: u32, height: u32, tile: u32, tiles_x: u32,
    tiles_y: u32, links: u32, step_x: u32, step_y: u32,
    fx: f32, fy: f32, cx: f32, cy: f32,
    delta: f32, min_depth: f32, max_depth: f32, near: f32,
    table_on: u32, r20: f32, r21: f32, r22: f32,
    tz: f32, zlim: f32, tri_count: u32, refine_obstacle: u32,
}

const NO_LINK: u32 = 255u;
const NONE: u32 = 0xffffffffu;
const INF_BITS: u32 = 0x7f800000u;
const WG: u32 = 64u;

@group(0) @binding(0) var<uniform> P: Params;
// Robot mesh vertices in the camera frame, w = link index (written by the host each frame).
@group(0) @binding(1) var<storage, read_write> vertices: array<vec4<f32>>;
// Triangles, three vertex indices each.
@group(0) @binding(2) var<storage, read_write> triangles: array<u32>;
// Real depth, m (0 or NaN = no return).
@group(0) @binding(3) var<storage, read_write> depth_in: array<f32>;
// ray_x = (u - cx)/fx for u < width, then ray_y = (v - cy)/fy.
@group(0) @binding(4) var<storage, read_write> rays: array<f32>;
// Z-buffer: [0, n) the bitwise NOT of the nearest depth's bits (0 = empty), [n, 2n) the bitwise
// NOT of the first triangle reaching that depth (atomicMax of NOTs = min of values).
@group(0) @binding(5) var<storage, read_write> zbuf: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read_write> vdepth: array<f32>;
@group(0) @binding(7) var<storage, read_write> labels: array<u32>;
@group(0) @binding(8) var<storage, read_write> filtered: array<f32>;
// Robot lattice slots (tile * links + link): [0, S) NOT of the least squared doubled pixel
// distance to the tile centre, [S, 2S) NOT of the first pixel reaching it.
@group(0) @binding(9) var<storage, read_write> tiles: array<atomic<u32>>;
// Object lattice (unordered): ray_x, ray_y, depth, pixel index (as an exact f32).
@group(0) @binding(10) var<storage, read_write> objects: array<vec4<f32>>;
// [0] object lattice points, [1] robot lattice points.
@group(0) @binding(11) var<storage, read_write> counters: array<atomic<u32>>;
// [0, S): per robot lattice slot (dist2 bits, robot pixel, object pixel, valid);
// [S, S + links * tile^2): per link and tile pixel, the same for the refinement.
@group(0) @binding(12) var<storage, read_write> scratch: array<vec4<u32>>;
// Per link, two entries: (dist2 bits, robot pixel, object pixel, tile), (d_r bits, d_o bits, 0, 0).
@group(0) @binding(13) var<storage, read_write> link_out: array<vec4<u32>>;

var<workgroup> red_d: array<u32, WG>;
var<workgroup> red_a: array<u32, WG>;
var<workgroup> red_b: array<u32, WG>;
var<workgroup> red_c: array<u32, WG>;
var<workgroup> flag: u32;

fn pixels() -> u32 { return P.width * P.height; }
fn slots() -> u32 { return P.tiles_x * P.tiles_y * P.links; }
fn ray_x(u: u32) -> f32 { return rays[u]; }
fn ray_y(v: u32) -> f32 { return rays[P.width + v]; }

// Index of this workgroup in a 2-D dispatch grid laid out by the host (x fastest).
fn group_index(wg: vec3<u32>, nw: vec3<u32>) -> u32 { return wg.y * nw.x + wg.x; }

// Eq. 5.15-5.17, squared (stages::dist2).
fn dist2(r: vec3<f32>, ox: f32, oy: f32, od: f32) -> f32 {
    var d = od;
    if (r.z > od) { d = r.z; }
    let vx = ox * d - r.x;
    let vy = oy * d - r.y;
    let vz = d - r.z;
    return vx * vx + vy * vy + vz * vz;
}

// Lexicographic (d, a, b) < (d2, a2, b2); d are bits of non-negative floats, so they order as
// the floats do.
fn lex_less(d: u32, a: u32, b: u32, d2: u32, a2: u32, b2: u32) -> bool {
    if (d != d2) { return d < d2; }
    if (a != a2) { return a < a2; }
    return b < b2;
}

// Workgroup minimum of (red_d, red_a, red_b), carrying red_c; result in slot 0.
fn reduce(li: u32) {
    for (var s = WG / 2u; s > 0u; s = s >> 1u) {
        workgroupBarrier();
        if (li < s) {
            let o = li + s;
            if (lex_less(red_d[o], red_a[o], red_b[o], red_d[li], red_a[li], red_b[li])) {
                red_d[li] = red_d[o];
                red_a[li] = red_a[o];
                red_b[li] = red_b[o];
                red_c[li] = red_c[o];
            }
        }
    }
    workgroupBarrier();
}

fn put(li: u32, d: u32, a: u32, b: u32, c: u32) {
    red_d[li] = d;
    red_a[li] = a;
    red_b[li] = b;
    red_c[li] = c;
}

// Best object lattice point for robot point r, strided over this thread's share:
// (dist2 bits, object pixel), ties to the lower pixel (the CPU's first in row-major order).
fn scan_objects(r: vec3<f32>, li: u32) -> vec2<u32> {
    let count = atomicLoad(&counters[0]);
    var best_d = INF_BITS;
    var best_p = NONE;
    for (var j = li; j < count; j = j + WG) {
        let o = objects[j];
        let q = bitcast<u32>(dist2(r, o.x, o.y, o.z));
        let p = u32(o.w);
        if (q < best_d || (q == best_d && p < best_p)) {
            best_d = q;
            best_p = p;
        }
    }
    return vec2<u32>(best_d, best_p);
}

fn robot_point(i: u32) -> vec3<f32> {
    let d = vdepth[i];
    return vec3<f32>(ray_x(i % P.width) * d, ray_y(i / P.width) * d, d);
}

// ---- Stage 1: virtual depth (raster.rs) ----

fn edge(a: vec2<f32>, b: vec2<f32>, p: vec2<f32>) -> f32 {
    return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
}

fn project(p: vec4<f32>) -> vec2<f32> {
    let iz = 1.0 / p.z;
    return vec2<f32>(P.fx * p.x * iz + P.cx, P.fy * p.y * iz + P.cy);
}

// Rasterises triangle t; pass 0 lowers the depth, pass 1 marks the first triangle (lowest
// index) that reaches the final depth of a pixel: the CPU z-buffer keeps the first triangle
// of the nearest depth, since a later one must be strictly nearer to replace it.
fn raster(t: u32, stage: u32) {
    if (t >= P.tri_count) { return; }
    let a = vertices[triangles[3u * t]];
    let b = vertices[triangles[3u * t + 1u]];
    let c = vertices[triangles[3u * t + 2u]];
    if (a.z < P.near || b.z < P.near || c.z < P.near) { return; }
    let e1 = b.xyz - a.xyz;
    let e2 = c.xyz - a.xyz;
    let n = vec3<f32>(
        e1.y * e2.z - e1.z * e2.y,
        e1.z * e2.x - e1.x * e2.z,
        e1.x * e2.y - e1.y * e2.x);
    if (n.x * a.x + n.y * a.y + n.z * a.z >= 0.0) { return; }
    let pa = project(a);
    let pb = project(b);
    let pc = project(c);
    let area = edge(pa, pb, pc);
    if (abs(area) < 1e-12) { return; }
    let w = f32(P.width);
    let h = f32(P.height);
    // Clamped in float first: far off-screen vertices must not overflow the integer casts.
    let u0 = i32(clamp(ceil(min(min(pa.x, pb.x), pc.x)), 0.0, w));
    let u1 = i32(clamp(floor(max(max(pa.x, pb.x), pc.x)), -1.0, w - 1.0));
    let v0 = i32(clamp(ceil(min(min(pa.y, pb.y), pc.y)), 0.0, h));
    let v1 = i32(clamp(floor(max(max(pa.y, pb.y), pc.y)), -1.0, h - 1.0));
    let inv_area = 1.0 / area;
    let iza = 1.0 / a.z;
    let izb = 1.0 / b.z;
    let izc = 1.0 / c.z;
    let n_px = pixels();
    for (var v = v0; v <= v1; v = v + 1) {
        let row = u32(v) * P.width;
        let py = f32(v);
        for (var u = u0; u <= u1; u = u + 1) {
            let p = vec2<f32>(f32(u), py);
            let w0 = edge(pb, pc, p) * inv_area;
            let w1 = edge(pc, pa, p) * inv_area;
            let w2 = 1.0 - w0 - w1;
            if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0) { continue; }
            let z = 1.0 / (w0 * iza + w1 * izb + w2 * izc);
            let i = row + u32(u);
            let key = ~bitcast<u32>(z);
            if (stage == 0u) {
                atomicMax(&zbuf[i], key);
            } else if (atomicLoad(&zbuf[i]) == key) {
                atomicMax(&zbuf[n_px + i], ~t);
            }
        }
    }
}

@compute @workgroup_size(64)
fn raster_depth(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nw: vec3<u32>,
                @builtin(local_invocation_index) li: u32) {
    raster(group_index(wg, nw) * WG + li, 0u);
}

@compute @workgroup_size(64)
fn raster_label(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nw: vec3<u32>,
                @builtin(local_invocation_index) li: u32) {
    raster(group_index(wg, nw) * WG + li, 1u);
}

// ---- Stage 1 resolve, stage 2 (filter_rows), stage 3 candidates, stage 4 (object_lattice) ----

// Doubled squared distance of pixel (u, v) to its tile centre, as stages::robot_lattice.
fn tile_d2(u: u32, v: u32) -> u32 {
    let t = P.tile;
    let dx = i32(2u * u) - i32(2u * (u / t) * t + t - 1u);
    let dy = i32(2u * v) - i32(2u * (v / t) * t + t - 1u);
    return u32(dx * dx + dy * dy);
}

fn slot_of(u: u32, v: u32, link: u32) -> u32 {
    return ((v / P.tile) * P.tiles_x + u / P.tile) * P.links + link;
}

@compute @workgroup_size(64)
fn resolve(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nw: vec3<u32>,
           @builtin(local_invocation_index) li: u32) {
    let i = group_index(wg, nw) * WG + li;
    let n = pixels();
    if (i >= n) { return; }
    let u = i % P.width;
    let v = i / P.width;
    let key = atomicLoad(&zbuf[i]);
    var dr = 0.0;
    var lab = NO_LINK;
    if (key != 0u) {
        dr = bitcast<f32>(~key);
        let t = ~atomicLoad(&zbuf[n + i]);
        lab = u32(vertices[triangles[3u * t]].w);
    }
    vdepth[i] = dr;
    labels[i] = lab;

    let d = depth_in[i];
    // NaN and infinities by their bits: WGSL lets compilers assume floats are finite.
    let finite = (bitcast<u32>(d) & INF_BITS) != INF_BITS;
    let ok = finite && d >= P.min_depth && d <= P.max_depth;
    let robot = dr > 0.0 && abs(d - dr) <= P.delta;
    var table = false;
    if (P.table_on != 0u) {
        let row_c = P.r21 * ray_y(v) + P.r22;
        table = d * (P.r20 * ray_x(u) + row_c) + P.tz < P.zlim;
    }
    var f = 0.0;
    if (ok && !robot && !table) { f = d; }
    filtered[i] = f;

    if (lab != NO_LINK) {
        atomicMax(&tiles[slot_of(u, v, lab)], ~tile_d2(u, v));
    }
    if (f > 0.0 && u % P.step_x == 0u && v % P.step_y == 0u) {
        let j = atomicAdd(&counters[0], 1u);
        objects[j] = vec4<f32>(ray_x(u), ray_y(v), f, f32(i));
    }
}

// Stage 3: per slot, the first pixel (row-major) among those closest to the tile centre.
@compute @workgroup_size(64)
fn lattice_pick(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nw: vec3<u32>,
                @builtin(local_invocation_index) li: u32) {
    let i = group_index(wg, nw) * WG + li;
    if (i >= pixels()) { return; }
    let lab = labels[i];
    if (lab == NO_LINK) { return; }
    let u = i % P.width;
    let v = i / P.width;
    let s = slot_of(u, v, lab);
    if (atomicLoad(&tiles[s]) == ~tile_d2(u, v)) {
        atomicMax(&tiles[slots() + s], ~i);
    }
}

// ---- Stage 5 (lattice_minimum) ----

// One workgroup per robot lattice slot: its best object lattice point.
@compute @workgroup_size(64)
fn lattice_min(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nw: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let s = group_index(wg, nw);
    let n_slots = slots();
    var r = vec3<f32>(0.0);
    var rp = NONE;
    if (s < n_slots) {
        let key = atomicLoad(&tiles[n_slots + s]);
        if (key != 0u) {
            rp = ~key;
            r = robot_point(rp);
        }
    }
    var best = vec2<u32>(INF_BITS, NONE);
    if (rp != NONE) {
        best = scan_objects(r, li);
    }
    put(li, best.x, best.y, 0u, 0u);
    reduce(li);
    if (li == 0u && s < n_slots) {
        if (rp != NONE) {
            atomicAdd(&counters[1], 1u);
        }
        if (rp != NONE && red_a[0] != NONE) {
            scratch[s] = vec4<u32>(red_d[0], rp, red_a[0], 1u);
        } else {
            scratch[s] = vec4<u32>(INF_BITS, NONE, NONE, 0u);
        }
    }
}

// One workgroup per link: the best slot of that link, ties to the lower tile (the CPU visits
// the lattice tile by tile) and then the lower object pixel.
@compute @workgroup_size(64)
fn link_reduce(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let l = wg.x;
    let tiles_n = P.tiles_x * P.tiles_y;
    var bd = INF_BITS;
    var bt = NONE;
    var bo = NONE;
    var br = NONE;
    for (var t = li; t < tiles_n; t = t + WG) {
        let e = scratch[t * P.links + l];
        if (e.w == 1u && lex_less(e.x, t, e.z, bd, bt, bo)) {
            bd = e.x;
            bt = t;
            bo = e.z;
            br = e.y;
        }
    }
    put(li, bd, bt, bo, br);
    reduce(li);
    if (li == 0u) {
        link_out[2u * l] = vec4<u32>(red_d[0], red_c[0], red_b[0], red_a[0]);
    }
}

// ---- Stage 6 (refine_tile) ----

// One workgroup per (link, pixel of that link's winning tile): the pixel's best object point.
@compute @workgroup_size(64)
fn refine_tile(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nw: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let g = group_index(wg, nw);
    let tt = P.tile * P.tile;
    let l = g / tt;
    let k = g % tt;
    var rp = NONE;
    var r = vec3<f32>(0.0);
    if (l < P.links) {
        let lb = link_out[2u * l];
        if (lb.y != NONE) {
            let tx = lb.w % P.tiles_x;
            let ty = lb.w / P.tiles_x;
            let u = tx * P.tile + k % P.tile;
            let v = ty * P.tile + k / P.tile;
            if (u < P.width && v < P.height) {
                let i = v * P.width + u;
                if (labels[i] == l) {
                    rp = i;
                    r = robot_point(i);
                }
            }
        }
    }
    var best = vec2<u32>(INF_BITS, NONE);
    if (rp != NONE) {
        best = scan_objects(r, li);
    }
    put(li, best.x, best.y, 0u, 0u);
    reduce(li);
    if (li == 0u && l < P.links) {
        let idx = slots() + l * tt + k;
        if (rp != NONE && red_a[0] != NONE) {
            scratch[idx] = vec4<u32>(red_d[0], rp, red_a[0], 1u);
        } else {
            scratch[idx] = vec4<u32>(INF_BITS, NONE, NONE, 0u);
        }
    }
}

// One workgroup per link: merges the refinement into the lattice result (the lattice result
// wins ties, as the CPU replaces only on strictly smaller; then the first pixel in row-major
// order), then the optional obstacle-side refinement (stages::refine_obstacle).
@compute @workgroup_size(64)
fn refine_link(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let l = wg.x;
    let tt = P.tile * P.tile;
    let start = link_out[2u * l];
    // (dist2, priority, object pixel) carrying the robot pixel; priority 0 = the current best.
    var bd = start.x;
    var ba = 0u;
    var bb = start.z;
    var bc = start.y;
    for (var k = li; k < tt; k = k + WG) {
        let e = scratch[slots() + l * tt + k];
        if (e.w == 1u && lex_less(e.x, 1u + e.y, e.z, bd, ba, bb)) {
            bd = e.x;
            ba = 1u + e.y;
            bb = e.z;
            bc = e.y;
        }
    }
    put(li, bd, ba, bb, bc);
    reduce(li);
    if (li == 0u) {
        flag = select(0u, 1u, red_c[0] != NONE && P.refine_obstacle != 0u);
    }
    let refine = workgroupUniformLoad(&flag);
    if (refine != 0u) {
        // Every obstacle pixel within ±(S - 1) of the object pixel, against the robot point.
        let d0 = red_d[0];
        let op0 = red_b[0];
        let rp = red_c[0];
        let r = robot_point(rp);
        let ou = op0 % P.width;
        let ov = op0 / P.width;
        let sx = P.step_x - 1u;
        let sy = P.step_y - 1u;
        let u_lo = select(0u, ou - sx, ou >= sx);
        let v_lo = select(0u, ov - sy, ov >= sy);
        let u_hi = min(ou + sx + 1u, P.width);
        let v_hi = min(ov + sy + 1u, P.height);
        let cols = u_hi - u_lo;
        let count = cols * (v_hi - v_lo);
        workgroupBarrier();
        var wd = d0;
        var wa = 0u;
        for (var k = li; k < count; k = k + WG) {
            let u = u_lo + k % cols;
            let v = v_lo + k / cols;
            let i = v * P.width + u;
            let od = filtered[i];
            if (od > 0.0) {
                let q = bitcast<u32>(dist2(r, ray_x(u), ray_y(v), od));
                if (lex_less(q, 1u + i, 0u, wd, wa, 0u)) {
                    wd = q;
                    wa = 1u + i;
                }
            }
        }
        put(li, wd, wa, 0u, 0u);
        reduce(li);
        var d1 = d0;
        var op = op0;
        if (red_a[0] != 0u) {
            d1 = red_d[0];
            op = red_a[0] - 1u;
        }
        // Everyone has read slot 0 before it is overwritten.
        workgroupBarrier();
        // Every robot pixel of the tile against that one object pixel.
        let tile = start.w;
        let tx = tile % P.tiles_x;
        let ty = tile / P.tiles_x;
        let ox = ray_x(op % P.width);
        let oy = ray_y(op / P.width);
        let od = filtered[op];
        var td = d1;
        var ta = 0u;
        var tc = rp;
        for (var k = li; k < tt; k = k + WG) {
            let u = tx * P.tile + k % P.tile;
            let v = ty * P.tile + k / P.tile;
            if (u < P.width && v < P.height) {
                let i = v * P.width + u;
                if (labels[i] == l) {
                    let q = bitcast<u32>(dist2(robot_point(i), ox, oy, od));
                    if (lex_less(q, 1u + i, 0u, td, ta, 0u)) {
                        td = q;
                        ta = 1u + i;
                        tc = i;
                    }
                }
            }
        }
        put(li, td, ta, op, tc);
        reduce(li);
    }
    if (li == 0u) {
        let rp = red_c[0];
        let op = red_b[0];
        if (rp != NONE && op != NONE) {
            link_out[2u * l] = vec4<u32>(red_d[0], rp, op, start.w);
            link_out[2u * l + 1u] = vec4<u32>(bitcast<u32>(vdepth[rp]), bitcast<u32>(filtered[op]), 0u, 0u);
        } else {
            link_out[2u * l] = vec4<u32>(INF_BITS, NONE, NONE, NONE);
            link_out[2u * l + 1u] = vec4<u32>(0u, 0u, 0u, 0u);
        }
    }
}
