//! Duality of marching tetrahedra and DMT on the same (grid-split) tetrahedra: MT vertices
//! are the DMT polygons, MT faces the DMT vertices, with the same incidences.

use std::collections::BTreeSet;

use glam::DVec3;
use wellmesh::dmt::extract::{self, PolygonKind, VertexRole};
use wellmesh::dmt::mt::{MtFace, marching_tetrahedra};
use wellmesh::dmt::{Placement, Triangulation, extract_shell};
use wellmesh::grid::{CubeSplit, GridVolume, tetrahedralize};
use wellmesh::progress::NoProgress;

/// `(marked end, unmarked end)` of an active edge and an active tetrahedron.
type Incidences = BTreeSet<((u32, u32), u32)>;
type Field = Box<dyn Fn(DVec3) -> f64>;

fn field(n: usize, f: impl Fn(DVec3) -> f64) -> GridVolume {
    let step = 2.0 / (n - 1) as f64;
    let values = (0..n * n * n)
        .map(|p| {
            let ijk = DVec3::new((p % n) as f64, ((p / n) % n) as f64, (p / (n * n)) as f64);
            f(ijk * step - DVec3::ONE)
        })
        .collect();
    GridVolume::regular("field", [n; 3], DVec3::splat(step), values).unwrap()
}

/// `(active edge, active tetrahedron)` incidences of the MT surface: vertex of edge e lies on
/// the face of tet t.
fn mt_incidences(
    grid: &GridVolume,
    split: CubeSplit,
    threshold: f64,
) -> (Incidences, usize, usize) {
    let mesh = tetrahedralize(grid, split).unwrap();
    let mt = marching_tetrahedra(&mesh, &grid.values, threshold);
    let mut pairs = BTreeSet::new();
    for (face, &t) in mt.faces.iter().zip(&mt.face_tets) {
        let vertices: Vec<u32> = match face {
            MtFace::Triangle(v) => v.to_vec(),
            MtFace::Quad(v) => v.to_vec(),
        };
        for v in vertices {
            let [a, b] = mt.vertex_edges[v as usize];
            pairs.insert(((a, b), t));
        }
    }
    (pairs, mt.vertices.len(), mt.faces.len())
}

#[test]
fn mt_and_dmt_are_dual_on_grid_meshes() {
    let fields: [(&str, Field); 3] = [
        ("sphere", Box::new(|p: DVec3| 0.8 - p.length())),
        (
            "waves",
            Box::new(|p: DVec3| (4.0 * p.x).sin() * (3.0 * p.y).cos() + p.z),
        ),
        (
            "cut by the boundary",
            Box::new(|p: DVec3| 0.9 - (p - DVec3::X).length()),
        ),
    ];
    for (name, f) in fields {
        let grid = field(11, f);
        for split in [CubeSplit::Five, CubeSplit::Six] {
            let mesh = tetrahedralize(&grid, split).unwrap();
            let marked: Vec<bool> = grid.values.iter().map(|v| *v >= 0.0).collect();
            let topo = extract::build(&mesh, &marked);
            let dmt_vertices = topo
                .roles
                .iter()
                .filter(|r| matches!(r, VertexRole::Tet { .. }))
                .count();
            let dual_polygons = topo
                .kinds
                .iter()
                .filter(|k| **k == PolygonKind::Dual)
                .count();

            let (mt_pairs, mt_vertices, mt_faces) = mt_incidences(&grid, split, 0.0);
            assert_eq!(
                dmt_vertices, mt_faces,
                "{name} {split}: #DMT vertices = #MT faces"
            );
            assert_eq!(
                dual_polygons, mt_vertices,
                "{name} {split}: #DMT faces = #MT vertices"
            );

            let mut dmt_pairs = BTreeSet::new();
            for k in 0..topo.polygon_count() {
                if topo.kinds[k] != PolygonKind::Dual {
                    continue;
                }
                for &c in topo.polygon(k) {
                    if let VertexRole::Tet { tet } = topo.roles[c as usize] {
                        dmt_pairs.insert((topo.dual_edges[k], tet));
                    }
                }
            }
            assert_eq!(dmt_pairs, mt_pairs, "{name} {split}: same incidences");
        }
    }
}

#[test]
fn dmt_runs_on_grid_meshes_and_closes_its_bodies() {
    let grid = field(21, |p| 0.7 - p.length());
    let exact = 4.0 / 3.0 * std::f64::consts::PI * 0.7f64.powi(3);
    for split in [CubeSplit::Five, CubeSplit::Six] {
        let mesh = tetrahedralize(&grid, split).unwrap();
        for placement in [Placement::Ibc, Placement::Coi] {
            let shell = extract_shell(
                &mesh,
                &grid.values,
                0.0,
                placement,
                Triangulation::default(),
                &NoProgress,
            )
            .unwrap();
            assert_eq!(shell.bodies.len(), 1, "{split} {placement:?}");
            let body = &shell.bodies[0];
            assert!(body.closed && !body.truncated, "{split} {placement:?}");
            let error = (body.volume - exact) / exact;
            eprintln!(
                "DMT {placement:?} split {split}: volume {:+.3}%",
                error * 100.0
            );
            assert!(error.abs() < 0.05, "{split} {placement:?}: {}", body.volume);
        }
    }
}
