//! Exporters on hand-built results: the GLB read back with the `gltf` crate, the tileset's
//! placement on the globe, GeoJSON level plans, OBJ and VTU.
//!
//! The GLBs written here are also kept under `target/tmp/export/` so that the Khronos
//! validator (`node viewer/test/validate.mjs target/tmp/export/*.glb`) checks them.

use std::collections::HashMap;

use glam::DVec3;
use serde_json::Value;
use wellmesh::contour::{BodySummary, ContourResult, ShellSummary, Summary, UnknownMode};
use wellmesh::dmt::{Body, Quality, Shell, ShellCounts};
use wellmesh::export::{
    ExportError, Levels, OutputOptions, all_outputs, enu_frame, geojson_levels, glb, obj,
    tileset_json, vtu,
};
use wellmesh::wells::{ReadReport, SampleSet, Well};

/// UTM zone 33N coordinates of the local origin: a body at (5e5, 7e6).
const ORIGIN: [f64; 3] = [500_000.0, 7_000_000.0, 300.0];

/// An icosphere of `radius` around local `centre`, subdivided `levels` times; triangles
/// counter-clockwise from outside. With `inward`, the winding is reversed (a cavity).
fn icosphere(centre: DVec3, radius: f64, levels: u32, inward: bool) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut unit: Vec<DVec3> = [
        (-1.0, phi, 0.0),
        (1.0, phi, 0.0),
        (-1.0, -phi, 0.0),
        (1.0, -phi, 0.0),
        (0.0, -1.0, phi),
        (0.0, 1.0, phi),
        (0.0, -1.0, -phi),
        (0.0, 1.0, -phi),
        (phi, 0.0, -1.0),
        (phi, 0.0, 1.0),
        (-phi, 0.0, -1.0),
        (-phi, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, unit: &mut Vec<DVec3>| -> u32 {
            *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                unit.push(((unit[a as usize] + unit[b as usize]) / 2.0).normalize());
                unit.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for [a, b, c] in faces {
            let (ab, bc, ca) = (
                mid(a, b, &mut unit),
                mid(b, c, &mut unit),
                mid(c, a, &mut unit),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    for f in &mut faces {
        let [a, b, c] = f.map(|i| unit[i as usize]);
        let outward = (b - a).cross(c - a).dot(a + b + c) > 0.0;
        if outward == inward {
            f.swap(1, 2);
        }
    }
    (unit.iter().map(|&u| centre + u * radius).collect(), faces)
}

fn measure(positions: &[DVec3], triangles: &[[u32; 3]]) -> (f64, f64) {
    triangles.iter().fold((0.0, 0.0), |(v, a), t| {
        let [p, q, r] = t.map(|i| positions[i as usize]);
        (
            v + p.dot(q.cross(r)) / 6.0,
            a + (q - p).cross(r - p).length() / 2.0,
        )
    })
}

fn body(parts: &[(Vec<DVec3>, Vec<[u32; 3]>)]) -> Body {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for (p, t) in parts {
        let first = positions.len() as u32;
        positions.extend_from_slice(p);
        triangles.extend(t.iter().map(|t| t.map(|i| i + first)));
    }
    let (volume, area) = measure(&positions, &triangles);
    let bbox = positions.iter().fold(
        [DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)],
        |[lo, hi], &p| [lo.min(p), hi.max(p)],
    );
    Body {
        positions,
        triangles,
        volume,
        area,
        closed: true,
        truncated: false,
        bbox,
        region: 0,
        mt_fallback: false,
    }
}

fn samples(crs: Option<&str>) -> SampleSet {
    let mut wells = Vec::new();
    let mut points = Vec::new();
    let mut values = Vec::new();
    let mut well_of = Vec::new();
    for (w, (x, y)) in [(-40.0, -40.0), (0.0, 0.0), (40.0, 30.0)]
        .into_iter()
        .enumerate()
    {
        let collar = DVec3::new(x, y, 100.0);
        wells.push(Well {
            id: format!("DH{}", w + 1),
            collar,
            trace: vec![collar, DVec3::new(x, y, -100.0)],
        });
        for k in 0..20 {
            points.push(DVec3::new(x, y, 95.0 - 10.0 * k as f64));
            values.push(if k == 3 {
                None
            } else {
                Some((k % 7) as f64 / 6.0)
            });
            well_of.push(w as u32);
        }
    }
    SampleSet {
        origin: DVec3::from(ORIGIN),
        crs: crs.map(str::to_owned),
        unit: "m".to_owned(),
        wells,
        points,
        values,
        well_of,
        report: ReadReport::default(),
    }
}

/// A result with the shells `(threshold, bodies)`, its summary computed from them.
fn result(shells: Vec<(f64, Vec<Body>)>, crs: Option<&str>) -> ContourResult {
    let origin = DVec3::from(ORIGIN);
    let shell_summaries = shells
        .iter()
        .map(|(threshold, bodies)| ShellSummary {
            threshold: *threshold,
            volume: bodies.iter().map(|b| b.volume).sum(),
            area: bodies.iter().map(|b| b.area).sum(),
            bodies: bodies
                .iter()
                .map(|b| BodySummary {
                    volume: b.volume,
                    area: b.area,
                    closed: b.closed,
                    truncated: b.truncated,
                    mt_fallback: b.mt_fallback,
                    bbox: [
                        (b.bbox[0] + origin).to_array(),
                        (b.bbox[1] + origin).to_array(),
                    ],
                    resource: None,
                })
                .collect(),
            counts: ShellCounts::default(),
            quality: Quality::default(),
            filtered_bodies: 0,
            filtered_volume: 0.0,
            volume_range: None,
            resource: None,
            simplified: None,
        })
        .collect();
    let summary = Summary {
        method: "ibc".to_owned(),
        interpolant: "linear".into(),
        model: None,
        min_volume: None,
        relax_sweeps: 0,
        origin: ORIGIN,
        crs: crs.map(str::to_owned),
        unit: "m".to_owned(),
        unknown: UnknownMode::Drop,
        binary: false,
        counts: serde_json::Map::new(),
        shells: shell_summaries,
        report: None,
        warnings: Vec::new(),
    };
    ContourResult {
        summary,
        shells: shells
            .into_iter()
            .map(|(threshold, bodies)| Shell {
                threshold,
                bodies,
                counts: ShellCounts::default(),
                quality: Quality::default(),
                point_touches: 0,
            })
            .collect(),
        samples: samples(crs),
    }
}

/// Two nested shells: a large sphere at 0.3 around two small ones at 0.7.
fn nested() -> ContourResult {
    result(
        vec![
            (0.3, vec![body(&[icosphere(DVec3::ZERO, 60.0, 3, false)])]),
            (
                0.7,
                vec![
                    body(&[icosphere(DVec3::new(-20.0, 5.0, 3.0), 15.0, 2, false)]),
                    body(&[icosphere(DVec3::new(25.0, -10.0, -5.0), 12.5, 2, false)]),
                ],
            ),
        ],
        Some("EPSG:32633"),
    )
}

fn keep(name: &str, bytes: &[u8]) {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("export");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(name), bytes).unwrap();
}

/// `value` is the JSON number `expected` (serde_json's default parser may be one ulp off
/// the shortest representation the writer produced).
fn assert_number(value: &Value, expected: f64) {
    let got = value
        .as_f64()
        .unwrap_or_else(|| panic!("{value} is not a number"));
    assert!(
        (got - expected).abs() <= 1e-14 * expected.abs().max(1.0),
        "{got} != {expected}"
    );
}

fn extras(raw: &gltf::json::Extras) -> Value {
    serde_json::from_str(raw.as_ref().expect("extras present").get()).unwrap()
}

#[test]
fn the_glb_reads_back_with_its_meshes_vertices_and_extras() {
    let result = nested();
    let bytes = glb(&result, &OutputOptions::default()).unwrap();
    keep("nested.glb", &bytes);
    keep(
        "nested.summary.json",
        &wellmesh::export::summary_json(&result.summary).unwrap(),
    );
    let (document, buffers, _) = gltf::import_slice(&bytes).unwrap();

    // Scene extras: the origin, CRS and unit.
    let scene = document.default_scene().unwrap();
    let scene_extras = extras(scene.extras());
    for (k, &v) in ORIGIN.iter().enumerate() {
        assert_number(&scene_extras["origin"][k], v);
    }
    assert_eq!(scene_extras["crs"], "EPSG:32633");
    assert_eq!(scene_extras["unit"], "m");

    // Root nodes: two shells, the drill holes and the samples.
    let roots: Vec<_> = scene.nodes().collect();
    let names: Vec<_> = roots.iter().map(|n| n.name().unwrap().to_owned()).collect();
    assert_eq!(
        names,
        [
            "shell 1 threshold 0.3",
            "shell 2 threshold 0.7",
            "drill holes",
            "samples"
        ]
    );
    // Three body meshes, one line mesh, one point mesh.
    assert_eq!(document.meshes().count(), 5);

    for (s, shell_node) in roots[..2].iter().enumerate() {
        let shell = &result.shells[s];
        let shell_summary = &result.summary.shells[s];
        let shell_extras = extras(shell_node.extras());
        assert_number(&shell_extras["threshold"], shell.threshold);
        assert_number(&shell_extras["volume"], shell_summary.volume);
        let children: Vec<_> = shell_node.children().collect();
        assert_eq!(children.len(), shell.bodies.len());
        for (b, node) in children.iter().enumerate() {
            let body = &shell.bodies[b];
            let expected = &shell_summary.bodies[b];
            assert_eq!(
                node.name().unwrap(),
                format!(
                    "shell {} threshold {} body {}",
                    s + 1,
                    shell.threshold,
                    b + 1
                )
            );
            let mesh = node.mesh().unwrap();
            for e in [extras(node.extras()), extras(mesh.extras())] {
                assert_number(&e["volume"], expected.volume);
                assert_number(&e["area"], expected.area);
                assert_number(&e["threshold"], shell.threshold);
                assert_eq!(e["closed"], true);
                assert_eq!(e["truncated"], false);
                assert_eq!(e["mt_fallback"], false);
                for (k, corner) in expected.bbox.iter().enumerate() {
                    for (c, &v) in corner.iter().enumerate() {
                        assert_number(&e["bbox"][k][c], v);
                    }
                }
            }
            let primitive = mesh.primitives().next().unwrap();
            assert_eq!(primitive.mode(), gltf::mesh::Mode::Triangles);
            let reader = primitive.reader(|buffer| Some(&buffers[buffer.index()]));
            assert_eq!(
                reader.read_positions().unwrap().count(),
                body.positions.len()
            );
            assert_eq!(
                reader.read_indices().unwrap().into_u32().count(),
                3 * body.triangles.len()
            );
            for n in reader.read_normals().unwrap() {
                let length = DVec3::from(n.map(f64::from)).length();
                assert!((length - 1.0).abs() < 1e-6, "normal length {length}");
            }
        }
    }
    // The outer shell is translucent, the inner one opaque.
    let alpha_modes: Vec<_> = document.materials().map(|m| m.alpha_mode()).collect();
    assert_eq!(alpha_modes[0], gltf::material::AlphaMode::Blend);
    assert_eq!(alpha_modes[1], gltf::material::AlphaMode::Opaque);

    let holes = roots[2].mesh().unwrap().primitives().next().unwrap();
    assert_eq!(holes.mode(), gltf::mesh::Mode::Lines);
    let points = roots[3].mesh().unwrap().primitives().next().unwrap();
    assert_eq!(points.mode(), gltf::mesh::Mode::Points);
    let reader = points.reader(|buffer| Some(&buffers[buffer.index()]));
    assert_eq!(reader.read_positions().unwrap().count(), 60);
}

/// Reads every body mesh of a GLB back as f64 input coordinates (origin added, axes turned
/// back to x east, y north, z up) with its triangles.
fn bodies_in_input_coordinates(bytes: &[u8]) -> Vec<(Vec<DVec3>, Vec<[u32; 3]>)> {
    let (document, buffers, _) = gltf::import_slice(bytes).unwrap();
    let scene = document.default_scene().unwrap();
    let origin: [f64; 3] =
        serde_json::from_value(extras(scene.extras())["origin"].clone()).unwrap();
    let origin = DVec3::from(origin);
    let mut out = Vec::new();
    for mesh in document.meshes() {
        let primitive = mesh.primitives().next().unwrap();
        if primitive.mode() != gltf::mesh::Mode::Triangles {
            continue;
        }
        let reader = primitive.reader(|buffer| Some(&buffers[buffer.index()]));
        let positions = reader
            .read_positions()
            .unwrap()
            .map(|[e, u, s]| origin + DVec3::new(e as f64, -s as f64, u as f64))
            .collect();
        let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
        let triangles = indices.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        out.push((positions, triangles));
    }
    out
}

#[test]
fn every_glb_body_is_watertight_outward_and_measures_as_the_summary_says() {
    let result = nested();
    let bytes = glb(&result, &OutputOptions::default()).unwrap();
    let read = bodies_in_input_coordinates(&bytes);
    let expected: Vec<&BodySummary> = result
        .summary
        .shells
        .iter()
        .flat_map(|s| &s.bodies)
        .collect();
    assert_eq!(read.len(), expected.len());
    for ((positions, triangles), summary) in read.iter().zip(expected) {
        // Every directed edge appears once and its reverse once: closed and consistently
        // wound.
        let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
        for t in triangles {
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &directed {
            assert_eq!(n, 1, "edge {a}-{b} used {n} times in one direction");
            assert_eq!(directed.get(&(b, a)), Some(&1), "edge {a}-{b} has no twin");
        }
        // Volume and area, measured about the body's first vertex to keep f64 precise.
        let o = positions[0];
        let local: Vec<DVec3> = positions.iter().map(|&p| p - o).collect();
        let (volume, area) = measure(&local, triangles);
        assert!(volume > 0.0, "outward orientation gives a positive volume");
        assert!((volume - summary.volume).abs() < 1e-5 * summary.volume);
        assert!((area - summary.area).abs() < 1e-5 * summary.area);
    }
}

#[test]
fn a_body_at_utm_coordinates_keeps_millimetre_vertex_precision() {
    let result = nested();
    let bytes = glb(&result, &OutputOptions::default()).unwrap();
    let read = bodies_in_input_coordinates(&bytes);
    let origin = DVec3::from(ORIGIN);
    let written = result.shells.iter().flat_map(|s| &s.bodies);
    let mut worst: f64 = 0.0;
    for ((positions, _), body) in read.iter().zip(written) {
        for (p, local) in positions.iter().zip(&body.positions) {
            worst = worst.max((*p - (origin + *local)).abs().max_element());
        }
    }
    assert!(worst < 1e-3, "worst vertex error {worst} m");
}

#[test]
fn wells_are_left_out_on_request() {
    let result = nested();
    let options = OutputOptions {
        well_traces: false,
        well_samples: false,
        ..OutputOptions::default()
    };
    let bytes = glb(&result, &options).unwrap();
    keep("no-wells.glb", &bytes);
    let document = gltf::Gltf::from_slice(&bytes).unwrap();
    assert_eq!(document.meshes().count(), 3);
    assert!(document.meshes().all(|m| {
        m.primitives()
            .all(|p| p.mode() == gltf::mesh::Mode::Triangles)
    }));
}

#[test]
fn a_single_shell_is_opaque_and_an_empty_shell_has_no_node() {
    let result = result(
        vec![
            (0.5, vec![body(&[icosphere(DVec3::ZERO, 10.0, 1, false)])]),
            (0.9, vec![]),
        ],
        None,
    );
    let bytes = glb(&result, &OutputOptions::default()).unwrap();
    keep("single.glb", &bytes);
    let document = gltf::Gltf::from_slice(&bytes).unwrap();
    let scene = document.default_scene().unwrap();
    assert_eq!(scene.nodes().count(), 3, "one shell, drill holes, samples");
    assert_eq!(extras(scene.extras())["crs"], Value::Null);
    let first = document.materials().next().unwrap();
    assert_eq!(first.alpha_mode(), gltf::material::AlphaMode::Opaque);
}

#[test]
fn a_summary_that_does_not_match_the_shells_is_an_error() {
    let mut result = nested();
    result.summary.shells[1].bodies.pop();
    let err = glb(&result, &OutputOptions::default()).unwrap_err();
    assert!(matches!(err, ExportError::Inconsistent(_)), "{err}");
    assert!(err.to_string().contains("shell 2"), "{err}");

    let mut result = nested();
    result.shells[0].bodies[0].triangles.push([0, 1, 1_000_000]);
    assert!(matches!(obj(&result), Err(ExportError::Inconsistent(_))));
    let mut result = nested();
    result.shells[0].bodies[0].positions[0].x = f64::NAN;
    assert!(matches!(vtu(&result), Err(ExportError::NonFinite(_))));
}

/// Latitude (radians) whose WGS84 meridian arc, times UTM's scale 0.9996, is `northing`:
/// the series of the meridian arc, inverted by Newton's method. Independent of proj4rs.
fn utm_latitude_on_central_meridian(northing: f64) -> f64 {
    let a = 6_378_137.0;
    let f = 1.0 / 298.257_223_563;
    let e2: f64 = f * (2.0 - f);
    let (e4, e6) = (e2 * e2, e2 * e2 * e2);
    let arc = |phi: f64| {
        a * ((1.0 - e2 / 4.0 - 3.0 * e4 / 64.0 - 5.0 * e6 / 256.0) * phi
            - (3.0 * e2 / 8.0 + 3.0 * e4 / 32.0 + 45.0 * e6 / 1024.0) * (2.0 * phi).sin()
            + (15.0 * e4 / 256.0 + 45.0 * e6 / 1024.0) * (4.0 * phi).sin()
            - (35.0 * e6 / 3072.0) * (6.0 * phi).sin())
    };
    let target = northing / 0.9996;
    let mut phi = target / a;
    for _ in 0..20 {
        let derivative = (arc(phi + 1e-7) - arc(phi - 1e-7)) / 2e-7;
        phi -= (arc(phi) - target) / derivative;
    }
    phi
}

fn ecef(lon: f64, lat: f64, h: f64) -> DVec3 {
    let a = 6_378_137.0;
    let f = 1.0 / 298.257_223_563;
    let e2 = f * (2.0 - f);
    let n = a / (1.0 - e2 * lat.sin().powi(2)).sqrt();
    DVec3::new(
        (n + h) * lat.cos() * lon.cos(),
        (n + h) * lat.cos() * lon.sin(),
        (n * (1.0 - e2) + h) * lat.sin(),
    )
}

#[test]
fn the_tileset_places_the_origin_at_its_utm_position_on_the_globe() {
    // On UTM 33N's central meridian (15 deg E): easting 500000, northing 7000000.
    let frame = enu_frame(ORIGIN, "EPSG:32633").unwrap();
    let lat = utm_latitude_on_central_meridian(ORIGIN[1]);
    assert!((frame.lon_deg - 15.0).abs() < 1e-9);
    assert!(
        (frame.lat_deg - lat.to_degrees()).abs() < 1e-8,
        "{}",
        frame.lat_deg
    );
    let expected = ecef(15f64.to_radians(), lat, ORIGIN[2]);
    let at_origin = frame.apply(DVec3::ZERO);
    assert!(
        (at_origin - expected).length() < 0.01,
        "{at_origin} vs {expected}"
    );

    // On the equator the origin is at a known ECEF point.
    let equator = enu_frame([500_000.0, 0.0, 0.0], "EPSG:32633").unwrap();
    let a = 6_378_137.0;
    let expected = DVec3::new(
        a * 15f64.to_radians().cos(),
        a * 15f64.to_radians().sin(),
        0.0,
    );
    assert!((equator.apply(DVec3::ZERO) - expected).length() < 0.01);

    // 1 km of grid northing is 1 km / 0.9996 on the ground along the central meridian,
    // and a local "up" metre is a metre along the ellipsoid normal.
    let north = frame.apply(DVec3::new(0.0, 1000.0, 0.0));
    let lat_1km = utm_latitude_on_central_meridian(ORIGIN[1] + 1000.0);
    let expected_north = ecef(15f64.to_radians(), lat_1km, ORIGIN[2]);
    assert!(
        (north - expected_north).length() < 0.2,
        "{}",
        (north - expected_north).length()
    );
    let up = frame.apply(DVec3::Z) - at_origin;
    assert!((up.length() - 1.0).abs() < 1e-9);
    assert!(up.dot(at_origin.normalize()) > 0.99);
}

#[test]
fn the_tileset_points_at_the_glb_and_bounds_the_bodies() {
    let result = nested();
    let bytes = tileset_json(&result, "nested.glb").unwrap();
    keep("tileset.json", &bytes);
    let tileset: Value = serde_json::from_slice(&bytes).unwrap();
    assert_eq!(tileset["asset"]["version"], "1.1");
    let root = &tileset["root"];
    assert_eq!(root["content"]["uri"], "nested.glb");
    let transform: Vec<f64> = serde_json::from_value(root["transform"].clone()).unwrap();
    let frame = enu_frame(ORIGIN, "EPSG:32633").unwrap();
    for (got, expected) in transform.iter().zip(frame.matrix) {
        assert!((got - expected).abs() <= 1e-14 * expected.abs().max(1.0));
    }
    let bbox: Vec<f64> = serde_json::from_value(root["boundingVolume"]["box"].clone()).unwrap();
    // The wells reach 100 m above and below the origin; the large sphere has a 60 m radius.
    let expected = [
        0.0, 0.0, 0.0, 60.0, 0.0, 0.0, 0.0, 60.0, 0.0, 0.0, 0.0, 100.0,
    ];
    for (got, expected) in bbox.iter().zip(expected) {
        assert!((got - expected).abs() < 1e-9, "{bbox:?}");
    }

    let no_crs = result_without_crs();
    assert!(matches!(
        tileset_json(&no_crs, "glb"),
        Err(ExportError::NoCrs)
    ));
}

fn result_without_crs() -> ContourResult {
    result(
        vec![(0.5, vec![body(&[icosphere(DVec3::ZERO, 10.0, 1, false)])])],
        None,
    )
}

fn polygons(geojson: &Value) -> Vec<(&Value, Vec<Vec<[f64; 3]>>)> {
    geojson["features"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            assert_eq!(f["geometry"]["type"], "Polygon");
            (
                &f["properties"],
                serde_json::from_value(f["geometry"]["coordinates"].clone()).unwrap(),
            )
        })
        .collect()
}

fn ring_area(ring: &[[f64; 3]]) -> f64 {
    let o = ring[0];
    ring.windows(2)
        .map(|w| ((w[0][0] - o[0]) * (w[1][1] - o[1]) - (w[1][0] - o[0]) * (w[0][1] - o[1])) / 2.0)
        .sum()
}

#[test]
fn a_sphere_cut_at_its_equator_is_a_circle_of_the_right_area() {
    let radius = 50.0;
    let centre = DVec3::new(10.0, -20.0, 30.0);
    let result = result(
        vec![(0.5, vec![body(&[icosphere(centre, radius, 4, false)])])],
        Some("EPSG:32633"),
    );
    let level = ORIGIN[2] + centre.z + 1e-3;
    let bytes = geojson_levels(&result, &Levels::At(vec![level])).unwrap();
    keep("sphere-equator.geojson", &bytes);
    let geojson: Value = serde_json::from_slice(&bytes).unwrap();
    assert_eq!(
        geojson["crs"]["properties"]["name"],
        "urn:ogc:def:crs:EPSG::32633"
    );
    let polys = polygons(&geojson);
    assert_eq!(polys.len(), 1);
    let (properties, rings) = &polys[0];
    assert_eq!(properties["level"], level);
    assert_eq!(rings.len(), 1, "no holes");
    let ring = &rings[0];
    assert_eq!(ring.first(), ring.last(), "closed ring");
    let exact = std::f64::consts::PI * radius * radius;
    let area = ring_area(ring);
    assert!(area > 0.0, "outer ring counter-clockwise");
    assert!((area - exact).abs() < 0.01 * exact, "{area} vs {exact}");
    assert!((properties["area"].as_f64().unwrap() - area).abs() < 1e-6 * area);
    // In input coordinates: every point about `radius` from the sphere's centre.
    for p in ring {
        let d =
            ((p[0] - ORIGIN[0] - centre.x).powi(2) + (p[1] - ORIGIN[1] - centre.y).powi(2)).sqrt();
        assert!(d <= radius + 1e-6 && d > 0.98 * radius, "{d}");
        assert_eq!(p[2], level);
    }
}

#[test]
fn a_hollow_sphere_cut_at_its_equator_is_a_ring_with_a_hole() {
    let (outer, inner) = (40.0, 20.0);
    let hollow = body(&[
        icosphere(DVec3::ZERO, outer, 4, false),
        icosphere(DVec3::ZERO, inner, 4, true),
    ]);
    let result = result(vec![(0.5, vec![hollow])], Some("EPSG:32633"));
    let bytes = geojson_levels(&result, &Levels::At(vec![ORIGIN[2] + 0.01])).unwrap();
    keep("hollow-equator.geojson", &bytes);
    let geojson: Value = serde_json::from_slice(&bytes).unwrap();
    let polys = polygons(&geojson);
    assert_eq!(polys.len(), 1);
    let (properties, rings) = &polys[0];
    assert_eq!(rings.len(), 2, "outer ring and one hole");
    assert!(ring_area(&rings[0]) > 0.0 && ring_area(&rings[1]) < 0.0);
    let exact = std::f64::consts::PI * (outer * outer - inner * inner);
    let area = properties["area"].as_f64().unwrap();
    assert!((area - exact).abs() < 0.01 * exact, "{area} vs {exact}");
}

#[test]
fn automatic_levels_cut_every_body_and_bad_levels_are_errors() {
    let result = nested();
    let geojson: Value =
        serde_json::from_slice(&geojson_levels(&result, &Levels::Automatic).unwrap()).unwrap();
    let levels: Vec<f64> = serde_json::from_value(geojson["levels"].clone()).unwrap();
    // The large sphere spans about 242..358 m: levels every 20 m strictly inside.
    assert_eq!(levels, [260.0, 280.0, 300.0, 320.0, 340.0]);
    let bodies: std::collections::HashSet<(u64, u64)> = polygons(&geojson)
        .iter()
        .map(|(p, _)| (p["shell"].as_u64().unwrap(), p["body"].as_u64().unwrap()))
        .collect();
    assert_eq!(bodies.len(), 3);
    assert!(matches!(
        geojson_levels(&result, &Levels::At(vec![f64::NAN])),
        Err(ExportError::BadLevel(_))
    ));
}

#[test]
fn obj_and_vtu_hold_every_triangle() {
    let result = nested();
    let vertices: usize = result
        .shells
        .iter()
        .flat_map(|s| &s.bodies)
        .map(|b| b.positions.len())
        .sum();
    let triangles: usize = result
        .shells
        .iter()
        .flat_map(|s| &s.bodies)
        .map(|b| b.triangles.len())
        .sum();

    let bytes = obj(&result).unwrap();
    keep("nested.obj", &bytes);
    let text = String::from_utf8(bytes).unwrap();
    assert_eq!(
        text.lines().filter(|l| l.starts_with("v ")).count(),
        vertices
    );
    assert_eq!(
        text.lines().filter(|l| l.starts_with("f ")).count(),
        triangles
    );
    assert_eq!(text.lines().filter(|l| l.starts_with("o ")).count(), 3);
    let max_index = text
        .lines()
        .filter_map(|l| l.strip_prefix("f "))
        .flat_map(|l| l.split(' ').map(|i| i.parse::<usize>().unwrap()))
        .max();
    assert_eq!(max_index, Some(vertices));

    let bytes = vtu(&result).unwrap();
    keep("nested.vtu", &bytes);
    let text = String::from_utf8(bytes).unwrap();
    assert!(text.contains(&format!(
        r#"NumberOfPoints="{vertices}" NumberOfCells="{triangles}""#
    )));
    // Points are in input coordinates.
    let first_point: Vec<f64> = text
        .lines()
        .skip_while(|l| !l.contains(r#"Name="Points""#))
        .nth(1)
        .unwrap()
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    let expected = DVec3::from(ORIGIN) + result.shells[0].bodies[0].positions[0];
    assert_eq!(first_point, expected.to_array());
}

#[test]
fn all_outputs_lists_each_format_with_its_media_type() {
    let outputs = all_outputs(&nested(), &OutputOptions::default()).unwrap();
    let ids: Vec<_> = outputs.iter().map(|o| (o.id, o.media_type)).collect();
    assert_eq!(
        ids,
        [
            ("glb", "model/gltf-binary"),
            ("summary", "application/json"),
            ("tileset", "application/json"),
            ("geojson", "application/geo+json"),
            ("obj", "model/obj"),
            ("vtu", "application/xml"),
        ]
    );
    let tileset: Value = serde_json::from_slice(&outputs[2].bytes).unwrap();
    assert_eq!(tileset["root"]["content"]["uri"], "glb");
    let summary: Value = serde_json::from_slice(&outputs[1].bytes).unwrap();
    assert_eq!(summary["shells"][1]["bodies"].as_array().unwrap().len(), 2);

    // Without a CRS there is nothing to place on the globe: no tileset, no error.
    let outputs = all_outputs(&result_without_crs(), &OutputOptions::default()).unwrap();
    assert!(outputs.iter().all(|o| o.id != "tileset"));
}

/// Timing of every exporter on icospheres of 327,680 and 1,310,720 triangles (printed, not
/// asserted: timings are measurements, not test conditions). Run with
/// `cargo test --test export_outputs -- --ignored --nocapture export_timing`.
#[test]
#[ignore = "measurement: prints timings of large exports"]
fn export_timing() {
    for levels in [7u32, 8] {
        let result = result(
            vec![(
                0.5,
                vec![body(&[icosphere(DVec3::ZERO, 500.0, levels, false)])],
            )],
            Some("EPSG:32633"),
        );
        let triangles = result.shells[0].bodies[0].triangles.len();
        let time = |f: &dyn Fn() -> Vec<u8>| {
            let start = std::time::Instant::now();
            let bytes = f();
            (start.elapsed().as_secs_f64(), bytes)
        };
        let (t_glb, g) = time(&|| glb(&result, &OutputOptions::default()).unwrap());
        let (t_geojson, j) = time(&|| geojson_levels(&result, &Levels::Automatic).unwrap());
        let (t_obj, o) = time(&|| obj(&result).unwrap());
        let (t_vtu, v) = time(&|| vtu(&result).unwrap());
        let (t_tileset, _) = time(&|| tileset_json(&result, "glb").unwrap());
        // What was timed is a real output: the GLB holds every triangle.
        let (document, buffers, _) = gltf::import_slice(&g).unwrap();
        let primitive = document
            .meshes()
            .next()
            .unwrap()
            .primitives()
            .next()
            .unwrap();
        let reader = primitive.reader(|b| Some(&buffers[b.index()]));
        assert_eq!(
            reader.read_indices().unwrap().into_u32().count(),
            3 * triangles
        );
        println!(
            "{triangles} triangles: glb {t_glb:.3} s ({:.1} MB), geojson {t_geojson:.3} s \
             ({:.1} MB), obj {t_obj:.3} s ({:.1} MB), vtu {t_vtu:.3} s ({:.1} MB), \
             tileset {t_tileset:.4} s",
            g.len() as f64 / 1e6,
            j.len() as f64 / 1e6,
            o.len() as f64 / 1e6,
            v.len() as f64 / 1e6,
        );
    }
}
