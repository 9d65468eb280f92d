//! Grid readers on the real data in `../shared/data` and on arbitrary bytes: the real files
//! read as their sources describe them; malformed input is an error, never a panic. The
//! real-data tests skip with a note when the shared corpus is absent (`common`).

mod common;

use std::path::Path;

use glam::DVec3;
use proptest::prelude::*;
use wellmesh::dmt::mt::marching_tetrahedra;
use wellmesh::grid::{
    CubeSplit, Endian, GridError, Plot3dVariable, ScalarType, parse_nrrd, read_nrrd, read_plot3d,
    read_raw, tetrahedralize_with_report,
};

use common::shared_data;

fn bytes(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn headsq_reads_as_its_sources_describe() {
    let Some(head) = shared_data("vtk_headsq") else {
        return;
    };
    let grid = read_nrrd(&head.join("quarter.nhdr")).unwrap();
    assert_eq!(grid.dims, [64, 64, 93]);
    assert_eq!(grid.value_range(), Some((0.0, 3926.0)));
    let extent = grid.points[grid.len() - 1] - grid.points[0];
    assert!(extent.abs_diff_eq(DVec3::new(63.0 * 3.2, 63.0 * 3.2, 92.0 * 1.5), 1e-9));
    assert!(
        grid.points[0].abs_diff_eq(-extent / 2.0, 1e-9),
        "centred on its bbox"
    );
    // Slice k holds file quarter.(k+1): its first sample is the file's first int16.
    let slice7 = bytes(&head.join("quarter.8"));
    let first = i16::from_le_bytes([slice7[0], slice7[1]]) as f64;
    assert_eq!(grid.values[grid.index(0, 0, 7)], first);
    let last = i16::from_le_bytes([slice7[8190], slice7[8191]]) as f64;
    assert_eq!(grid.values[grid.index(63, 63, 7)], last);
}

#[test]
fn headsq_skin_is_closed_on_both_splits() {
    let Some(head) = shared_data("vtk_headsq") else {
        return;
    };
    let grid = read_nrrd(&head.join("quarter.nhdr")).unwrap();
    for split in [CubeSplit::Five, CubeSplit::Six] {
        let (mesh, report) = tetrahedralize_with_report(&grid, split).unwrap();
        assert_eq!(report.tets, 63 * 63 * 92 * split.tets_per_cell());
        let mt = marching_tetrahedra(&mesh, &grid.values, 500.0);
        assert!(!mt.bodies.is_empty());
        assert!(mt.bodies.iter().all(|b| b.closed), "{split}");
        let volume: f64 = mt.bodies.iter().map(|b| b.volume).sum();
        // Counting voxels at or above the threshold estimates the same volume.
        let voxels = grid.values.iter().filter(|v| **v >= 500.0).count() as f64;
        let estimate = voxels * 3.2 * 3.2 * 1.5;
        assert!(
            (volume - estimate).abs() / estimate < 0.02,
            "{split}: {volume} vs voxel estimate {estimate}"
        );
    }
}

#[test]
fn blunt_fin_reads_with_its_padding_and_big_endian_layout() {
    let Some(fin) = shared_data("vtk_plot3d_bluntfin_combustor") else {
        return;
    };
    let xyz = bytes(&fin.join("bluntfinxyz.bin"));
    let q = bytes(&fin.join("bluntfinq.bin"));
    let grid = read_plot3d(
        "bluntfinxyz.bin",
        &xyz,
        "bluntfinq.bin",
        &q,
        Plot3dVariable::Density,
        0,
    )
    .unwrap();
    assert_eq!(grid.dims, [40, 32, 32]);
    assert!(
        grid.warnings
            .iter()
            .any(|w| w.contains("484 trailing zero bytes")),
        "{:?}",
        grid.warnings
    );
    // The first x coordinate stored (big-endian f32 at byte 12) is point (0, 0, 0).
    let x0 = f32::from_be_bytes([xyz[12], xyz[13], xyz[14], xyz[15]]) as f64;
    assert_eq!(grid.points[0].x + grid.origin.x, x0);
    let (lo, hi) = grid.value_range().unwrap();
    assert!(lo > 0.0 && hi < 10.0, "density {lo}..{hi}");
    let (mesh, report) = tetrahedralize_with_report(&grid, CubeSplit::Six).unwrap();
    assert_eq!(report.tets + report.degenerate_tets, 39 * 31 * 31 * 6);
    let mt = marching_tetrahedra(&mesh, &grid.values, (lo + hi) / 2.0);
    assert!(mt.bodies.iter().all(|b| b.closed));

    let speed = read_plot3d(
        "bluntfinxyz.bin",
        &xyz,
        "bluntfinq.bin",
        &q,
        Plot3dVariable::VelocityMagnitude,
        0,
    )
    .unwrap();
    assert!(speed.values.iter().all(|v| v.is_finite() && *v >= 0.0));
    let mach = read_plot3d(
        "bluntfinxyz.bin",
        &xyz,
        "bluntfinq.bin",
        &q,
        Plot3dVariable::Mach,
        0,
    )
    .unwrap();
    // Free-stream Mach number in the q header (fsmach) is 2.95: the flow is supersonic.
    let fsmach = f32::from_be_bytes([q[12], q[13], q[14], q[15]]) as f64;
    assert!((fsmach - 2.95).abs() < 1e-6);
    let max_mach = mach.value_range().unwrap().1;
    assert!(max_mach > 2.5 && max_mach < 3.5, "max Mach {max_mach}");
}

#[test]
fn combustor_pressure_is_refused_because_its_energy_is_all_zero() {
    let Some(fin) = shared_data("vtk_plot3d_bluntfin_combustor") else {
        return;
    };
    let xyz = bytes(&fin.join("combxyz.bin"));
    let q = bytes(&fin.join("combq.bin"));
    let grid = read_plot3d(
        "combxyz.bin",
        &xyz,
        "combq.bin",
        &q,
        Plot3dVariable::Density,
        0,
    )
    .unwrap();
    assert_eq!(grid.dims, [57, 33, 25]);
    let err = read_plot3d(
        "combxyz.bin",
        &xyz,
        "combq.bin",
        &q,
        Plot3dVariable::Pressure,
        0,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("combq.bin") && err.contains("energy"), "{err}");
    let err = read_plot3d(
        "combxyz.bin",
        &xyz,
        "bluntfinq.bin",
        &bytes(&fin.join("bluntfinq.bin")),
        Plot3dVariable::Density,
        0,
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("bluntfinq.bin") && err.contains("dims"),
        "{err}"
    );
}

#[test]
fn truncated_real_files_are_errors_naming_them() {
    let Some(fin) = shared_data("vtk_plot3d_bluntfin_combustor") else {
        return;
    };
    let Some(head) = shared_data("vtk_headsq") else {
        return;
    };
    let xyz = bytes(&fin.join("bluntfinxyz.bin"));
    let q = bytes(&fin.join("bluntfinq.bin"));
    let err = read_plot3d(
        "fin.xyz",
        &xyz[..xyz.len() / 2],
        "fin.q",
        &q,
        Plot3dVariable::Density,
        0,
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("fin.xyz") && err.contains("truncated"),
        "{err}"
    );

    let header = bytes(&head.join("quarter.nhdr"));
    let mut open = |name: &str| -> Result<Vec<u8>, GridError> {
        let mut content = bytes(&head.join(name));
        if name == "quarter.50" {
            content.truncate(100);
        }
        Ok(content)
    };
    let err = parse_nrrd("quarter.nhdr", &header, &mut open)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("quarter.nhdr") && err.contains("bytes"),
        "{err}"
    );
}

fn no_files(name: &str) -> Result<Vec<u8>, GridError> {
    Err(GridError::Io {
        file: name.to_string(),
        source: std::io::Error::from(std::io::ErrorKind::NotFound),
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn nrrd_never_panics_on_arbitrary_bytes(body in prop::collection::vec(any::<u8>(), 0..400)) {
        let _ = parse_nrrd("any.nrrd", &body, &mut no_files);
        let mut with_magic = b"NRRD0004\n".to_vec();
        with_magic.extend(&body);
        let _ = parse_nrrd("any.nrrd", &with_magic, &mut no_files);
    }

    #[test]
    fn nrrd_never_panics_on_mangled_headers(
        lines in prop::collection::vec(prop::sample::select(vec![
            "dimension: 3", "dimension: 2", "sizes: 2 2 2", "sizes: 4000000000 4000000000 9",
            "sizes: 0 2 2", "type: short", "type: double", "type: block", "endian: big",
            "encoding: raw", "encoding: gzip", "encoding: ascii", "encoding: bzip2",
            "spacings: 1 nan 2", "spacings: 1 2 3", "space directions: (1,0,0) (0,1,0) none",
            "space directions: (1,0,0) (0,1,0) (0,0,1)", "space origin: (1,2)", "byte skip: -1",
            "line skip: 9", "data file: q.%d 1 999999999 1", "data file: q.%d 5 1 1",
            "data file: LIST", "x.raw", "data file: %d%d 1 2 1", "key:=value", "# comment", "junk",
        ]), 0..14),
        data in prop::collection::vec(any::<u8>(), 0..80),
    ) {
        let mut bytes = b"NRRD0004\n".to_vec();
        for line in &lines {
            bytes.extend(line.as_bytes());
            bytes.push(b'\n');
        }
        bytes.push(b'\n');
        bytes.extend(&data);
        let payload = data.clone();
        let mut open = |_: &str| Ok(payload.clone());
        let _ = parse_nrrd("mangled.nrrd", &bytes, &mut open);
    }

    #[test]
    fn plot3d_never_panics_on_arbitrary_or_mangled_bytes(
        xyz in prop::collection::vec(any::<u8>(), 0..300),
        q in prop::collection::vec(any::<u8>(), 0..300),
        dims in prop::collection::vec(1i32..4, 3),
        cut in 0usize..200,
    ) {
        let _ = read_plot3d("x", &xyz, "q", &q, Plot3dVariable::Mach, 0);
        // A plausible header followed by arbitrary (often too short) data.
        let mut head: Vec<u8> = dims.iter().flat_map(|d| d.to_be_bytes()).collect();
        head.extend(&xyz);
        let mut qhead: Vec<u8> = dims.iter().flat_map(|d| d.to_be_bytes()).collect();
        qhead.extend(&q);
        qhead.truncate(qhead.len().saturating_sub(cut));
        let _ = read_plot3d("x", &head, "q", &qhead, Plot3dVariable::Pressure, 1);
        let _ = read_plot3d("x", &head, "q", &qhead, Plot3dVariable::Density, 0);
    }

    #[test]
    fn raw_never_panics_and_accepts_only_exact_sizes(
        bytes in prop::collection::vec(any::<u8>(), 0..200),
        dims in prop::collection::vec(0usize..6, 3),
        float in any::<bool>(),
    ) {
        let dims = [dims[0], dims[1], dims[2]];
        let scalar = if float { ScalarType::F32 } else { ScalarType::U16 };
        let result = read_raw("v.raw", &bytes, dims, DVec3::ONE, scalar, Endian::Big);
        let exact = dims.iter().all(|d| *d >= 2) && bytes.len() == dims.iter().product::<usize>() * scalar.size();
        prop_assert_eq!(result.is_ok(), exact);
    }
}
