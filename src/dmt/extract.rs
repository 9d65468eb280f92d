//! DMT topology: active tetrahedra and edges, the dual polygon of every active edge
//! (walked around the edge), and the hull caps that close each body
//! (reference/capping.md).
//!
//! Invariant: every polygon is oriented so that its normal points from the marked to the
//! unmarked side; together, DMT polygons and cap polygons use every directed edge once and
//! its reverse once (a closed, oriented 2-manifold).

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

use crate::tet::{NO_NEIGHBOUR, TetMesh};

/// Vertices of the face opposite corner `i`, ordered counter-clockwise seen from outside a
/// positively oriented tetrahedron.
pub const FACE_OUTWARD: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// The six edges of a tetrahedron as corner pairs.
const TET_EDGES: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];

/// What a surface vertex stands for; decides how it is placed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VertexRole {
    /// The DMT vertex inside active tetrahedron `tet`.
    Tet { tet: u32 },
    /// `W_f`: on the active hull face `face` (encoded `tet * 4 + corner opposite`).
    HullFace { face: u32 },
    /// `U_e`: on the active hull edge between mesh vertices `a` and `b`.
    HullEdge { a: u32, b: u32 },
    /// A marked mesh vertex on the hull, corner of cap polygons.
    HullPoint { point: u32 },
}

/// Kinds of polygons: duals of active edges, or caps on hull faces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PolygonKind {
    Dual,
    Cap,
}

/// The combinatorial DMT surface of one threshold, before vertex placement.
///
/// Shapes: `roles` #V; polygon `k` has vertices `corners[starts[k]..starts[k+1]]`, kind
/// `kinds[k]`. Vertices `0..active_tets` are the DMT vertices (`Tet` roles), in tet order.
#[derive(Debug, Clone, Default)]
pub struct Topology {
    pub roles: Vec<VertexRole>,
    pub corners: Vec<u32>,
    pub starts: Vec<u32>,
    pub kinds: Vec<PolygonKind>,
    /// For dual polygon `k` (the first `active_edges` polygons), its active edge as
    /// `(marked, unmarked)` mesh vertices.
    pub dual_edges: Vec<(u32, u32)>,
    /// `true` for dual polygons closed through the hull (their edge's crossing is `U_e`).
    pub dual_open: Vec<bool>,
    pub active_tets: usize,
    pub active_edges: usize,
    pub marked_points: usize,
}

impl Topology {
    pub fn polygon(&self, k: usize) -> &[u32] {
        &self.corners[self.starts[k] as usize..self.starts[k + 1] as usize]
    }

    pub fn polygon_count(&self) -> usize {
        self.kinds.len()
    }
}

fn edge_key(a: u32, b: u32) -> u64 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    (u64::from(lo) << 32) | u64::from(hi)
}

/// Corner order `(a, b, c, d)` of tet `t` such that `a`,`b` are the edge and the order is
/// an even permutation of the stored (positive) one.
fn oriented_around(tet: &[u32; 4], a: u32, b: u32) -> (u32, u32) {
    let ia = tet.iter().position(|&v| v == a).expect("edge in tet");
    let ib = tet.iter().position(|&v| v == b).expect("edge in tet");
    let mut rest = (0..4).filter(|&i| i != ia && i != ib);
    let (k, l) = (
        rest.next().expect("4 corners"),
        rest.next().expect("4 corners"),
    );
    // Parity of the permutation (ia, ib, k, l).
    let perm = [ia, ib, k, l];
    let mut inversions = 0;
    for i in 0..4 {
        for j in i + 1..4 {
            if perm[i] > perm[j] {
                inversions += 1;
            }
        }
    }
    if inversions % 2 == 0 {
        (tet[k], tet[l])
    } else {
        (tet[l], tet[k])
    }
}

fn corner_index(tet: &[u32; 4], v: u32) -> usize {
    tet.iter().position(|&x| x == v).expect("vertex in tet")
}

/// Builds the DMT topology of `mesh` classified by `marked` (one flag per mesh vertex).
pub fn build(mesh: &TetMesh, marked: &[bool]) -> Topology {
    let active = active_tets(mesh, marked);
    let mut tet_vertex = vec![u32::MAX; mesh.tet_count()];
    for (i, &t) in active.iter().enumerate() {
        tet_vertex[t as usize] = i as u32;
    }
    let mut roles: Vec<VertexRole> = active.iter().map(|&t| VertexRole::Tet { tet: t }).collect();
    let edges = active_edges(mesh, marked, &active);
    let hull_faces = hull_faces(mesh);
    let hull = HullVertices::new(mesh, marked, &hull_faces, &mut roles);
    let dual: Vec<(Vec<u32>, (u32, u32), bool)> = edges
        .par_iter()
        .map(|&(key, start)| dual_polygon(mesh, marked, &tet_vertex, &hull, key, start))
        .collect();

    let mut topo = Topology {
        active_tets: active.len(),
        active_edges: edges.len(),
        marked_points: marked.iter().filter(|&&m| m).count(),
        ..Topology::default()
    };
    topo.starts.push(0);
    for (ring, edge, open) in dual {
        topo.dual_edges.push(edge);
        topo.dual_open.push(open);
        topo.corners.extend_from_slice(&ring);
        topo.starts.push(topo.corners.len() as u32);
        topo.kinds.push(PolygonKind::Dual);
    }
    push_caps(&mut topo, mesh, marked, &hull_faces, &hull);
    topo.roles = roles;
    topo
}

/// The tetrahedra with both marked and unmarked corners, in tet order.
fn active_tets(mesh: &TetMesh, marked: &[bool]) -> Vec<u32> {
    let is_active = |t: usize| {
        let m = mesh.tet(t).iter().filter(|&&v| marked[v as usize]).count();
        m > 0 && m < 4
    };
    (0..mesh.tet_count() as u32)
        .into_par_iter()
        .filter(|&t| is_active(t as usize))
        .collect()
}

/// The active edges (by [`edge_key`], sorted), each with one tetrahedron that holds it.
fn active_edges(mesh: &TetMesh, marked: &[bool], active: &[u32]) -> Vec<(u64, u32)> {
    let mut edges: Vec<(u64, u32)> = active
        .par_iter()
        .flat_map_iter(|&t| {
            let tv = mesh.tet(t as usize);
            TET_EDGES.iter().filter_map(move |&(i, j)| {
                let (a, b) = (tv[i], tv[j]);
                (marked[a as usize] != marked[b as usize]).then(|| (edge_key(a, b), t))
            })
        })
        .collect();
    edges.par_sort_unstable();
    edges.dedup_by_key(|e| e.0);
    edges
}

/// The hull faces (`tet * 4 + corner opposite`), in tet order.
fn hull_faces(mesh: &TetMesh) -> Vec<u32> {
    (0..mesh.tet_count() as u32)
        .into_par_iter()
        .flat_map_iter(|t| {
            (0..4u32).filter_map(move |i| {
                (mesh.neighbours(t as usize)[i as usize] == NO_NEIGHBOUR).then_some(t * 4 + i)
            })
        })
        .collect()
}

/// The corners of hull face `f`, counter-clockwise seen from outside.
fn face_corners(mesh: &TetMesh, f: u32) -> [u32; 3] {
    let tv = mesh.tet((f / 4) as usize);
    FACE_OUTWARD[(f % 4) as usize].map(|i| tv[i])
}

/// The surface vertices on the hull: active hull faces (`W_f`), active hull edges (`U_e`)
/// and marked hull points, by what they stand for.
struct HullVertices {
    face: HashMap<u32, u32>,
    edge: HashMap<u64, u32>,
    point: HashMap<u32, u32>,
}

impl HullVertices {
    /// Numbers the hull vertices of `hull_faces` after those in `roles`, adding theirs.
    fn new(
        mesh: &TetMesh,
        marked: &[bool],
        hull_faces: &[u32],
        roles: &mut Vec<VertexRole>,
    ) -> Self {
        let mut face_vertex: HashMap<u32, u32> = HashMap::new();
        let mut edge_vertex: HashMap<u64, u32> = HashMap::new();
        let mut point_vertex: HashMap<u32, u32> = HashMap::new();
        for &f in hull_faces {
            let c = face_corners(mesh, f);
            let m = c.iter().filter(|&&v| marked[v as usize]).count();
            if m > 0 {
                for &v in &c {
                    if marked[v as usize] {
                        point_vertex.entry(v).or_insert_with(|| {
                            roles.push(VertexRole::HullPoint { point: v });
                            roles.len() as u32 - 1
                        });
                    }
                }
            }
            if m == 0 || m == 3 {
                continue;
            }
            face_vertex.insert(f, roles.len() as u32);
            roles.push(VertexRole::HullFace { face: f });
            for k in 0..3 {
                let (a, b) = (c[k], c[(k + 1) % 3]);
                if marked[a as usize] != marked[b as usize] {
                    edge_vertex.entry(edge_key(a, b)).or_insert_with(|| {
                        let (a, b) = if marked[a as usize] { (a, b) } else { (b, a) };
                        roles.push(VertexRole::HullEdge { a, b });
                        roles.len() as u32 - 1
                    });
                }
            }
        }
        Self {
            face: face_vertex,
            edge: edge_vertex,
            point: point_vertex,
        }
    }
}

/// The dual polygon of the active edge `key` (held by tetrahedron `start`), counter-clockwise
/// around the edge oriented marked -> unmarked: its corners, the edge as (marked, unmarked)
/// and whether it closes through the hull.
fn dual_polygon(
    mesh: &TetMesh,
    marked: &[bool],
    tet_vertex: &[u32],
    hull: &HullVertices,
    key: u64,
    start: u32,
) -> (Vec<u32>, (u32, u32), bool) {
    let (lo, hi) = ((key >> 32) as u32, key as u32);
    let (a, b) = if marked[lo as usize] {
        (lo, hi)
    } else {
        (hi, lo)
    };
    let (c0, d0) = oriented_around(&mesh.tet(start as usize), a, b);
    let mut ring = Vec::with_capacity(8);
    // Walk counter-clockwise from `start`; an interior edge closes the ring.
    let (mut t, mut c, mut d) = (start, c0, d0);
    let mut end_face = None;
    loop {
        ring.push(tet_vertex[t as usize]);
        let k = corner_index(&mesh.tet(t as usize), c);
        let n = mesh.neighbours(t as usize)[k];
        if n == NO_NEIGHBOUR {
            end_face = Some(t * 4 + k as u32);
            break;
        }
        (t, c, d) = (n / 4, d, mesh.tet((n / 4) as usize)[(n % 4) as usize]);
        if t == start {
            break;
        }
    }
    let Some(end_face) = end_face else {
        return (ring, (a, b), false);
    };
    // A hull edge: walk clockwise from `start` to the other hull face, then close the
    // chain through W_f, U_e, W_f' (capping.md).
    let mut before = Vec::new();
    let (mut t, mut c, mut d) = (start, c0, d0);
    let start_face = loop {
        let l = corner_index(&mesh.tet(t as usize), d);
        let n = mesh.neighbours(t as usize)[l];
        if n == NO_NEIGHBOUR {
            break t * 4 + l as u32;
        }
        (t, c, d) = (n / 4, mesh.tet((n / 4) as usize)[(n % 4) as usize], c);
        before.push(tet_vertex[t as usize]);
    };
    before.reverse();
    before.extend_from_slice(&ring);
    let mut ring = before;
    ring.push(hull.face[&end_face]);
    ring.push(hull.edge[&edge_key(a, b)]);
    ring.push(hull.face[&start_face]);
    (ring, (a, b), true)
}

/// Adds the caps: the marked part of every hull triangle, counter-clockwise seen from
/// outside.
fn push_caps(
    topo: &mut Topology,
    mesh: &TetMesh,
    marked: &[bool],
    hull_faces: &[u32],
    hull: &HullVertices,
) {
    for &f in hull_faces {
        let c = face_corners(mesh, f);
        let m = c.iter().filter(|&&v| marked[v as usize]).count();
        if m == 0 {
            continue;
        }
        for k in 0..3 {
            let (p, q) = (c[k], c[(k + 1) % 3]);
            let (mp, mq) = (marked[p as usize], marked[q as usize]);
            if mp {
                topo.corners.push(hull.point[&p]);
            }
            if mp != mq {
                topo.corners.push(hull.edge[&edge_key(p, q)]);
                if mp {
                    topo.corners.push(hull.face[&f]);
                }
            }
        }
        topo.starts.push(topo.corners.len() as u32);
        topo.kinds.push(PolygonKind::Cap);
    }
}

/// Positions of the hull vertices (`W_f`, `U_e`, hull points): `U_e` is the crossing on its
/// edge given by `crossing`, `W_f` the mean of the crossings on its two active edges.
pub fn place_hull_vertices(
    topo: &Topology,
    mesh: &TetMesh,
    marked: &[bool],
    crossing: &(dyn Fn(u32, u32) -> DVec3 + Sync),
    positions: &mut [DVec3],
) {
    for (v, role) in topo.roles.iter().enumerate() {
        positions[v] = match *role {
            VertexRole::Tet { .. } => continue,
            VertexRole::HullPoint { point } => mesh.points[point as usize],
            VertexRole::HullEdge { a, b } => crossing(a, b),
            VertexRole::HullFace { face } => {
                let tv = mesh.tet((face / 4) as usize);
                let c = FACE_OUTWARD[(face % 4) as usize].map(|i| tv[i]);
                let mut sum = DVec3::ZERO;
                let mut n = 0.0;
                for k in 0..3 {
                    let (p, q) = (c[k], c[(k + 1) % 3]);
                    if marked[p as usize] != marked[q as usize] {
                        let (a, b) = if marked[p as usize] { (p, q) } else { (q, p) };
                        sum += crossing(a, b);
                        n += 1.0;
                    }
                }
                sum / n
            }
        };
    }
}
