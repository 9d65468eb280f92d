//! The first pass of a large body's simplification, in parts at once.
//!
//! The vertices (in Morton order) are cut into [`CHUNKS`] runs of equal length. Each part
//! is simplified on its own copy of the triangles that touch it, removing only vertices
//! whose neighbours all lie in the part: such a collapse changes only triangles whose
//! corners all lie in the part, so the parts never touch the same triangle, and a triangle
//! with corners in two parts (the seam) is left as it is by both. The parts' triangles and
//! the removed vertices they hold are then put together, and the sequential pass goes on
//! from the seam's vertices. The parts do not depend on the number of threads: the result
//! is the same on any machine.

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

use super::{Limits, Work};

/// How many parts a large body is cut into.
pub const CHUNKS: usize = 4;

/// The bodies' triangles after the parts' pass, the removed vertices each holds, and which
/// vertices lie on the seam (a neighbour in another part).
pub(super) struct FirstPass {
    pub triangles: Vec<[u32; 3]>,
    pub held: Vec<Vec<u32>>,
    pub seam: Vec<bool>,
}

/// One part's result: its triangles (every corner in the part, or seam triangles it is
/// the first part of), with what each holds, in global numbers.
struct PartOut {
    triangles: Vec<[u32; 3]>,
    held: Vec<Vec<u32>>,
}

/// Simplifies the parts of `positions`/`triangles` at once; `None` when cancelled.
pub(super) fn simplify_chunks(
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    limits: &Limits,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<FirstPass> {
    let n = positions.len();
    let part_of = |v: u32| (v as usize * CHUNKS / n.max(1)).min(CHUNKS - 1);
    let mut seam = vec![false; n];
    for t in triangles {
        let parts = t.map(part_of);
        if parts[0] != parts[1] || parts[1] != parts[2] {
            for &v in t {
                seam[v as usize] = true;
            }
        }
    }
    let outs: Option<Vec<PartOut>> = (0..CHUNKS)
        .into_par_iter()
        .map(|part| {
            simplify_part(
                part, positions, triangles, &seam, limits, &part_of, cancelled,
            )
        })
        .collect();
    Some(join(outs?, seam, &part_of))
}

/// Simplifies the vertices of `part` whose neighbours all lie in it.
fn simplify_part(
    part: usize,
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    seam: &[bool],
    limits: &Limits,
    part_of: &(dyn Fn(u32) -> usize + Sync),
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<PartOut> {
    // The triangles touching the part, in local numbers.
    let mut local: HashMap<u32, u32> = HashMap::new();
    let mut global: Vec<u32> = Vec::new();
    let mut tris: Vec<[u32; 3]> = Vec::new();
    for t in triangles {
        if t.iter().any(|&v| part_of(v) == part) {
            tris.push(t.map(|v| {
                *local.entry(v).or_insert_with(|| {
                    global.push(v);
                    global.len() as u32 - 1
                })
            }));
        }
    }
    let pos: Vec<DVec3> = global.iter().map(|&v| positions[v as usize]).collect();
    let locked: Vec<bool> = global
        .iter()
        .map(|&v| part_of(v) != part || seam[v as usize])
        .collect();
    let mut work = Work::new(&pos, &tris, *limits, locked, &|_| true);
    work.run(cancelled)?;
    let mut out = PartOut {
        triangles: Vec::new(),
        held: Vec::new(),
    };
    for (t, tri) in work.tris.iter().enumerate() {
        if !work.tri_alive[t] {
            continue;
        }
        let g = tri.map(|v| global[v as usize]);
        // A seam triangle is in every part it touches, unchanged: the first part keeps it.
        if g.iter().map(|&v| part_of(v)).min() != Some(part) {
            if !work.held[t].is_empty() {
                out.triangles.push(g);
                out.held
                    .push(work.held[t].iter().map(|&w| global[w as usize]).collect());
            }
            continue;
        }
        out.triangles.push(g);
        out.held
            .push(work.held[t].iter().map(|&w| global[w as usize]).collect());
    }
    Some(out)
}

/// Puts the parts' triangles together: each once, holding what every part gave it.
fn join(outs: Vec<PartOut>, seam: Vec<bool>, part_of: &dyn Fn(u32) -> usize) -> FirstPass {
    let mut triangles = Vec::new();
    let mut held: Vec<Vec<u32>> = Vec::new();
    let mut seam_index: HashMap<[u32; 3], usize> = HashMap::new();
    for out in outs {
        for (t, h) in out.triangles.into_iter().zip(out.held) {
            let parts = t.map(part_of);
            let on_seam = parts[0] != parts[1] || parts[1] != parts[2];
            if !on_seam {
                triangles.push(t);
                held.push(h);
                continue;
            }
            match seam_index.get(&t) {
                Some(&i) => held[i].extend(h),
                None => {
                    seam_index.insert(t, triangles.len());
                    triangles.push(t);
                    held.push(h);
                }
            }
        }
    }
    FirstPass {
        triangles,
        held,
        seam,
    }
}
