//! Marching tetrahedra (quad variant) on a tetrahedral mesh, closed at the hull into
//! watertight bodies, for comparison with DMT on the same tetrahedra.
//!
//! Invariant: one surface vertex per active edge (on its linear-interpolation crossing), one
//! face per active tetrahedron (a triangle for 1 or 3 marked corners, a quad for 2), every
//! face oriented from the marked (`value >= threshold`) side to the unmarked one. With the
//! marked parts of the hull triangles added as caps, every body is a closed, consistently
//! wound 2-manifold enclosing the marked region.

use std::collections::HashMap;

use glam::DVec3;

use rayon::prelude::*;

use super::{Body, DmtError, Shell, ShellCounts};
use crate::progress::{Progress, Stage};
use crate::tet::{NO_NEIGHBOUR, TetMesh};

/// Corners of the face opposite corner `j` of a positively oriented tetrahedron, counter-
/// clockwise seen from outside it.
pub const OUTWARD_FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// The point where the linear interpolation between `fp` at `p` and `fq` at `q` reaches
/// `threshold`, clamped to the segment; the midpoint when `fp == fq`. The result does not
/// depend on the order of the two ends.
pub fn crossing(p: DVec3, q: DVec3, fp: f64, fq: f64, threshold: f64) -> DVec3 {
    let (p, q, fp, fq) = if fq < fp {
        (q, p, fq, fp)
    } else {
        (p, q, fp, fq)
    };
    let t = (threshold - fp) / (fq - fp);
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.5
    };
    p + (q - p) * t
}

/// One marching-tetrahedra face: indices into [`MtSurface::vertices`], counter-clockwise
/// seen from the unmarked side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MtFace {
    Triangle([u32; 3]),
    Quad([u32; 4]),
}

/// The marching-tetrahedra surface at one threshold, and its closed bodies.
#[derive(Debug, Clone, PartialEq)]
pub struct MtSurface {
    pub threshold: f64,
    /// One vertex per active edge, on the edge's crossing; local coordinates.
    pub vertices: Vec<DVec3>,
    /// The mesh edge of each vertex: `[marked end, unmarked end]`.
    pub vertex_edges: Vec<[u32; 2]>,
    /// One face per active tetrahedron (before capping).
    pub faces: Vec<MtFace>,
    /// The tetrahedron of each face.
    pub face_tets: Vec<u32>,
    /// Counts of the uncapped surface (`surface_vertices` = active edges, `surface_faces` =
    /// active tetrahedra).
    pub counts: ShellCounts,
    /// Connected components of the capped surface, largest volume first.
    pub bodies: Vec<Body>,
}

impl MtSurface {
    /// The faces as triangles, quads split along their shorter diagonal.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        let mut out = Vec::with_capacity(self.faces.len() * 2);
        for face in &self.faces {
            match *face {
                MtFace::Triangle(t) => out.push(t),
                MtFace::Quad(q) => out.extend(split_quad(&self.vertices, q)),
            }
        }
        out
    }
}

/// Splits quad `q` (cyclic) along its shorter diagonal, keeping its orientation.
fn split_quad(positions: &[DVec3], q: [u32; 4]) -> [[u32; 3]; 2] {
    let p = |n: usize| positions[q[n] as usize];
    if p(0).distance_squared(p(2)) <= p(1).distance_squared(p(3)) {
        [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    } else {
        [[q[0], q[1], q[3]], [q[1], q[2], q[3]]]
    }
}

/// Parity of the permutation `order` of `0..4` (true = odd).
fn odd(order: [usize; 4]) -> bool {
    let mut inversions = 0;
    for a in 0..4 {
        for b in a + 1..4 {
            if order[a] > order[b] {
                inversions += 1;
            }
        }
    }
    inversions % 2 == 1
}

/// Marching tetrahedra on `mesh` with one value per mesh vertex (`values[v]`, finite);
/// a vertex is marked when `value >= threshold`.
///
/// The surface is closed at the hull of the mesh: every hull triangle contributes its
/// marked part, cut at the crossings of its edges (`truncated` bodies).
///
/// # Panics
/// If `values.len() != mesh.points.len()` (a caller bug).
pub fn marching_tetrahedra(mesh: &TetMesh, values: &[f64], threshold: f64) -> MtSurface {
    assert_eq!(
        values.len(),
        mesh.points.len(),
        "marching_tetrahedra needs one value per mesh vertex"
    );
    let marks: Vec<bool> = values.par_iter().map(|v| *v >= threshold).collect();

    // Active tetrahedra, then active edges, canonical (min, max), sorted: vertex n is edge n.
    let active_tets: Vec<u32> = mesh
        .par_tets()
        .enumerate()
        .filter(|(_, tet)| !matches!(corner_mask(&marks, tet), 0 | 15))
        .map(|(t, _)| t as u32)
        .collect();
    let edges = active_edges(mesh, &marks, &active_tets);
    let mut vertices = Vec::with_capacity(edges.len());
    let mut vertex_edges = Vec::with_capacity(edges.len());
    for &(x, y) in &edges {
        let (fx, fy) = (values[x as usize], values[y as usize]);
        vertices.push(crossing(
            mesh.points[x as usize],
            mesh.points[y as usize],
            fx,
            fy,
            threshold,
        ));
        vertex_edges.push(if marks[x as usize] { [x, y] } else { [y, x] });
    }
    let faces: Vec<MtFace> = active_tets
        .iter()
        .map(|&t| tet_face(&mesh.tet(t as usize), &marks, &edges))
        .collect();

    let regions = marked_regions(mesh, &marks);
    let counts = ShellCounts {
        marked_points: regions.par_iter().filter(|r| **r != NO_REGION).count(),
        active_tets: active_tets.len(),
        active_edges: edges.len(),
        surface_vertices: vertices.len(),
        surface_faces: faces.len(),
    };
    let mut surface = MtSurface {
        threshold,
        vertices,
        vertex_edges,
        faces,
        face_tets: active_tets,
        counts,
        bodies: Vec::new(),
    };
    surface.bodies = capped_bodies(mesh, &surface, &marks, &regions, &edges);
    surface
}

/// Bit `c` set when corner `c` of `tet` is marked.
fn corner_mask(marks: &[bool], tet: &[u32; 4]) -> u8 {
    (0..4).fold(0u8, |m, c| m | (u8::from(marks[tet[c] as usize]) << c))
}

/// The active edges of the `active` tetrahedra, canonical (min, max), sorted and unique.
fn active_edges(mesh: &TetMesh, marks: &[bool], active: &[u32]) -> Vec<(u32, u32)> {
    let mut edges: Vec<(u32, u32)> = Vec::with_capacity(active.len() * 3);
    for &t in active {
        let tet = &mesh.tet(t as usize);
        let mask = corner_mask(marks, tet);
        for a in 0..4 {
            for b in a + 1..4 {
                if (mask >> a & 1) != (mask >> b & 1) {
                    let (x, y) = (tet[a], tet[b]);
                    edges.push((x.min(y), x.max(y)));
                }
            }
        }
    }
    edges.sort_unstable();
    edges.dedup();
    edges
}

/// The surface vertex (index into the sorted active `edges`) on the edge `x`-`y`.
fn edge_vertex(edges: &[(u32, u32)], x: u32, y: u32) -> u32 {
    edges
        .binary_search(&(x.min(y), x.max(y)))
        .expect("every edge with differing marks of an active tetrahedron is listed") as u32
}

/// The face of active tetrahedron `tet`, oriented from marked to unmarked.
fn tet_face(tet: &[u32; 4], marks: &[bool], edges: &[(u32, u32)]) -> MtFace {
    let mask = corner_mask(marks, tet);
    let e = |a: usize, b: usize| edge_vertex(edges, tet[a], tet[b]);
    let inside: Vec<usize> = (0..4).filter(|c| mask >> c & 1 == 1).collect();
    let outside: Vec<usize> = (0..4).filter(|c| mask >> c & 1 == 0).collect();
    match (inside.as_slice(), outside.as_slice()) {
        // One corner `a` alone on its side; (a, b, c, d) made an even permutation so that
        // triangle (ab, ac, ad) faces away from `a`.
        ([a], [b, c, d]) | ([b, c, d], [a]) => {
            let (a, b, mut c, mut d) = (*a, *b, *c, *d);
            if odd([a, b, c, d]) {
                std::mem::swap(&mut c, &mut d);
            }
            if inside.len() == 1 {
                MtFace::Triangle([e(a, b), e(a, c), e(a, d)])
            } else {
                MtFace::Triangle([e(a, b), e(a, d), e(a, c)])
            }
        }
        // Marked a, b; unmarked c, d; (a, b, c, d) even: quad (ac, ad, bd, bc) faces the
        // unmarked side.
        ([a, b], [c, d]) => {
            let (a, b, mut c, mut d) = (*a, *b, *c, *d);
            if odd([a, b, c, d]) {
                std::mem::swap(&mut c, &mut d);
            }
            MtFace::Quad([e(a, c), e(a, d), e(b, d), e(b, c)])
        }
        _ => unreachable!("an active tetrahedron has 1, 2 or 3 marked corners"),
    }
}

/// The bodies of `surface`: its faces cut into triangles and closed at the hull by the
/// marked part of every hull triangle, each triangle labelled with the marked region
/// behind it.
fn capped_bodies(
    mesh: &TetMesh,
    surface: &MtSurface,
    marks: &[bool],
    regions: &[u32],
    edges: &[(u32, u32)],
) -> Vec<Body> {
    let marked = |v: u32| marks[v as usize];
    let edge_vertex = |x: u32, y: u32| edge_vertex(edges, x, y);
    let region_of_tet = |tet: &[u32; 4]| -> u32 {
        let v = tet.iter().find(|v| marks[**v as usize]);
        regions[*v.expect("an active or capped tetrahedron has a marked corner") as usize]
    };

    // Hull faces with a marked corner, in tetrahedron order.
    let hull_faces: Vec<(u32, u8)> = (0..mesh.tet_count())
        .into_par_iter()
        .flat_map_iter(|t| {
            let (tet, neighbours) = (mesh.tet(t), mesh.neighbours(t));
            (0..4).filter_map(move |j| {
                let on_hull = neighbours[j] == NO_NEIGHBOUR;
                let any_marked = OUTWARD_FACES[j].iter().any(|c| marked(tet[*c]));
                (on_hull && any_marked).then_some((t as u32, j as u8))
            })
        })
        .collect();
    let face_vertices = |f: usize| -> [u32; 3] {
        let (t, j) = hull_faces[f];
        OUTWARD_FACES[j as usize].map(|c| mesh.tet(t as usize)[c])
    };
    let mut positions = surface.vertices.clone();
    let sheets = HullSheets::new(
        mesh,
        &hull_faces,
        &face_vertices,
        &marked,
        &mut positions,
        edge_vertex,
    );

    // The MT faces; a crossing on a hull edge where separate sheets of the hull meet takes
    // the copy of its sheet.
    let mut triangles = Vec::with_capacity(surface.faces.len() * 2);
    let mut labels = Vec::with_capacity(surface.faces.len() * 2);
    for (face, &t) in surface.faces.iter().zip(&surface.face_tets) {
        let label = region_of_tet(&mesh.tet(t as usize));
        let split = match *face {
            MtFace::Triangle(v) => vec![v],
            MtFace::Quad(q) => split_quad(&surface.vertices, q).to_vec(),
        };
        for tri in split {
            triangles.push(tri.map(|v| sheets.crossing(v, t)));
            labels.push(label);
        }
    }
    let mut is_cap = vec![false; triangles.len()];

    // Close at the hull: the marked part of every hull triangle, outward.
    for (f, &(t, _)) in hull_faces.iter().enumerate() {
        let tet = &mesh.tet(t as usize);
        let face = face_vertices(f);
        let mut polygon: Vec<u32> = Vec::with_capacity(4);
        for n in 0..3 {
            let (x, y) = (face[n], face[(n + 1) % 3]);
            if marked(x) {
                polygon.push(sheets.hull_vertex(f, n));
            }
            if marked(x) != marked(y) {
                polygon.push(sheets.crossing(edge_vertex(x, y), t));
            }
        }
        match polygon.len() {
            3 => triangles.push([polygon[0], polygon[1], polygon[2]]),
            4 => triangles.extend(split_quad(
                &positions,
                [polygon[0], polygon[1], polygon[2], polygon[3]],
            )),
            n => unreachable!("the marked part of a triangle has 3 or 4 corners, not {n}"),
        }
        is_cap.resize(triangles.len(), true);
        labels.resize(triangles.len(), region_of_tet(tet));
    }
    bodies_by_label(&positions, &triangles, &is_cap, &labels)
}

/// Vertex identities on the hull that keep the capped surface a 2-manifold where the hull
/// is not one (tetrahedra left out around blanked points or collapsed cells can leave two
/// pieces of the mesh touching along an edge or at a point).
///
/// Around a hull edge, the tetrahedra form arcs from one hull face to another; each arc is
/// one sheet. The hull faces at the two ends of an arc are paired across the edge, the
/// crossing on the edge gets one copy per arc, and every marked hull vertex one copy per
/// umbrella of hull faces joined through paired edges. Where the hull is a manifold this
/// changes nothing but numbering.
struct HullSheets {
    /// Per hull face and corner position: the surface vertex of that marked corner.
    hull_vertex: Vec<u32>,
    /// `(crossing vertex, tetrahedron)` to the copy used in that tetrahedron, for crossings
    /// on edges where several sheets meet.
    crossing_copy: HashMap<(u32, u32), u32>,
}

impl HullSheets {
    fn new(
        mesh: &TetMesh,
        hull_faces: &[(u32, u8)],
        face_vertices: &dyn Fn(usize) -> [u32; 3],
        marked: &dyn Fn(u32) -> bool,
        positions: &mut Vec<DVec3>,
        edge_vertex: impl Fn(u32, u32) -> u32,
    ) -> HullSheets {
        // Hull edges with a marked end, with the hull faces around them.
        let mut edge_faces: Vec<((u32, u32), u32)> = Vec::with_capacity(hull_faces.len() * 3);
        for f in 0..hull_faces.len() {
            let face = face_vertices(f);
            for n in 0..3 {
                let (x, y) = (face[n], face[(n + 1) % 3]);
                if marked(x) || marked(y) {
                    edge_faces.push(((x.min(y), x.max(y)), f as u32));
                }
            }
        }
        edge_faces.par_sort_unstable();

        let mut pairs: Vec<(u32, u32, u32, u32)> = Vec::with_capacity(edge_faces.len() / 2);
        let mut crossing_copy = HashMap::new();
        let mut face_index: Option<HashMap<(u32, u8), u32>> = None;
        for group in edge_faces.chunk_by(|a, b| a.0 == b.0) {
            let (x, y) = group[0].0;
            if group.len() == 2 {
                pairs.push((group[0].1, group[1].1, x, y));
                continue;
            }
            // Several sheets meet at this edge: walk the arcs of tetrahedra around it.
            let index = face_index.get_or_insert_with(|| {
                hull_faces
                    .iter()
                    .enumerate()
                    .map(|(f, tj)| (*tj, f as u32))
                    .collect()
            });
            let crossing = (marked(x) != marked(y)).then(|| edge_vertex(x, y));
            let mut visited: Vec<u32> = Vec::new();
            for &(_, start) in group {
                if visited.contains(&start) {
                    continue;
                }
                let (mut t, mut k) = hull_faces[start as usize];
                let mut arc = Vec::new();
                let mut end = None;
                for _ in 0..=mesh.tet_count() {
                    let tet = mesh.tet(t as usize);
                    arc.push(t);
                    let entered = tet[k as usize];
                    let Some(exit) = (0..4).find(|&c| {
                        let v = tet[c];
                        v != x && v != y && v != entered
                    }) else {
                        break;
                    };
                    let next = mesh.neighbours(t as usize)[exit];
                    if next == NO_NEIGHBOUR {
                        end = index.get(&(t, exit as u8)).copied();
                        break;
                    }
                    (t, k) = (next / 4, (next % 4) as u8);
                }
                visited.push(start);
                if let Some(end) = end {
                    visited.push(end);
                    pairs.push((start, end, x, y));
                }
                if let Some(v) = crossing {
                    let copy = if visited.len() <= 2 {
                        v
                    } else {
                        positions.push(positions[v as usize]);
                        positions.len() as u32 - 1
                    };
                    for t in arc {
                        crossing_copy.insert((v, t), copy);
                    }
                }
            }
        }

        // Umbrellas: (face, corner) nodes of one marked vertex joined across paired edges.
        let node = |f: u32, v: u32| -> u32 {
            let face = face_vertices(f as usize);
            f * 3 + face.iter().position(|w| *w == v).expect("edge of its face") as u32
        };
        let mut parent: Vec<u32> = (0..hull_faces.len() as u32 * 3).collect();
        fn root(parent: &mut [u32], mut v: u32) -> u32 {
            while parent[v as usize] != v {
                let up = parent[parent[v as usize] as usize];
                parent[v as usize] = up;
                v = up;
            }
            v
        }
        for &(f1, f2, x, y) in &pairs {
            for v in [x, y] {
                if marked(v) {
                    let a = root(&mut parent, node(f1, v));
                    let b = root(&mut parent, node(f2, v));
                    if a != b {
                        parent[b as usize] = a;
                    }
                }
            }
        }
        let mut vertex_of_root = vec![u32::MAX; parent.len()];
        let mut hull_vertex = vec![u32::MAX; parent.len()];
        for f in 0..hull_faces.len() {
            let face = face_vertices(f);
            for (n, &v) in face.iter().enumerate() {
                if !marked(v) {
                    continue;
                }
                let r = root(&mut parent, (f * 3 + n) as u32) as usize;
                if vertex_of_root[r] == u32::MAX {
                    vertex_of_root[r] = positions.len() as u32;
                    positions.push(mesh.points[v as usize]);
                }
                hull_vertex[f * 3 + n] = vertex_of_root[r];
            }
        }
        HullSheets {
            hull_vertex,
            crossing_copy,
        }
    }

    /// The surface vertex of the marked corner at position `n` of hull face `f`.
    fn hull_vertex(&self, f: usize, n: usize) -> u32 {
        self.hull_vertex[f * 3 + n]
    }

    /// The copy of crossing vertex `v` used in tetrahedron `t`.
    fn crossing(&self, v: u32, t: u32) -> u32 {
        if self.crossing_copy.is_empty() {
            return v;
        }
        self.crossing_copy.get(&(v, t)).copied().unwrap_or(v)
    }
}

/// Marching tetrahedra as a [`Shell`]: checks the input like DMT's extraction, runs
/// [`marching_tetrahedra`] and measures triangle quality over the bodies.
pub fn shell(
    mesh: &TetMesh,
    values: &[f64],
    threshold: f64,
    progress: &dyn Progress,
) -> Result<Shell, DmtError> {
    super::check_inputs(mesh, values, threshold)?;
    let lowered = lower_point_touches(mesh, values, threshold);
    let (values, point_touches) = match &lowered {
        Some((lowered, count)) => (lowered.as_slice(), *count),
        None => (values, 0),
    };
    progress.report(Stage::Contour, 0.0);
    if progress.is_cancelled() {
        return Err(DmtError::Cancelled);
    }
    let surface = marching_tetrahedra(mesh, values, threshold);
    let quality = super::measure::quality(
        surface
            .bodies
            .iter()
            .map(|b| (b.positions.as_slice(), b.triangles.as_slice())),
    );
    progress.report(Stage::Contour, 1.0);
    Ok(Shell {
        threshold,
        bodies: surface.bodies,
        counts: surface.counts,
        quality,
        point_touches,
    })
}

/// Marked material (`value >= threshold`) whose every sample sits exactly at the
/// threshold encloses no volume: every crossing on its edges is at a sample itself, so
/// marching tetrahedra and DMT alike would give a "body" collapsed onto its samples (e.g.
/// one assay of exactly the cut-off grade among lower ones). Such samples are lowered
/// just below the threshold, so they form no body; no crossing of any other body uses
/// them (their neighbours are below the threshold or lowered too). Returns the values and
/// how many such regions there were, or `None` when there are none.
pub fn lower_point_touches(
    mesh: &TetMesh,
    values: &[f64],
    threshold: f64,
) -> Option<(Vec<f64>, usize)> {
    if !values.contains(&threshold) {
        return None;
    }
    let marked: Vec<bool> = values.iter().map(|&v| v >= threshold).collect();
    let regions = marked_regions(mesh, &marked);
    let count = region_count(&regions);
    let mut above = vec![false; count];
    for (&r, &v) in regions.iter().zip(values) {
        if r != NO_REGION && v > threshold {
            above[r as usize] = true;
        }
    }
    let touches = above.iter().filter(|&&a| !a).count();
    if touches == 0 {
        return None;
    }
    let lowered = regions
        .iter()
        .zip(values)
        .map(|(&r, &v)| {
            if r != NO_REGION && !above[r as usize] {
                threshold.next_down()
            } else {
                v
            }
        })
        .collect();
    Some((lowered, touches))
}

/// The number of regions of `regions` ([`marked_regions`]): the largest id + 1.
pub fn region_count(regions: &[u32]) -> usize {
    regions
        .iter()
        .filter(|&&r| r != NO_REGION)
        .map(|&r| r as usize + 1)
        .max()
        .unwrap_or(0)
}

/// Connected pieces of the marked region: `regions[v]` is the same number for marked
/// vertices joined through marked material (ids 0, 1, .. in the order of each piece's
/// first vertex), [`NO_REGION`] for unmarked or unused vertices.
///
/// The marked part of a tetrahedron (linear interpolation) is convex, so all marked corners
/// of one tetrahedron are in one piece, and pieces of neighbouring tetrahedra meet exactly
/// where they share a marked corner. A body is one piece: its outer shell together with the
/// shells of its cavities.
pub fn marked_regions(mesh: &TetMesh, marked: &[bool]) -> Vec<u32> {
    let mut parent: Vec<u32> = (0..mesh.points.len() as u32).collect();
    fn root(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            let up = parent[parent[v as usize] as usize];
            parent[v as usize] = up;
            v = up;
        }
        v
    }
    for tet in mesh.tets() {
        let mut first = None;
        for v in tet {
            if !marked[v as usize] {
                continue;
            }
            match first {
                None => first = Some(root(&mut parent, v)),
                Some(a) => {
                    let b = root(&mut parent, v);
                    if a != b {
                        parent[b as usize] = a;
                    }
                }
            }
        }
    }
    let mut used = vec![false; mesh.points.len()];
    for tet in mesh.tets() {
        for v in tet {
            used[v as usize] = true;
        }
    }
    // Compact ids, numbered in the order of each region's first vertex.
    let mut id = vec![NO_REGION; mesh.points.len()];
    let mut next = 0;
    (0..mesh.points.len() as u32)
        .map(|v| {
            if marked[v as usize] && used[v as usize] {
                let r = root(&mut parent, v) as usize;
                if id[r] == NO_REGION {
                    id[r] = next;
                    next += 1;
                }
                id[r]
            } else {
                NO_REGION
            }
        })
        .collect()
}

/// The volume of each marked region under the linear interpolation of `values` on `mesh`
/// (the volume marching tetrahedra encloses, without building its surface): per region id
/// of `regions` ([`marked_regions`]), `len` = the largest id + 1.
///
/// Per tetrahedron the marked part is convex: the whole tetrahedron, a corner cut off at the
/// crossings (one marked corner), the tetrahedron minus such a corner (three), or a wedge
/// (two), measured as cones from a marked corner over the faces away from it.
pub fn region_volumes(mesh: &TetMesh, values: &[f64], threshold: f64, regions: &[u32]) -> Vec<f64> {
    let len = region_count(regions);
    let cone = |apex: DVec3, a: DVec3, b: DVec3, c: DVec3| {
        ((a - apex).dot((b - apex).cross(c - apex)) / 6.0).abs()
    };
    // Fixed chunks summed in order: the result does not depend on the thread count or on
    // scheduling (at most about 4M partial sums in flight).
    let chunks = (4_000_000 / len.max(1)).clamp(1, mesh.tet_count().div_ceil(4096).max(1));
    let chunk = mesh.tet_count().div_ceil(chunks).max(1);
    let partial: Vec<Vec<f64>> = (0..mesh.tet_count().div_ceil(chunk))
        .into_par_iter()
        .map(|c| {
            let tets = c * chunk..((c + 1) * chunk).min(mesh.tet_count());
            tets.map(|t| mesh.tet(t))
                .fold(vec![0.0; len], |mut acc, tet| {
                    let marked = tet.map(|v| values[v as usize] >= threshold);
                    let m = marked.iter().filter(|&&x| x).count();
                    if m == 0 {
                        return acc;
                    }
                    let p = tet.map(|v| mesh.points[v as usize]);
                    let f = tet.map(|v| values[v as usize]);
                    // The crossing on edge i -> j (i marked, j not).
                    let cross = |i: usize, j: usize| {
                        let t = ((f[i] - threshold) / (f[i] - f[j])).clamp(0.0, 1.0);
                        p[i] + (p[j] - p[i]) * t
                    };
                    // The marked corners first, then the others.
                    let mut order = [0usize; 4];
                    let (mut lo, mut hi) = (0, 4);
                    for (i, &mk) in marked.iter().enumerate() {
                        if mk {
                            order[lo] = i;
                            lo += 1;
                        } else {
                            hi -= 1;
                            order[hi] = i;
                        }
                    }
                    let (inside, outside) = order.split_at(m);
                    let whole = cone(p[0], p[1], p[2], p[3]);
                    let volume = match m {
                        4 => whole,
                        1 => {
                            let a = inside[0];
                            let [b, c, d] = [outside[0], outside[1], outside[2]];
                            cone(p[a], cross(a, b), cross(a, c), cross(a, d))
                        }
                        3 => {
                            let d = outside[0];
                            let [a, b, c] = [inside[0], inside[1], inside[2]];
                            whole - cone(p[d], cross(a, d), cross(b, d), cross(c, d))
                        }
                        _ => {
                            let [a, b] = [inside[0], inside[1]];
                            let [c, d] = [outside[0], outside[1]];
                            let (ac, ad, bc, bd) =
                                (cross(a, c), cross(a, d), cross(b, c), cross(b, d));
                            // Faces away from `a`: the triangle (b, bc, bd) on face bcd and the
                            // planar quad (ac, ad, bd, bc) of the cut.
                            cone(p[a], p[b], bc, bd)
                                + cone(p[a], ac, ad, bd)
                                + cone(p[a], ac, bd, bc)
                        }
                    };
                    let r = regions[tet[inside[0]] as usize];
                    if r != NO_REGION {
                        acc[r as usize] += volume;
                    }
                    acc
                })
        })
        .collect();
    partial.into_iter().fold(vec![0.0; len], |mut a, b| {
        for (x, y) in a.iter_mut().zip(b) {
            *x += y;
        }
        a
    })
}

/// No marked region (see [`marked_regions`]).
pub const NO_REGION: u32 = u32::MAX;

/// Groups triangles into bodies by `labels` (one per triangle, e.g. the
/// [`marked_regions`] number of the marked material behind it) and measures each: volume by
/// the divergence theorem, area, `closed` (every edge in exactly two oppositely directed
/// triangles), `truncated` (has a triangle flagged in `is_cap`), bbox. Bodies come largest
/// volume first; each keeps only its own vertices.
pub fn bodies_by_label(
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    is_cap: &[bool],
    labels: &[u32],
) -> Vec<Body> {
    let mut order: Vec<usize> = (0..triangles.len()).collect();
    order.sort_by_key(|n| labels[*n]);
    let mut local = vec![u32::MAX; positions.len()];
    let mut bodies = Vec::new();
    for group in order.chunk_by(|a, b| labels[*a] == labels[*b]) {
        let mut body_positions = Vec::new();
        let mut body_triangles = Vec::with_capacity(group.len());
        for &n in group {
            body_triangles.push(triangles[n].map(|v| {
                if local[v as usize] == u32::MAX {
                    local[v as usize] = body_positions.len() as u32;
                    body_positions.push(positions[v as usize]);
                }
                local[v as usize]
            }));
        }
        for &n in group {
            for v in triangles[n] {
                local[v as usize] = u32::MAX;
            }
        }
        let truncated = group
            .iter()
            .any(|n| is_cap.get(*n).copied().unwrap_or(false));
        let mut body = measure_body(body_positions, body_triangles, truncated);
        body.region = labels[group[0]];
        bodies.push(body);
    }
    bodies.sort_by(|a, b| b.volume.total_cmp(&a.volume));
    bodies
}

/// Builds a [`Body`] from its own vertices and triangles, measuring it.
pub fn measure_body(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>, truncated: bool) -> Body {
    let mut volume = 0.0;
    let mut area = 0.0;
    for t in &triangles {
        let [a, b, c] = t.map(|v| positions[v as usize]);
        volume += a.dot(b.cross(c)) / 6.0;
        area += (b - a).cross(c - a).length() / 2.0;
    }
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in &positions {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let closed = is_closed(&triangles);
    Body {
        positions,
        triangles,
        volume,
        area,
        closed,
        truncated,
        bbox: [lo, hi],
        region: NO_REGION,
        mt_fallback: false,
    }
}

/// Every directed edge appears once and its reverse once.
pub fn is_closed(triangles: &[[u32; 3]]) -> bool {
    let mut directed: Vec<(u32, u32)> = triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .collect();
    directed.sort_unstable();
    if directed.windows(2).any(|w| w[0] == w[1]) {
        return false;
    }
    directed
        .iter()
        .all(|&(a, b)| a != b && directed.binary_search(&(b, a)).is_ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn single_tet() -> TetMesh {
        TetMesh::from_parts(
            vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            vec![[0, 1, 2, 3]],
            vec![[NO_NEIGHBOUR; 4]],
            vec![0, 1, 2, 3],
            0,
        )
    }

    fn newell(positions: &[DVec3], face: &[u32]) -> DVec3 {
        let mut n = DVec3::ZERO;
        for i in 0..face.len() {
            let a = positions[face[i] as usize];
            let b = positions[face[(i + 1) % face.len()] as usize];
            n += a.cross(b);
        }
        n
    }

    #[test]
    fn crossing_interpolates_and_is_symmetric() {
        let c = crossing(DVec3::ZERO, DVec3::X * 4.0, 0.0, 2.0, 0.5);
        assert_eq!(c, DVec3::X);
        assert_eq!(crossing(DVec3::X * 4.0, DVec3::ZERO, 2.0, 0.0, 0.5), c);
        assert_eq!(
            crossing(DVec3::ZERO, DVec3::X, 1.0, 1.0, 1.0),
            DVec3::X * 0.5
        );
    }

    #[test]
    fn every_marking_of_a_tet_faces_the_unmarked_side_and_closes() {
        let mesh = single_tet();
        for mask in 1..15u8 {
            let values: Vec<f64> = (0..4).map(|c| f64::from(mask >> c & 1)).collect();
            let mt = marching_tetrahedra(&mesh, &values, 0.5);
            assert_eq!(mt.faces.len(), 1);
            let face: Vec<u32> = match mt.faces[0] {
                MtFace::Triangle(t) => t.to_vec(),
                MtFace::Quad(q) => q.to_vec(),
            };
            let marked: Vec<DVec3> = (0..4)
                .filter(|c| mask >> c & 1 == 1)
                .map(|c| mesh.points[c])
                .collect();
            let unmarked: Vec<DVec3> = (0..4)
                .filter(|c| mask >> c & 1 == 0)
                .map(|c| mesh.points[c])
                .collect();
            let centre = |ps: &[DVec3]| ps.iter().copied().sum::<DVec3>() / ps.len() as f64;
            let direction = centre(&unmarked) - centre(&marked);
            assert!(
                newell(&mt.vertices, &face).dot(direction) > 0.0,
                "mask {mask:04b}"
            );
            assert_eq!(mt.bodies.len(), 1);
            let body = &mt.bodies[0];
            assert!(body.closed && body.truncated, "mask {mask:04b}");
            // Midpoint crossings: the marked region is a corner (1/8 of 1/6), its
            // complement (7/8 of 1/6), or the middle slab (1/2 of 1/6).
            let expected = match marked.len() {
                1 => 1.0 / 48.0,
                3 => 7.0 / 48.0,
                _ => 1.0 / 12.0,
            };
            assert!(
                (body.volume - expected).abs() < 1e-12,
                "mask {mask:04b}: {}",
                body.volume
            );
        }
    }

    #[test]
    fn all_marked_is_the_whole_hull() {
        let mt = marching_tetrahedra(&single_tet(), &[1.0; 4], 0.5);
        assert_eq!(mt.counts.active_tets, 0);
        assert_eq!(mt.bodies.len(), 1);
        assert!((mt.bodies[0].volume - 1.0 / 6.0).abs() < 1e-15);
        assert!(mt.bodies[0].closed && mt.bodies[0].truncated);
        assert!(
            marching_tetrahedra(&single_tet(), &[0.0; 4], 0.5)
                .bodies
                .is_empty()
        );
    }

    #[test]
    fn open_or_doubled_edges_are_not_closed() {
        assert!(!is_closed(&[[0, 1, 2]]));
        assert!(is_closed(&[[0, 1, 2], [0, 2, 1]]));
        assert!(!is_closed(&[[0, 1, 2], [0, 1, 2]]));
    }

    #[test]
    fn shell_checks_its_input_and_measures_quality() {
        let mesh = single_tet();
        let progress = crate::progress::NoProgress;
        let shell = shell(&mesh, &[1.0, 0.0, 0.0, 0.0], 0.5, &progress).unwrap();
        assert_eq!(shell.counts.surface_faces, 1);
        assert_eq!(shell.quality.triangles, 4, "MT triangle + 3 cap triangles");
        assert!(shell.quality.min_angle_deg > 40.0);
        assert!(matches!(
            super::shell(&mesh, &[1.0, f64::NAN, 0.0, 0.0], 0.5, &progress),
            Err(DmtError::NonFinite(1))
        ));
        assert!(super::shell(&mesh, &[1.0; 3], 0.5, &progress).is_err());
    }
}
