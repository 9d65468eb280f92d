//! `wellmesh inspect` end to end: text and JSON reports, and errors with exit code 1 that
//! name the file and line.

mod common;

use std::process::Command;

fn wellmesh(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_wellmesh"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

/// A fresh directory for one test's files (removed by the test at its end).
fn scratch_dir(tag: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("wellmesh-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn inspect_json_reports_the_copper_wells() {
    let out = wellmesh(&["inspect", "sample_wells/copper_wells.csv", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["wells"], 13);
    assert_eq!(v["samples"], 335);
    assert_eq!(v["binary"], true);
    assert_eq!(v["unit"], "m");
    assert_eq!(v["report"]["source"], "samples_csv");
}

#[test]
fn inspect_text_reports_drill_hole_tables_and_their_warnings() {
    let out = wellmesh(&[
        "inspect",
        "--collars",
        "sample_wells/tom_zone/collar.csv",
        "--surveys",
        "sample_wells/tom_zone/survey.csv",
        "--intervals",
        "sample_wells/tom_zone/interp.csv",
        "--variable",
        "code",
        "--inside",
        "TSBF,TSGF",
        "--composite",
        "3",
        "--crs",
        "EPSG:32609",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("source        drillholes"), "{text}");
    assert!(text.contains("crs           EPSG:32609"), "{text}");
    assert!(text.contains("values        0 .. 1"), "{text}");
    assert!(text.contains("warning: "), "{text}");
}

#[test]
fn a_malformed_samples_csv_exits_1_naming_file_line_and_column() {
    let dir = scratch_dir("cli");
    let path = dir.join("bad.csv");
    std::fs::write(&path, "well,x,y,z,value\nA,1,2,3,1\nA,1,2,x4,1\n").unwrap();
    let out = wellmesh(&["inspect", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.csv, line 3, column 'z'"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_missing_file_and_an_unknown_kind_exit_1() {
    let out = wellmesh(&["inspect", "no/such/file.csv"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no/such/file.csv"));
    let out = wellmesh(&["inspect", "Cargo.toml"]);
    assert_eq!(out.status.code(), Some(1));
    let out = wellmesh(&["inspect"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no input"));
}

#[test]
fn a_bad_dip_convention_value_is_a_usage_error() {
    let out = wellmesh(&["inspect", "--dip-down", "sideways", "x.csv"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn inspect_reads_a_las_directory_with_a_locations_table() {
    let Some(dir) = common::shared_data("mcmurray_athabasca_las_subset") else {
        return;
    };
    let out = wellmesh(&[
        "inspect",
        "--las",
        dir.join("logs").to_str().unwrap(),
        "--locations",
        dir.join("DERIVED_wells_utm12_kb_tops.csv")
            .to_str()
            .unwrap(),
        "--variable",
        "GR",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["report"]["source"], "las");
    assert_eq!(v["wells"], v["report"]["holes_read"]);
}

#[test]
fn below_detection_flags_reach_the_reader() {
    let dir = scratch_dir("bd");
    let c = dir.join("c.csv");
    let a = dir.join("a.csv");
    std::fs::write(&c, "hole_id,x,y,z\nH,0,0,100\n").unwrap();
    std::fs::write(
        &a,
        "hole_id,from,to,au\nH,0,1,-0.01\nH,1,2,<0.02\nH,2,3,1\n",
    )
    .unwrap();
    let (c, a) = (c.to_str().unwrap(), a.to_str().unwrap());
    let range = |extra: &[&str]| {
        let mut args = vec!["inspect", "--collars", c, "--intervals", a, "--json"];
        args.extend_from_slice(extra);
        let out = wellmesh(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        (
            v["value_range"][0].as_f64().unwrap(),
            v["report"]["below_detection"].as_u64().unwrap(),
        )
    };
    assert_eq!(range(&[]), (0.005, 2));
    assert_eq!(range(&["--below-detection", "zero"]), (0.0, 2));
    assert_eq!(range(&["--negative-values", "value"]), (-0.01, 1));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_coordinate_beyond_any_place_on_earth_exits_1_naming_the_hole() {
    let dir = scratch_dir("cli-far");
    let path = dir.join("far.csv");
    // A northing with a stray exponent.
    std::fs::write(
        &path,
        "well,x,y,z,value\nA,500000,7000000,0,1\nA,500000,7000000,-10,0\nB,500100,7e90,0,1\n",
    )
    .unwrap();
    let out = wellmesh(&["inspect", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(
            "far.csv: hole 'B': a sample position (5.001e5, 7e90, 0e0) lies more than 1e9"
        ),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn wells_in_one_vertical_section_exit_1_saying_so_once() {
    // Three holes on one line in plan view: every sample lies in one vertical plane.
    let dir = scratch_dir("cli-fence");
    let path = dir.join("fence.csv");
    let mut csv = String::from("well,x,y,z,value\n");
    for (w, x) in [("A", 0), ("B", 100), ("C", 200)] {
        for z in [0, -10, -20] {
            csv.push_str(&format!("{w},{x},0,{z},{}\n", u8::from(z == -10)));
        }
    }
    std::fs::write(&path, csv).unwrap();
    let glb = dir.join("fence.glb");
    // The samples' own tetrahedra (the linear interpolant) cannot be built in one plane.
    let out = wellmesh(&[
        "contour",
        path.to_str().unwrap(),
        "--interpolant",
        "linear",
        "-o",
        glb.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.matches("lie in one plane").count(), 1, "{err}");
    assert!(
        err.starts_with("error: tetrahedralization: all points lie in one plane"),
        "{err}"
    );
    // The model between the holes (the default) reaches out of the section, within its
    // ranges, and closes a body there.
    let out = wellmesh(&[
        "contour",
        path.to_str().unwrap(),
        "-o",
        glb.to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::remove_dir_all(&dir).ok();
}
