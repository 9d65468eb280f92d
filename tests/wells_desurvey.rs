//! Minimum-curvature desurvey on trajectories where it is exact: a straight inclined hole
//! and circular arcs (in a vertical plane and in a tilted one), through the `Trajectory`
//! API and through collar/survey/interval tables.

use glam::DVec3;
use wellmesh::wells::desurvey::{Station, Trajectory, direction};
use wellmesh::wells::{Input, InputFile};

/// Azimuth (degrees from north) and downward dip (degrees) of a unit direction.
fn az_dip(t: DVec3) -> (f64, f64) {
    let az = t.x.atan2(t.y).to_degrees().rem_euclid(360.0);
    let dip = (-t.z).asin().to_degrees();
    (az, dip)
}

/// A circular arc of radius `r` starting at the collar in direction `t0`, turning towards
/// the unit vector `n` (perpendicular to `t0`): position and direction at measured depth s.
fn arc(t0: DVec3, n: DVec3, r: f64, s: f64) -> (DVec3, DVec3) {
    let a = s / r;
    (
        t0 * (r * a.sin()) + n * (r * (1.0 - a.cos())),
        t0 * a.cos() + n * a.sin(),
    )
}

fn stations_on_arc(t0: DVec3, n: DVec3, r: f64, depths: &[f64]) -> Vec<Station> {
    depths
        .iter()
        .map(|&d| {
            let (az, dip) = az_dip(arc(t0, n, r, d).1);
            Station {
                depth: d,
                azimuth_deg: az,
                dip_down_deg: dip,
            }
        })
        .collect()
}

#[test]
fn a_straight_inclined_hole_is_a_straight_line_at_every_depth() {
    let stations: Vec<Station> = [0.0, 40.0, 130.0]
        .iter()
        .map(|&d| Station {
            depth: d,
            azimuth_deg: 30.0,
            dip_down_deg: 60.0,
        })
        .collect();
    let t = Trajectory::new(&stations);
    let dir = direction(30.0, 60.0);
    for k in 0..=40 {
        let d = k as f64 * 5.0;
        assert!((t.position(d) - dir * d).length() < 1e-9, "depth {d}");
    }
}

#[test]
fn a_vertical_build_arc_is_reproduced_exactly_between_stations() {
    // Starts vertical, builds 1 degree per 10 m towards the east (radius 572.96 m).
    let r = 1800.0 / std::f64::consts::PI;
    let (t0, n) = (DVec3::NEG_Z, DVec3::X);
    let stations = stations_on_arc(t0, n, r, &[0.0, 30.0, 75.0, 150.0, 300.0]);
    let t = Trajectory::new(&stations);
    for k in 0..=300 {
        let d = k as f64;
        let exact = arc(t0, n, r, d).0;
        assert!((t.position(d) - exact).length() < 1e-8, "depth {d}");
    }
}

#[test]
fn a_tilted_circular_arc_is_reproduced_exactly_between_stations() {
    let t0 = direction(20.0, 70.0);
    let n = t0.cross(DVec3::new(0.3, -0.8, 0.2)).normalize();
    let r = 250.0;
    let depths = [0.0, 12.5, 60.0, 61.0, 200.0, 333.0];
    let t = Trajectory::new(&stations_on_arc(t0, n, r, &depths));
    for k in 0..=333 {
        let d = k as f64;
        let exact = arc(t0, n, r, d).0;
        assert!((t.position(d) - exact).length() < 1e-8, "depth {d}");
    }
    // Past the last station the hole continues straight in the last direction.
    let (p, dir) = arc(t0, n, r, 333.0);
    assert!((t.position(350.0) - (p + dir * 17.0)).length() < 1e-8);
}

#[test]
fn a_first_station_below_the_collar_extends_straight_up_to_the_collar() {
    let t = Trajectory::new(&[Station {
        depth: 20.0,
        azimuth_deg: 90.0,
        dip_down_deg: 45.0,
    }]);
    let dir = direction(90.0, 45.0);
    assert!((t.position(10.0) - dir * 10.0).length() < 1e-12);
    assert!((t.position(50.0) - dir * 50.0).length() < 1e-12);
}

fn tables_for_arc(dip_sign: f64) -> (Input, DVec3, DVec3, f64) {
    let t0 = direction(110.0, 55.0);
    let n = t0.cross(DVec3::Z).cross(t0).normalize() * -1.0; // steepening
    let r = 400.0;
    let depths = [0.0, 50.0, 100.0, 150.0, 200.0];
    let mut survey = String::from("HOLEID,AT,AZ,DIP\n");
    for s in stations_on_arc(t0, n, r, &depths) {
        survey += &format!(
            "DH1,{},{:.12},{:.12}\n",
            s.depth,
            s.azimuth_deg,
            dip_sign * s.dip_down_deg
        );
    }
    let collars = "HOLEID,XCOLLAR,YCOLLAR,ZCOLLAR\nDH1,512000.5,7021000.25,350\n";
    let mut assays = String::from("HOLEID,FROM,TO,CU\n");
    for k in 0..20 {
        assays += &format!("DH1,{},{},{}\n", k * 10, k * 10 + 10, k);
    }
    let mut input = Input::from_drillholes(
        InputFile::new("collar.csv", collars),
        Some(InputFile::new("survey.csv", survey)),
        InputFile::new("assay.csv", assays),
        Some("CU"),
    );
    input.negative_is_below_detection = Some(false);
    (input, t0, n, r)
}

#[test]
fn drill_hole_tables_desurvey_interval_midpoints_onto_the_arc() {
    for (sign, given) in [(-1.0, None), (1.0, Some(false)), (1.0, None)] {
        let (mut input, t0, n, r) = tables_for_arc(sign);
        input.dip_down_negative = given;
        let set = input.load().unwrap();
        assert_eq!(set.points.len(), 20);
        let collar = DVec3::new(512000.5, 7021000.25, 350.0);
        for (k, p) in set.points.iter().enumerate() {
            let exact = collar + arc(t0, n, r, k as f64 * 10.0 + 5.0).0;
            assert!(
                (*p + set.origin - exact).length() < 1e-6,
                "sample {k}: {} vs {exact}",
                *p + set.origin
            );
            assert_eq!(set.values[k], Some(k as f64));
        }
        let expected = if sign < 0.0 {
            "negative-down"
        } else {
            "positive-down"
        };
        assert_eq!(set.report.dip_convention.as_deref(), Some(expected));
        assert_eq!(set.report.up_holes, 0);
        assert!(set.wells[0].trace.len() >= 2);
    }
}

#[test]
fn a_dip_convention_against_the_data_is_warned_and_gives_up_holes() {
    let (mut input, ..) = tables_for_arc(-1.0);
    input.dip_down_negative = Some(false);
    let set = input.load().unwrap();
    assert_eq!(set.report.up_holes, 1);
    assert!(
        set.report
            .warnings
            .iter()
            .any(|w| w.contains("--dip-down positive was given")),
        "{:?}",
        set.report.warnings
    );
    // The hole now rises from its collar.
    let top = set.points.iter().map(|p| p.z).fold(f64::MIN, f64::max) + set.origin.z;
    assert!(top > 350.0);
}

#[test]
fn azimuths_past_360_wrap_and_unsurveyed_holes_are_vertical() {
    let collars = "hole_id,x,y,z\nA,100,200,50\nB,300,200,50\n";
    let survey = "hole_id,depth,azimuth,dip\nA,0,385,-60\nA,100,25,-60\n";
    let assay = "hole_id,from,to,grade\nA,0,10,1\nB,0,10,2\n";
    let set = Input::from_drillholes(
        InputFile::new("c.csv", collars),
        Some(InputFile::new("s.csv", survey)),
        InputFile::new("a.csv", assay),
        None,
    )
    .load()
    .unwrap();
    assert_eq!(set.report.azimuths_wrapped, 1);
    assert_eq!(set.report.unsurveyed_holes, 1);
    let a = set.points[0] + set.origin;
    let exact = DVec3::new(100.0, 200.0, 50.0) + direction(25.0, 60.0) * 5.0;
    assert!((a - exact).length() < 1e-9);
    let b = set.points[1] + set.origin;
    assert!((b - DVec3::new(300.0, 200.0, 45.0)).length() < 1e-9);
}

/// The grade field of `sample_wells/make_copper.py` (same constants).
fn copper_grade(p: DVec3) -> f64 {
    let d = p - DVec3::new(512300.0, 7021850.0, 240.0);
    let (s, c) = 30f64.to_radians().sin_cos();
    let u = c * d.x + s * d.y;
    let v = -s * d.x + c * d.y;
    let r2 = (u / 150.0).powi(2) + (v / 90.0).powi(2) + (d.z / 45.0).powi(2);
    (2.0 * (1.0 - r2)).max(0.0)
}

#[test]
fn shipped_curved_drill_holes_desurvey_every_assay_to_where_it_was_taken() {
    let dir = format!("{}/sample_wells", env!("CARGO_MANIFEST_DIR"));
    let read = |name: &str| InputFile::new(name, std::fs::read(format!("{dir}/{name}")).unwrap());
    let set = Input::from_drillholes(
        read("copper_collars.csv"),
        Some(read("copper_surveys.csv")),
        read("copper_assays.csv"),
        Some("cu"),
    )
    .load()
    .unwrap();
    assert_eq!(set.wells.len(), 80);
    assert_eq!(set.points.len(), 12000);
    assert_eq!(set.report.dip_convention.as_deref(), Some("negative-down"));
    let mut inside = 0;
    for (p, v) in set.points.iter().zip(&set.values) {
        let expected = copper_grade(*p + set.origin);
        let v = v.unwrap();
        assert!(
            (v - expected).abs() < 1e-4,
            "{v} vs {expected} at {}",
            *p + set.origin
        );
        if v > 0.0 {
            inside += 1;
        }
    }
    assert!(
        inside > 500,
        "the holes cross the body ({inside} samples inside)"
    );
}

#[test]
fn an_inclination_column_desurveys_like_the_equivalent_dip() {
    let (dip_input, ..) = tables_for_arc(-1.0);
    let survey = String::from_utf8(dip_input.surveys_csv.clone().unwrap().bytes).unwrap();
    let mut inc = String::from("HOLEID,AT,AZ,INCLINATION\n");
    for line in survey.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let dip: f64 = f[3].parse().unwrap();
        inc += &format!("{},{},{},{}\n", f[0], f[1], f[2], dip + 90.0);
    }
    let mut inc_input = dip_input.clone();
    inc_input.surveys_csv = Some(InputFile::new("inc.csv", inc));
    let (a, b) = (dip_input.load().unwrap(), inc_input.load().unwrap());
    assert_eq!(
        b.report.dip_convention.as_deref(),
        Some("inclination (0 = down)")
    );
    for (p, q) in a.points.iter().zip(&b.points) {
        assert!((*p + a.origin - (*q + b.origin)).length() < 1e-9);
    }
    let bad = "HOLEID,AT,AZ,INC\nDH1,0,10,200\n";
    inc_input.surveys_csv = Some(InputFile::new("inc.csv", bad));
    let e = inc_input.load().unwrap_err().to_string();
    assert!(
        e.contains("inc.csv, line 2, column 'INC'") && e.contains("0..180"),
        "{e}"
    );
}
