// fDED on the GPU (thesis Sec. 5.1.2): the distance stages of the CPU reference — stage 5
// (stages::lattice_minimum) and stage 6 (stages::refine_slot) — on the lattices the host built
// with the CPU's own stages 1-4. Every arithmetic expression is written in the CPU's order so
// that, up to fused multiply-adds, the numbers are the same; every reduction breaks ties the
// way the single-threaded CPU loop does, so the result does not depend on the order in which
// the GPU runs its threads.

struct Params {
    n_obj: u32, n_lattice: u32, links: u32, max_count: u32,
}

const NONE: u32 = 0xffffffffu;
const INF_BITS: u32 = 0x7f800000u;
const WG: u32 = 64u;

@group(0) @binding(0) var<uniform> P: Params;
// Object lattice: ray_x, ray_y, depth d_o, gray-area cap (finite).
@group(0) @binding(1) var<storage, read> objects: array<vec4<f32>>;
// Robot lattice points: camera-frame x, y, z and the link index (an exact small float).
@group(0) @binding(2) var<storage, read> lattice: array<vec4<f32>>;
// Per robot lattice point: its robot point, its slot, the slot's first entry in slot_points
// and the slot's point count.
@group(0) @binding(3) var<storage, read> lattice_info: array<vec4<u32>>;
// Every robot point, camera frame, w = link.
@group(0) @binding(4) var<storage, read> points: array<vec4<f32>>;
// Robot point indices grouped by slot.
@group(0) @binding(5) var<storage, read> slot_points: array<u32>;
// Per robot lattice point: (dist2 bits, object index, 0, valid).
@group(0) @binding(6) var<storage, read_write> scratch_lattice: array<vec4<u32>>;
// Per (link, point of that link's winning slot): (dist2 bits, object index, robot point, valid).
@group(0) @binding(7) var<storage, read_write> scratch_refine: array<vec4<u32>>;
// Per link: (dist2 bits, robot point, object index, lattice entry); NONE where no pair.
@group(0) @binding(8) var<storage, read_write> link_out: array<vec4<u32>>;

var<workgroup> red_d: array<u32, WG>;
var<workgroup> red_a: array<u32, WG>;
var<workgroup> red_b: array<u32, WG>;
var<workgroup> red_c: array<u32, WG>;

// Index of this workgroup in a 2-D dispatch grid laid out by the host (x fastest).
fn group_index(wg: vec3<u32>, nw: vec3<u32>) -> u32 { return wg.y * nw.x + wg.x; }

// Eq. 5.15-5.17 with the table cap, squared (stages::dist2).
fn dist2(r: vec3<f32>, o: vec4<f32>) -> f32 {
    var d = o.z;
    if (r.z > o.z) { d = r.z; }
    if (d > o.w) { d = o.w; }
    let vx = o.x * d - r.x;
    let vy = o.y * d - r.y;
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

// Best object for robot point r over the whole object lattice (this thread's stride, then the
// workgroup): (dist2 bits, object index), ties to the lower index (the CPU's argmin).
fn best_object(r: vec3<f32>, li: u32, live: bool) {
    var bd = INF_BITS;
    var bj = NONE;
    if (live) {
        for (var j = li; j < P.n_obj; j = j + WG) {
            let q = bitcast<u32>(dist2(r, objects[j]));
            if (q < bd || (q == bd && j < bj)) {
                bd = q;
                bj = j;
            }
        }
    }
    put(li, bd, bj, 0u, 0u);
    reduce(li);
}

// Stage 5, part 1: one workgroup per robot lattice point, its closest object.
@compute @workgroup_size(64)
fn lattice_min(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nw: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let k = group_index(wg, nw);
    let live = k < P.n_lattice;
    var r = vec3<f32>(0.0);
    if (live) { r = lattice[k].xyz; }
    best_object(r, li, live);
    if (li == 0u && live) {
        scratch_lattice[k] = vec4<u32>(red_d[0], red_a[0], 0u, select(0u, 1u, red_a[0] != NONE));
    }
}

// Stage 5, part 2: one workgroup per link, its best lattice point; ties to the earlier lattice
// point (the CPU replaces only on strictly smaller), then the lower object index.
@compute @workgroup_size(64)
fn link_reduce(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let l = wg.x;
    var bd = INF_BITS;
    var bk = NONE;
    var bj = NONE;
    for (var k = li; k < P.n_lattice; k = k + WG) {
        let e = scratch_lattice[k];
        if (e.w == 1u && u32(lattice[k].w) == l && lex_less(e.x, k, e.y, bd, bk, bj)) {
            bd = e.x;
            bk = k;
            bj = e.y;
        }
    }
    put(li, bd, bk, bj, 0u);
    reduce(li);
    if (li == 0u && l < P.links) {
        let k = red_a[0];
        if (k != NONE) {
            link_out[l] = vec4<u32>(red_d[0], lattice_info[k].x, red_b[0], k);
        } else {
            link_out[l] = vec4<u32>(INF_BITS, NONE, NONE, NONE);
        }
    }
}

// Stage 6, part 1: one workgroup per (link, point m of the link's winning slot): the point's
// closest object.
@compute @workgroup_size(64)
fn refine_points(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nw: vec3<u32>,
                 @builtin(local_invocation_index) li: u32) {
    let g = group_index(wg, nw);
    let l = g / max(P.max_count, 1u);
    let m = g % max(P.max_count, 1u);
    var live = false;
    var pi = NONE;
    var r = vec3<f32>(0.0);
    if (l < P.links) {
        let k = link_out[l].w;
        if (k != NONE) {
            let info = lattice_info[k];
            if (m < info.w) {
                pi = slot_points[info.z + m];
                r = points[pi].xyz;
                live = true;
            }
        }
    }
    best_object(r, li, live);
    if (li == 0u && l < P.links) {
        scratch_refine[g] = vec4<u32>(red_d[0], red_a[0], pi, select(0u, 1u, live && red_a[0] != NONE));
    }
}

// Stage 6, part 2: one workgroup per link, merging the slot's points into the lattice result:
// the lattice result wins ties (the CPU replaces only on strictly smaller), then the earlier
// point of the slot, then the lower object index.
@compute @workgroup_size(64)
fn refine_link(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let l = wg.x;
    let start = link_out[l];
    // (dist2, priority, object) carrying the robot point; priority 0 = the lattice result.
    var bd = start.x;
    var ba = 0u;
    var bb = start.z;
    var bc = start.y;
    if (start.w != NONE) {
        let mc = max(P.max_count, 1u);
        for (var m = li; m < P.max_count; m = m + WG) {
            let e = scratch_refine[l * mc + m];
            if (e.w == 1u && lex_less(e.x, 1u + m, e.y, bd, ba, bb)) {
                bd = e.x;
                ba = 1u + m;
                bb = e.y;
                bc = e.z;
            }
        }
    }
    put(li, bd, ba, bb, bc);
    reduce(li);
    if (li == 0u && start.w != NONE) {
        link_out[l] = vec4<u32>(red_d[0], red_c[0], red_b[0], start.w);
    }
}
