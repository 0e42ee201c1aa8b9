//! Brute force: all robot pixels × all obstacle pixels.

use crate::error::Result;
use crate::layout::{LinkBest, NO_LINK};
use crate::pipeline::{Fded, Frame};
use crate::stages::{Objects, argmin_dist2, min_dist2};
use rayon::prelude::*;

/// Exact per-link minimum of eq. 5.15–5.17 over every robot pixel of the virtual depth and
/// every obstacle pixel of the filtered depth of `frame` (runs `fded`'s stages 1–2 first).
/// One entry per link; [`LinkBest::NONE`] for links not visible or when there is no obstacle.
///
/// Cost: robot pixels × obstacle pixels distance evaluations (≈ 10⁹ on a 640×480 scene),
/// spread over rayon's global pool. Benchmark only.
pub fn brute_force(fded: &mut Fded, frame: &Frame<'_>) -> Result<Vec<LinkBest>> {
    fded.prepare(frame)?;
    let buf = fded.buffers();
    let w = buf.width as usize;
    let (mut ox, mut oy, mut od, mut opix) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (i, &d) in buf.filtered.iter().enumerate() {
        if d > 0.0 {
            ox.push(buf.ray_x[i % w]);
            oy.push(buf.ray_y[i / w]);
            od.push(d);
            opix.push(i as u32);
        }
    }
    let obj = Objects {
        ray_x: &ox,
        ray_y: &oy,
        depth: &od,
    };
    let links = fded.model().link_count();
    let robot: Vec<u32> = (0..buf.labels.len() as u32)
        .filter(|&i| buf.labels[i as usize] != NO_LINK)
        .collect();
    let best = robot
        .par_chunks(256)
        .map(|chunk| {
            let mut best = vec![LinkBest::NONE; links];
            for &i in chunk {
                let i = i as usize;
                let d = buf.virtual_depth[i];
                let p = [buf.ray_x[i % w] * d, buf.ray_y[i / w] * d, d];
                let l = buf.labels[i] as usize;
                let m = min_dist2(&p, obj);
                if m < best[l].dist2
                    && let Some((j, q)) = argmin_dist2(&p, obj)
                {
                    best[l] = LinkBest {
                        dist2: q,
                        robot_pixel: i as u32,
                        object_pixel: opix[j],
                        tile: u32::MAX,
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
