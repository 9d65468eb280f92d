//! Property tests of the DMT bodies over random well sets and thresholds: every body is a
//! closed, consistently oriented 2-manifold with positive volume and no degenerate
//! triangles, whatever the placement; the surface counts keep the paper's duality facts.

use glam::DVec3;
use proptest::prelude::*;
use wellmesh::dmt::{self, Placement, Triangulation, measure};
use wellmesh::progress::NoProgress;
use wellmesh::tet;

/// Random vertical wells: `n` collars in a 200 m square, samples every `step` m.
fn well_points(collars: &[(f64, f64)], step: f64, samples: usize) -> Vec<DVec3> {
    collars
        .iter()
        .flat_map(|&(x, y)| (0..samples).map(move |k| DVec3::new(x, y, -(k as f64) * step)))
        .collect()
}

fn placements() -> [Placement; 5] {
    [
        Placement::Ibc,
        Placement::Coi,
        Placement::Midpoint,
        Placement::Distance,
        Placement::Curvature { lattice: 5 },
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn every_body_is_closed_oriented_and_non_degenerate(
        collars in prop::collection::vec((0.0..200.0f64, 0.0..200.0f64), 5..14),
        step in 2.0..10.0f64,
        samples in 4usize..12,
        centre in (50.0..150.0f64, 50.0..150.0f64, -40.0..0.0f64),
        radius in 20.0..120.0f64,
        binary in any::<bool>(),
        threshold in 0.2..0.8f64,
    ) {
        let points = well_points(&collars, step, samples);
        let mesh = match tet::delaunay(&points, &NoProgress) {
            Ok(m) => m,
            // Coplanar collars (all wells in a line) are refused; nothing to contour.
            Err(_) => return Ok(()),
        };
        let c = DVec3::new(centre.0, centre.1, centre.2);
        let values: Vec<f64> = mesh
            .points
            .iter()
            .map(|p| {
                let g = 1.0 - (*p - c).length() / radius;
                if binary { f64::from(u8::from(g >= 0.0)) } else { g }
            })
            .collect();
        let threshold = if binary { 0.5 } else { threshold * 0.5 };
        for (placement, triangulation) in placements()
            .into_iter()
            .flat_map(|p| [(p, Triangulation::MaxMinAngle), (p, Triangulation::Star)])
        {
            let shell = dmt::extract_shell(&mesh, &values, threshold, placement, triangulation, &NoProgress)
                .expect("extraction");
            for body in &shell.bodies {
                prop_assert!(body.closed, "{placement:?}: open body");
                prop_assert!(measure::is_closed_and_oriented(&body.triangles));
                prop_assert!(body.volume > 0.0, "{placement:?}: volume {}", body.volume);
                for t in &body.triangles {
                    let [a, b, c] = t.map(|i| body.positions[i as usize]);
                    let twice_area = (b - a).cross(c - a).length();
                    let longest = (b - a).length().max((c - b).length()).max((a - c).length());
                    prop_assert!(twice_area > 1e-9 * longest * longest, "{placement:?}: degenerate triangle {a} {b} {c}");
                }
            }
            prop_assert_eq!(shell.counts.surface_vertices, shell.counts.active_tets);
            prop_assert_eq!(shell.counts.surface_faces, shell.counts.active_edges);
        }
    }
}
