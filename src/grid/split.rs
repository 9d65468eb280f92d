//! Cube splits: every grid cell cut into 5 or 6 tetrahedra, conforming across cells.
//!
//! Invariant: the returned mesh has only positively oriented tetrahedra (orientation decided
//! exactly; zero-volume ones are left out and counted) and symmetric `neighbours`, derived
//! from the cell structure (and checked in tests against pairing equal sorted face triples).

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::{CubeSplit, GridError, GridVolume};
use crate::tet::{NO_NEIGHBOUR, TetMesh};

/// Corner `b` of a cell is point `(i + (b & 1), j + (b >> 1 & 1), k + (b >> 2 & 1))`.
///
/// 6-split (CFK): the paths `0 -> e_a -> e_a + e_b -> 7` over the orderings of the axes.
/// Every cube face is cut along the diagonal through corner 0 or corner 7, which the
/// neighbouring cell cuts the same way.
/// Corner orders are positively oriented in a right-handed cell.
const SIX: [[u8; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 7, 5],
    [0, 2, 7, 3],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 7, 6],
];

/// 5-split of an even cell (`(i + j + k) % 2 == 0`): central tetrahedron on the corners of
/// even bit parity, then the four odd corners cut off. The odd cell is the mirror image.
const FIVE_EVEN: [[u8; 4]; 5] = [
    [0, 3, 6, 5],
    [1, 0, 5, 3],
    [2, 0, 3, 6],
    [4, 0, 6, 5],
    [7, 3, 5, 6],
];
const FIVE_ODD: [[u8; 4]; 5] = [
    [1, 2, 4, 7],
    [0, 1, 2, 4],
    [3, 1, 7, 2],
    [5, 1, 4, 7],
    [6, 2, 7, 4],
];

/// What the split did, for reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct SplitReport {
    pub cells: usize,
    pub tets: usize,
    /// Tetrahedra with negative volume in their cell's corner order (left-handed axes or
    /// folded curvilinear cells), reordered to be positive.
    pub flipped_tets: usize,
    /// Tetrahedra of exactly zero volume (collapsed cells), left out.
    pub degenerate_tets: usize,
    /// Cells with at least one degenerate tetrahedron.
    pub degenerate_cells: usize,
    /// Tetrahedra touching a blanked point, left out.
    pub blanked_tets: usize,
    /// Faces on the mesh boundary.
    pub boundary_faces: usize,
}

/// Splits every cell of `grid` into tetrahedra. See [`tetrahedralize_with_report`].
pub fn tetrahedralize(grid: &GridVolume, split: CubeSplit) -> Result<TetMesh, GridError> {
    tetrahedralize_with_report(grid, split).map(|(mesh, _)| mesh)
}

/// Splits every cell of `grid` into 5 or 6 tetrahedra.
///
/// The mesh's `points` are the grid's (all of them, `vertex_of_input` the identity), so
/// `grid.values` are its per-vertex values. Tetrahedra touching a blanked point or of zero
/// volume are left out; their faces become boundary faces. Fails only when no tetrahedron
/// is left.
pub fn tetrahedralize_with_report(
    grid: &GridVolume,
    split: CubeSplit,
) -> Result<(TetMesh, SplitReport), GridError> {
    let [nx, ny, nz] = grid.dims;
    if nx < 2 || ny < 2 || nz < 2 || grid.points.len() != nx * ny * nz {
        return Err(GridError::shape(
            &grid.source,
            format!(
                "dims {nx}x{ny}x{nz} do not match {} points",
                grid.points.len()
            ),
        ));
    }
    let cells = [nx - 1, ny - 1, nz - 1];
    let cells_per_slab = cells[0] * cells[1];
    let sets = TemplateSets::new(split);

    // Each slab of cells (fixed k) is independent: split them in parallel.
    let slabs: Vec<(Vec<[u32; 4]>, Vec<CellTets>, SplitReport)> = (0..cells[2])
        .into_par_iter()
        .map(|k| {
            let mut tets = Vec::with_capacity(cells_per_slab * split.tets_per_cell());
            let mut kept = Vec::with_capacity(cells_per_slab);
            let mut report = SplitReport::default();
            for j in 0..cells[1] {
                for i in 0..cells[0] {
                    let set = &sets.sets[sets.set_of([i, j, k])];
                    kept.push(split_cell(
                        grid,
                        &set.templates,
                        [i, j, k],
                        &mut tets,
                        &mut report,
                    ));
                }
            }
            (tets, kept, report)
        })
        .collect();

    let mut report = SplitReport {
        cells: cells_per_slab * cells[2],
        ..SplitReport::default()
    };
    let total: usize = slabs.iter().map(|(t, _, _)| t.len()).sum();
    let mut tets = Vec::with_capacity(total);
    let mut cell_tets = Vec::with_capacity(report.cells);
    let mut slab_sizes = Vec::with_capacity(cells[2]);
    for (slab, kept, r) in slabs {
        slab_sizes.push(slab.len());
        tets.extend_from_slice(&slab);
        cell_tets.extend_from_slice(&kept);
        report.flipped_tets += r.flipped_tets;
        report.degenerate_tets += r.degenerate_tets;
        report.degenerate_cells += r.degenerate_cells;
        report.blanked_tets += r.blanked_tets;
    }
    report.tets = tets.len();
    if tets.is_empty() {
        return Err(GridError::shape(
            &grid.source,
            format!(
                "no cell left to contour ({} tetrahedra blanked, {} of zero volume)",
                report.blanked_tets, report.degenerate_tets
            ),
        ));
    }

    let neighbours = structured_adjacency(&sets, cells, &cell_tets, &slab_sizes, tets.len());
    report.boundary_faces = neighbours
        .iter()
        .flatten()
        .filter(|n| **n == NO_NEIGHBOUR)
        .count();
    let mesh = TetMesh::from_parts(
        grid.points.clone(),
        tets,
        neighbours,
        (0..grid.points.len() as u32).collect(),
        0,
    );
    Ok((mesh, report))
}

/// Which templates of a cell became tetrahedra, and which of those were reordered.
#[derive(Debug, Clone, Copy, Default)]
struct CellTets {
    /// Bit `n`: template `n` was kept.
    kept: u8,
    /// Bit `n`: template `n` was stored with corners 2 and 3 swapped.
    flipped: u8,
    /// Index of the cell's first tetrahedron within its slab.
    first_in_slab: u32,
}

impl CellTets {
    /// Index within the slab of template `n`'s tetrahedron, if kept.
    fn tet(&self, n: usize) -> Option<u32> {
        (self.kept >> n & 1 == 1)
            .then(|| self.first_in_slab + (self.kept & ((1u8 << n) - 1)).count_ones())
    }

    /// The stored face index of template face `j` of template `n` (2 and 3 swap when the
    /// corners were swapped).
    fn stored_face(&self, n: usize, j: usize) -> usize {
        if self.flipped >> n & 1 == 1 && j >= 2 {
            5 - j
        } else {
            j
        }
    }
}

fn split_cell(
    grid: &GridVolume,
    templates: &[[u8; 4]],
    [i, j, k]: [usize; 3],
    tets: &mut Vec<[u32; 4]>,
    report: &mut SplitReport,
) -> CellTets {
    let corner = |b: u8| -> u32 {
        let b = b as usize;
        grid.index(i + (b & 1), j + (b >> 1 & 1), k + (b >> 2 & 1)) as u32
    };
    let mut cell = CellTets {
        first_in_slab: tets.len() as u32,
        ..CellTets::default()
    };
    let mut degenerate = false;
    for (n, template) in templates.iter().enumerate() {
        let mut tet = template.map(corner);
        if tet.iter().any(|v| grid.is_blanked(*v as usize)) {
            report.blanked_tets += 1;
            continue;
        }
        let [a, b, c, d] = tet.map(|v| grid.points[v as usize]);
        let volume6 = signed_volume6(a, b, c, d);
        if volume6 == 0.0 {
            report.degenerate_tets += 1;
            degenerate = true;
            continue;
        }
        if volume6 < 0.0 {
            tet.swap(2, 3);
            report.flipped_tets += 1;
            cell.flipped |= 1 << n;
        }
        cell.kept |= 1 << n;
        tets.push(tet);
    }
    if degenerate {
        report.degenerate_cells += 1;
    }
    cell
}

/// Where the face opposite corner `j` of a template tetrahedron leads.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Link {
    /// Face `j` of template `n` of the same cell.
    Inside { n: usize, j: usize },
    /// Face `j` of template `n` of the next cell along `axis`, `+1` or `-1`.
    Across {
        axis: usize,
        up: bool,
        n: usize,
        j: usize,
    },
}

/// The template sets of a split (one for CFK, two alternating ones for the 5-split) and the
/// face links between templates, derived from the corner triples.
struct TemplateSets {
    sets: Vec<TemplateSet>,
}

struct TemplateSet {
    templates: Vec<[u8; 4]>,
    links: Vec<[Link; 4]>,
}

impl TemplateSets {
    fn new(split: CubeSplit) -> TemplateSets {
        let raw: Vec<&[[u8; 4]]> = match split {
            CubeSplit::Six => vec![&SIX],
            CubeSplit::Five => vec![&FIVE_EVEN, &FIVE_ODD],
        };
        let face = |t: &[u8; 4], j: usize| {
            let mut f = [t[(j + 1) % 4], t[(j + 2) % 4], t[(j + 3) % 4]];
            f.sort_unstable();
            f
        };
        let find = |set: &[[u8; 4]], wanted: [u8; 3], skip: Option<(usize, usize)>| {
            (0..set.len())
                .flat_map(|n| (0..4).map(move |j| (n, j)))
                .find(|&(n, j)| Some((n, j)) != skip && face(&set[n], j) == wanted)
                .expect("the cube split templates are conforming")
        };
        let sets = (0..raw.len())
            .map(|s| {
                let set = raw[s];
                // The neighbouring cell uses the other set of the 5-split.
                let other = raw[(s + 1) % raw.len()];
                let links = (0..set.len())
                    .map(|n| {
                        std::array::from_fn(|j| {
                            let f = face(&set[n], j);
                            for axis in 0..3 {
                                for up in [false, true] {
                                    let bit = u8::from(up) << axis;
                                    if f.iter().all(|c| c & (1 << axis) == bit) {
                                        let mut mirrored = f.map(|c| c ^ (1 << axis));
                                        mirrored.sort_unstable();
                                        let (n, j) = find(other, mirrored, None);
                                        return Link::Across { axis, up, n, j };
                                    }
                                }
                            }
                            let (n2, j2) = find(set, f, Some((n, j)));
                            Link::Inside { n: n2, j: j2 }
                        })
                    })
                    .collect();
                TemplateSet {
                    templates: set.to_vec(),
                    links,
                }
            })
            .collect();
        TemplateSets { sets }
    }

    fn set_of(&self, [i, j, k]: [usize; 3]) -> usize {
        (i + j + k) % self.sets.len()
    }
}

/// `neighbours` from the cell structure: template faces inside a cell pair up within it,
/// faces on a cell face pair with the neighbouring cell's; a partner that was left out (or
/// beyond the grid) gives [`NO_NEIGHBOUR`].
fn structured_adjacency(
    sets: &TemplateSets,
    cells: [usize; 3],
    cell_tets: &[CellTets],
    slab_sizes: &[usize],
    total: usize,
) -> Vec<[u32; 4]> {
    let mut slab_start = Vec::with_capacity(slab_sizes.len());
    let mut start = 0u32;
    for size in slab_sizes {
        slab_start.push(start);
        start += *size as u32;
    }
    let cell_index = |c: [usize; 3]| c[0] + cells[0] * (c[1] + cells[1] * c[2]);
    let global = |c: [usize; 3], n: usize, j: usize| -> u32 {
        let cell = &cell_tets[cell_index(c)];
        match cell.tet(n) {
            Some(t) => (slab_start[c[2]] + t) * 4 + cell.stored_face(n, j) as u32,
            None => NO_NEIGHBOUR,
        }
    };
    let mut neighbours = vec![[NO_NEIGHBOUR; 4]; total];
    let mut chunks = Vec::with_capacity(slab_sizes.len());
    let mut rest = neighbours.as_mut_slice();
    for size in slab_sizes {
        let (chunk, tail) = rest.split_at_mut(*size);
        chunks.push(chunk);
        rest = tail;
    }
    chunks.into_par_iter().enumerate().for_each(|(k, chunk)| {
        for j in 0..cells[1] {
            for i in 0..cells[0] {
                let c = [i, j, k];
                let cell = &cell_tets[cell_index(c)];
                let set = &sets.sets[sets.set_of(c)];
                for (n, links) in set.links.iter().enumerate() {
                    let Some(t) = cell.tet(n) else { continue };
                    for (tj, link) in links.iter().enumerate() {
                        let value = match *link {
                            Link::Inside { n: n2, j: j2 } => global(c, n2, j2),
                            Link::Across {
                                axis,
                                up,
                                n: n2,
                                j: j2,
                            } => {
                                let mut c2 = c;
                                if up && c2[axis] + 1 < cells[axis] {
                                    c2[axis] += 1;
                                } else if !up && c2[axis] > 0 {
                                    c2[axis] -= 1;
                                } else {
                                    continue;
                                }
                                global(c2, n2, j2)
                            }
                        };
                        chunk[t as usize][cell.stored_face(n, tj)] = value;
                    }
                }
            }
        }
    });
    neighbours
}

/// Six times the signed volume `(b-a) . ((c-a) x (d-a))`, with an exact sign (Shewchuk's
/// adaptive predicate; `robust::orient3d` is positive for the opposite orientation).
pub(crate) fn signed_volume6(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    let p = |v: DVec3| robust::Coord3D {
        x: v.x,
        y: v.y,
        z: v.z,
    };
    -robust::orient3d(p(a), p(b), p(c), p(d))
}

/// `neighbours[t][j]` = `t2 * 4 + j2` for the tetrahedron sharing the face opposite corner
/// `j` of `t`, [`NO_NEIGHBOUR`] when no other tetrahedron has that face.
///
/// # Panics
/// If a face is in three or more tetrahedra: the splits are conforming, so that is a bug.
#[cfg(test)]
pub(crate) fn face_adjacency(tets: &[[u32; 4]]) -> Vec<[u32; 4]> {
    let mut faces: Vec<([u32; 3], u32)> = Vec::with_capacity(tets.len() * 4);
    for (t, tet) in tets.iter().enumerate() {
        for j in 0..4 {
            let mut key = [tet[(j + 1) % 4], tet[(j + 2) % 4], tet[(j + 3) % 4]];
            key.sort_unstable();
            faces.push((key, (t * 4 + j) as u32));
        }
    }
    faces.par_sort_unstable();
    let mut neighbours = vec![[NO_NEIGHBOUR; 4]; tets.len()];
    let mut n = 0;
    while n < faces.len() {
        let mut m = n + 1;
        while m < faces.len() && faces[m].0 == faces[n].0 {
            m += 1;
        }
        assert!(
            m - n <= 2,
            "face {:?} is in {} tetrahedra: the cube split is not conforming",
            faces[n].0,
            m - n
        );
        if m - n == 2 {
            let (x, y) = (faces[n].1, faces[n + 1].1);
            neighbours[(x / 4) as usize][(x % 4) as usize] = y;
            neighbours[(y / 4) as usize][(y % 4) as usize] = x;
        }
        n = m;
    }
    neighbours
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_volume_matches_the_tet_convention() {
        let v = signed_volume6(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z);
        assert_eq!(v, 1.0);
        assert_eq!(
            signed_volume6(DVec3::ZERO, DVec3::Y, DVec3::X, DVec3::Z),
            -1.0
        );
    }

    #[test]
    fn templates_are_positive_and_fill_the_unit_cube() {
        let corner = |b: u8| DVec3::new((b & 1) as f64, (b >> 1 & 1) as f64, (b >> 2 & 1) as f64);
        for templates in [&SIX[..], &FIVE_EVEN[..], &FIVE_ODD[..]] {
            let total: f64 = templates
                .iter()
                .map(|t| {
                    let [a, b, c, d] = t.map(corner);
                    let v = signed_volume6(a, b, c, d);
                    assert!(v > 0.0, "{t:?}");
                    v / 6.0
                })
                .sum();
            assert!((total - 1.0).abs() < 1e-12, "{templates:?}: {total}");
        }
    }

    #[test]
    fn structured_adjacency_equals_pairing_face_triples() {
        // Blank a scattering of points and collapse a row so that cells lose tetrahedra.
        for split in [CubeSplit::Five, CubeSplit::Six] {
            for seed in 0..4usize {
                let dims = [5, 4, 6];
                let n = dims.iter().product::<usize>();
                let mut points = Vec::with_capacity(n);
                for k in 0..dims[2] {
                    for j in 0..dims[1] {
                        for i in 0..dims[0] {
                            let z = if seed == 3 && k == 0 && j == 1 {
                                1.0
                            } else {
                                k as f64
                            };
                            points.push(DVec3::new(i as f64, j as f64 * 0.5, z));
                        }
                    }
                }
                let blanked = (0..n)
                    .map(|p| seed > 0 && (p * 7 + seed) % 13 == 0)
                    .collect();
                let grid =
                    GridVolume::curvilinear("g", dims, points, vec![0.0; n], blanked).unwrap();
                let (mesh, _) = tetrahedralize_with_report(&grid, split).unwrap();
                assert_eq!(
                    (0..mesh.tet_count())
                        .map(|t| mesh.neighbours(t))
                        .collect::<Vec<_>>(),
                    face_adjacency(&mesh.tets().collect::<Vec<_>>()),
                    "{split} seed {seed}"
                );
            }
        }
    }
}
