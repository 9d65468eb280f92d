//! Timings of the grid path (read, split, marching tetrahedra), printed, never asserted.
//! Run: `cargo test --test grid_timing -- --ignored --nocapture` (the test profile is
//! optimised, opt-level 2). The real grids come from the shared corpus (`common`).

mod common;

use std::time::Instant;

use glam::DVec3;
use wellmesh::dmt::mt::marching_tetrahedra;
use wellmesh::grid::{
    CubeSplit, GridVolume, Plot3dVariable, read_nrrd, read_plot3d, tetrahedralize_with_report,
};

fn split_and_contour(name: &str, grid: &GridVolume, threshold: f64) {
    for split in [CubeSplit::Five, CubeSplit::Six] {
        let t0 = Instant::now();
        let (mesh, report) = tetrahedralize_with_report(grid, split).unwrap();
        let split_s = t0.elapsed().as_secs_f64();
        let mesh_volume: f64 = mesh
            .tets()
            .map(|t| {
                let [a, b, c, d] = t.map(|v| mesh.points[v as usize]);
                (b - a).dot((c - a).cross(d - a)) / 6.0
            })
            .sum();
        let t1 = Instant::now();
        let mt = marching_tetrahedra(&mesh, &grid.values, threshold);
        let mt_s = t1.elapsed().as_secs_f64();
        let volume: f64 = mt.bodies.iter().map(|b| b.volume).sum();
        let quality = wellmesh::dmt::mt::shell(
            &mesh,
            &grid.values,
            threshold,
            &wellmesh::progress::NoProgress,
        )
        .unwrap()
        .quality;
        let closed = mt.bodies.iter().filter(|b| b.closed).count();
        println!(
            "{name} split {split}: tets {} (flipped {}, degenerate {} in {} cells) mesh volume {mesh_volume:.6e} split {split_s:.3} s; \
             mt threshold {threshold}: active tets {} edges {} bodies {} ({closed} closed) volume {volume:.6e} in {mt_s:.3} s; \
             triangles {} min angle < 10 deg {:.1}%",
            report.tets,
            report.flipped_tets,
            report.degenerate_tets,
            report.degenerate_cells,
            mt.counts.active_tets,
            mt.counts.active_edges,
            mt.bodies.len(),
            quality.triangles,
            quality.min_angle_under_10deg * 100.0,
        );
    }
}

#[test]
#[ignore = "timing run, prints figures"]
fn timings() {
    let (Some(head), Some(fin)) = (
        common::shared_data("vtk_headsq/quarter.nhdr"),
        common::shared_data("vtk_plot3d_bluntfin_combustor"),
    ) else {
        return;
    };
    let t = Instant::now();
    let head = read_nrrd(&head).unwrap();
    println!(
        "headsq read {:?} in {:.3} s",
        head.dims,
        t.elapsed().as_secs_f64()
    );
    split_and_contour("headsq", &head, 500.0);

    let xyz = std::fs::read(fin.join("bluntfinxyz.bin")).unwrap();
    let q = std::fs::read(fin.join("bluntfinq.bin")).unwrap();
    let t = Instant::now();
    let fin = read_plot3d("fin.xyz", &xyz, "fin.q", &q, Plot3dVariable::Density, 0).unwrap();
    println!(
        "bluntfin read {:?} in {:.3} s, density {:?}",
        fin.dims,
        t.elapsed().as_secs_f64(),
        fin.value_range()
    );
    split_and_contour("bluntfin density", &fin, 1.5);

    // 103^3 cells x 6 = 6.56M tetrahedra: a sphere.
    let n = 104;
    let values: Vec<f64> = (0..n * n * n)
        .map(|i| {
            let p = DVec3::new((i % n) as f64, ((i / n) % n) as f64, (i / (n * n)) as f64);
            -(p - DVec3::splat(51.5)).length_squared()
        })
        .collect();
    let ball = GridVolume::regular("ball", [n; 3], DVec3::ONE, values).unwrap();
    split_and_contour("ball 104^3", &ball, -40.0 * 40.0);
}

#[test]
#[ignore = "timing run, prints figures"]
fn mt_sections() {
    let n = 104;
    let values: Vec<f64> = (0..n * n * n)
        .map(|i| {
            let p = DVec3::new((i % n) as f64, ((i / n) % n) as f64, (i / (n * n)) as f64);
            -(p - DVec3::splat(51.5)).length_squared()
        })
        .collect();
    let ball = GridVolume::regular("ball", [n; 3], DVec3::ONE, values).unwrap();
    let (mesh, _) = tetrahedralize_with_report(&ball, CubeSplit::Six).unwrap();
    let marks: Vec<bool> = ball.values.iter().map(|v| *v >= -1600.0).collect();
    for _ in 0..3 {
        let t = Instant::now();
        let r = wellmesh::dmt::mt::marked_regions(&mesh, &marks);
        println!(
            "marked_regions {:.3} s ({})",
            t.elapsed().as_secs_f64(),
            r.len()
        );
        let t = Instant::now();
        let mt = marching_tetrahedra(&mesh, &ball.values, -1600.0);
        println!(
            "mt {:.3} s ({})",
            t.elapsed().as_secs_f64(),
            mt.bodies.len()
        );
    }
}

/// How often random blanking (10% of points) leaves a non-manifold boundary that a body
/// touches: such bodies are reported `closed: false`.
#[test]
#[ignore = "measurement run, prints figures"]
fn random_blanking_open_body_share() {
    let (mut open, mut total) = (0, 0);
    for seed in 0..300u64 {
        let mut x = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let mut uniform = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 33) as f64 / (1u64 << 31) as f64
        };
        let n = 6 * 6 * 6;
        let values: Vec<f64> = (0..n).map(|_| uniform()).collect();
        let blanked: Vec<bool> = (0..n).map(|_| uniform() < 0.1).collect();
        let points = (0..n)
            .map(|p| DVec3::new((p % 6) as f64, ((p / 6) % 6) as f64, (p / 36) as f64))
            .collect();
        let grid = GridVolume::curvilinear("r", [6, 6, 6], points, values, blanked).unwrap();
        for split in [CubeSplit::Five, CubeSplit::Six] {
            let Ok((mesh, _)) = tetrahedralize_with_report(&grid, split) else {
                continue;
            };
            for body in marching_tetrahedra(&mesh, &grid.values, 0.5).bodies {
                total += 1;
                open += usize::from(!body.closed);
            }
        }
    }
    println!("random 10% blanking on 6^3 grids: {open} of {total} bodies not closed");
}
