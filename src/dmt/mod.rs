//! Dual Marching Tetrahedra: closed, oriented ore-body surfaces from a classified
//! tetrahedral mesh (reference: the DMT paper with its errata, and the hull capping note).
//!
//! Invariant: every [`Body`] with `closed == true` is a consistently wound 2-manifold
//! (every edge in exactly two triangles, in opposite directions) whose triangles face
//! outwards, away from the marked (`value >= threshold`) side; `volume` and `area` are
//! computed from exactly the triangles in `triangles`.

pub mod mt;

use glam::DVec3;
use serde::Serialize;

/// How the one DMT vertex inside each active tetrahedron is placed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Placement {
    /// Minimal discrete norm curvature over the barycentric lattice `(aP_i+..)/lattice`.
    Curvature { lattice: u32 },
    /// Intersection between Centroids (paper eq. 1, errata).
    Ibc,
    /// Centroid of Intersections: mean of the linear-interpolation crossings.
    Coi,
    /// Mean of the midpoints of the tetrahedron's active edges.
    Midpoint,
}

/// The surface extraction method.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Method {
    /// Dual Marching Tetrahedra with the given vertex placement.
    Dmt(Placement),
    /// Marching tetrahedra (quad variant), for comparison.
    MarchingTetrahedra,
}

/// One connected ore body: a triangle mesh in local coordinates.
///
/// Shapes: `positions` #V, `triangles` #F by 3 indices into `positions`, counter-clockwise
/// seen from outside the body.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Body {
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Enclosed volume (input units cubed), by the divergence theorem over `triangles`.
    pub volume: f64,
    /// Surface area (input units squared) of `triangles`.
    pub area: f64,
    /// Every edge in exactly two oppositely directed triangles.
    pub closed: bool,
    /// The body meets the hull of the data and was capped there.
    pub truncated: bool,
    /// Axis-aligned bounds of `positions`: `[min, max]`, local coordinates.
    pub bbox: [DVec3; 2],
}

/// Counts describing the extraction, for the summary.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct ShellCounts {
    pub marked_points: usize,
    pub active_tets: usize,
    pub active_edges: usize,
    /// Vertices and faces of the surface before capping (DMT/MT duality holds here).
    pub surface_vertices: usize,
    pub surface_faces: usize,
}

/// Triangle quality of a shell.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Quality {
    pub vertices: usize,
    pub triangles: usize,
    /// Share (0..1) of triangles whose smallest angle is under 10 degrees.
    pub min_angle_under_10deg: f64,
    /// Smallest triangle angle in degrees.
    pub min_angle_deg: f64,
    /// Mean of the triangles' smallest angles, in degrees.
    pub mean_min_angle_deg: f64,
}

/// The surface at one threshold.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Shell {
    pub threshold: f64,
    pub bodies: Vec<Body>,
    pub counts: ShellCounts,
    pub quality: Quality,
}

/// Default lattice resolution `N` of the curvature placement.
pub const DEFAULT_CURVATURE_LATTICE: u32 = 7;

impl std::str::FromStr for Method {
    type Err = String;

    /// Parses `curvature`, `ibc`, `coi`, `midpoint` or `mt` (case-insensitive).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "curvature" => Ok(Method::Dmt(Placement::Curvature {
                lattice: DEFAULT_CURVATURE_LATTICE,
            })),
            "ibc" => Ok(Method::Dmt(Placement::Ibc)),
            "coi" => Ok(Method::Dmt(Placement::Coi)),
            "midpoint" => Ok(Method::Dmt(Placement::Midpoint)),
            "mt" => Ok(Method::MarchingTetrahedra),
            other => Err(format!(
                "unknown method {other:?}: expected curvature, ibc, coi, midpoint or mt"
            )),
        }
    }
}

impl Method {
    /// The name used on the command line and in the summary.
    pub fn name(&self) -> &'static str {
        match self {
            Method::Dmt(Placement::Curvature { .. }) => "curvature",
            Method::Dmt(Placement::Ibc) => "ibc",
            Method::Dmt(Placement::Coi) => "coi",
            Method::Dmt(Placement::Midpoint) => "midpoint",
            Method::MarchingTetrahedra => "mt",
        }
    }
}
