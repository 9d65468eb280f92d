//! `wellmesh tetrahedralize`: the one-line report, the VTU file, and clear errors on bad
//! point files.

use std::path::PathBuf;
use std::process::Command;

fn wellmesh() -> Command {
    Command::new(env!("CARGO_BIN_EXE_wellmesh"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wellmesh-tet-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// A 3 x 3 x 3 lattice (27 points, 8 co-spherical cubes) plus one duplicate.
fn lattice_xyz() -> String {
    let mut text = String::from("# x y z\n");
    for i in 0..3 {
        for j in 0..3 {
            for k in 0..3 {
                text.push_str(&format!("{} {} {}\n", 500000 + i * 50, 6500000 + j * 50, k));
            }
        }
    }
    text.push_str("500000 6500000 0\n");
    text
}

fn base64_decode(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let bytes: Vec<u8> = text.bytes().filter(|&c| c != b'=').collect();
    let mut out = Vec::new();
    for chunk in bytes.chunks(4) {
        let mut n = 0u32;
        for (k, &c) in chunk.iter().enumerate() {
            n |= u32::from(value(c)) << (18 - 6 * k);
        }
        for k in 0..chunk.len() - 1 {
            out.push((n >> (16 - 8 * k)) as u8);
        }
    }
    out
}

/// The decoded payload (after the 8-byte size header) of the `DataArray` named `name`.
fn data_array(vtu: &str, name: &str) -> Vec<u8> {
    let start = vtu.find(&format!("Name=\"{name}\"")).unwrap();
    let open = start + vtu[start..].find('>').unwrap() + 1;
    let close = open + vtu[open..].find('<').unwrap();
    let raw = base64_decode(vtu[open..close].trim());
    let size = u64::from_le_bytes(raw[..8].try_into().unwrap()) as usize;
    assert_eq!(raw.len() - 8, size, "size header of {name}");
    raw[8..].to_vec()
}

#[test]
fn tetrahedralize_prints_one_line_and_writes_a_readable_vtu() {
    let input = scratch("lattice.xyz");
    std::fs::write(&input, lattice_xyz()).unwrap();
    let vtu_path = scratch("lattice.vtu");
    let out = wellmesh()
        .args(["tetrahedralize", input.to_str().unwrap(), "-o"])
        .arg(&vtu_path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Piped, as in CI: no progress bar, nothing on standard error.
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 1, "{stdout}");
    let words: Vec<&str> = lines[0].split(' ').collect();
    assert_eq!(words[..3], ["points", "28", "tets"]);
    assert_eq!(words[4], "seconds");
    let tets: usize = words[3].parse().unwrap();
    assert!(words[5].parse::<f64>().unwrap() >= 0.0);

    let vtu = std::fs::read_to_string(&vtu_path).unwrap();
    assert!(vtu.contains(&format!("NumberOfPoints=\"27\" NumberOfCells=\"{tets}\"")));
    let points: Vec<[f64; 3]> = data_array(&vtu, "Points")
        .chunks(24)
        .map(|c| [0, 1, 2].map(|k| f64::from_le_bytes(c[k * 8..k * 8 + 8].try_into().unwrap())))
        .collect();
    let conn: Vec<usize> = data_array(&vtu, "connectivity")
        .chunks(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()) as usize)
        .collect();
    assert_eq!(conn.len(), 4 * tets);
    assert_eq!(data_array(&vtu, "types"), vec![10u8; tets]);
    // Positive volumes that add up to the lattice's box: 100 x 100 x 2 m.
    let mut volume_m3 = 0.0;
    for t in conn.chunks(4) {
        let p = t.iter().map(|&v| points[v]).collect::<Vec<_>>();
        let d = |a: [f64; 3], b: [f64; 3]| [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let (u, v, w) = (d(p[0], p[1]), d(p[0], p[2]), d(p[0], p[3]));
        let vol = (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
            + u[2] * (v[0] * w[1] - v[1] * w[0]))
            / 6.0;
        assert!(vol > 0.0);
        volume_m3 += vol;
    }
    assert!((volume_m3 - 20_000.0).abs() < 1e-6, "{volume_m3}");
}

/// `wellmesh tetrahedralize --json` on `text` written to the scratch file `name`: its
/// JSON line (the run must succeed).
fn tetrahedralize_json(name: &str, text: &str) -> serde_json::Value {
    let input = scratch(name);
    std::fs::write(&input, text).unwrap();
    let out = wellmesh()
        .args(["tetrahedralize", input.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn json_flag_reports_duplicates() {
    let json = tetrahedralize_json("lattice_json.xyz", &lattice_xyz());
    assert_eq!(json["points"], 28);
    assert_eq!(json["distinct_points"], 27);
    assert_eq!(json["duplicates_merged"], 1);
}

#[test]
fn columns_after_x_y_z_are_ignored() {
    // An xyz file with an intensity column: the fourth number is not a coordinate.
    let json = tetrahedralize_json(
        "four_columns.xyz",
        "0 0 0 7\n1 0 0 7\n0 1 0 7\n0 0 1 7\n0 0 0 9\n",
    );
    assert_eq!(json["points"], 5);
    assert_eq!(json["distinct_points"], 4);
    assert_eq!(json["tets"], 1);
}

#[test]
fn csv_with_header_is_read() {
    let input = scratch("points.csv");
    std::fs::write(
        &input,
        "id,X,Y,Z\n1,0,0,0\n2,1,0,0\n3,0,1,0\n4,0,0,1\n5,1,1,1\n",
    )
    .unwrap();
    let out = wellmesh()
        .args(["tetrahedralize", input.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        String::from_utf8(out.stdout)
            .unwrap()
            .starts_with("points 5 tets ")
    );
}

#[test]
fn malformed_and_degenerate_files_fail_with_a_located_message() {
    let cases = [
        (
            "bad.xyz",
            "0 0 0\n1 0 0\n0 1 oops\n",
            "bad.xyz:3: z is not a number",
        ),
        (
            "nan.xyz",
            "0 0 0\n1 0 0\nnan 1 0\n0 0 1\n",
            "nan.xyz:3: x is not finite",
        ),
        // The two usual slips with `.xyz` names: commas, and a header line.
        (
            "commas.xyz",
            "0,0,0\n1,0,0\n0,1,0\n0,0,1\n",
            "commas.xyz:1: x is not a number: \"0,0,0\" (`.xyz` fields are separated by spaces or tabs; for comma-separated points name the file `.csv`)",
        ),
        (
            "header.xyz",
            "# exported\nX Y Z\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n",
            "header.xyz:2: x is not a number: \"X\" (`.xyz` takes no header line: start it with `#`, or use a `.csv` file with columns x,y,z)",
        ),
        (
            "short.xyz",
            "0 0 0\n1 0\n",
            "short.xyz:2: expected 3 numbers",
        ),
        (
            "flat.xyz",
            "0 0 0\n1 0 0\n0 1 0\n1 1 0\n",
            "lie in one plane",
        ),
        ("few.xyz", "0 0 0\n1 0 0\n", "at least 4 distinct points"),
        (
            "range.xyz",
            "0 0 0\n1 0 0\n0 1 0\n0 0 1\n1e300 1e300 1e300\n",
            "coordinates too far apart in magnitude for exact arithmetic: point 1 has 1e0 and point 4 has 1e300",
        ),
        (
            "bad.csv",
            "x,y,z\n0,0,0\n1,zz,0\n",
            "bad.csv:3: y is not a number",
        ),
        (
            "semicolons.csv",
            "0;0;0\n1;0;0\n",
            "semicolons.csv:1: the first row is neither three numbers nor a header naming columns x, y, z (or easting, northing, elevation): \"0;0;0\" (`.csv` fields are separated by commas)",
        ),
        (
            "two_columns.csv",
            "east,north\n0,0\n",
            "two_columns.csv:1: the first row is neither three numbers nor a header naming columns x, y, z (or easting, northing, elevation): \"east,north\"",
        ),
        ("points.ply", "", "unknown point file type"),
    ];
    for (name, text, expected) in cases {
        let input = scratch(name);
        std::fs::write(&input, text).unwrap();
        let out = wellmesh()
            .args(["tetrahedralize", input.to_str().unwrap()])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{name}");
        let stderr = String::from_utf8(out.stderr).unwrap();
        assert!(stderr.contains(expected), "{name}: {stderr}");
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
    }
}
