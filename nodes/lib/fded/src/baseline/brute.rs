//! Brute force: all robot points × all obstacle pixels.

use crate::error::Result;
use crate::layout::LinkBest;
use crate::pipeline::{Fded, Frame};
use crate::stages::{Objects, argmin_dist2, min_dist2};
use rayon::prelude::*;

/// Exact per-link minimum of eq. 5.15–5.17 over every robot point in the depth image (the
/// point set fDED samples its lattice from) and every obstacle pixel of `frame` (classified at
/// full resolution by [`Fded::classify_full`]: the same robot removal, table and range as the lattice
/// samples). One entry per link; [`LinkBest::NONE`] for links not visible or when there is no
/// obstacle. `lattice` is `u32::MAX` in the result.
///
/// Cost: robot points × obstacle pixels distance evaluations (≈ 10⁹ on a 640×480 scene; the
/// thesis's 1.5 × 10⁹), spread over rayon's global pool. Benchmark only.
pub fn brute_force(fded: &mut Fded, frame: &Frame<'_>) -> Result<Vec<LinkBest>> {
    fded.classify_full(frame)?;
    let k = *fded.classification();
    let buf = fded.buffers();
    let w = buf.width as usize;
    let (mut ox, mut oy, mut od, mut oc, mut opix) = (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (i, &d) in buf.filtered.iter().enumerate() {
        if d > 0.0 {
            let (rx, ry) = (buf.ray_x[i % w], buf.ray_y[i / w]);
            ox.push(rx);
            oy.push(ry);
            od.push(d);
            oc.push(k.gray_cap(d, rx, ry));
            opix.push(i as u32);
        }
    }
    let obj = Objects {
        ray_x: &ox,
        ray_y: &oy,
        depth: &od,
        cap: &oc,
    };
    let links = fded.model().link_count();
    let robot: Vec<u32> = (0..buf.cam_points.len() as u32)
        .filter(|&i| !buf.point_uv[i as usize][0].is_nan())
        .collect();
    let best = robot
        .par_chunks(64)
        .map(|chunk| {
            let mut best = vec![LinkBest::NONE; links];
            for &i in chunk {
                let r = buf.cam_points[i as usize];
                let p = [r[0], r[1], r[2]];
                let l = r[3] as usize;
                let m = min_dist2(&p, obj);
                if m < best[l].dist2
                    && let Some((j, q)) = argmin_dist2(&p, obj)
                {
                    best[l] = LinkBest {
                        dist2: q,
                        robot_point: i,
                        object_pixel: opix[j],
                        lattice: u32::MAX,
                    };
                }
            }
            best
        })
        .reduce(
            || vec![LinkBest::NONE; links],
            |a, b| a.iter().zip(&b).map(|(x, y)| x.min(*y)).collect(),
        );
    Ok(best)
}
