//! Dual Marching Tetrahedra: closed, oriented ore-body surfaces from a classified
//! tetrahedral mesh (reference: the DMT paper with its errata, and the hull capping note).
//!
//! Invariant: every [`Body`] with `closed == true` is a consistently wound 2-manifold
//! (every edge in exactly two triangles, in opposite directions) whose triangles face
//! outwards, away from the marked (`value >= threshold`) side; `volume` and `area` are
//! computed from exactly the triangles in `triangles`.

pub mod curvature;
pub mod distance;
pub mod extract;
pub mod measure;
pub mod mt;
pub mod place;
pub mod relax;
pub mod simplify;

use std::borrow::Cow;

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::progress::{CURVATURE_SHARE, Progress, Stage};
use crate::tet::TetMesh;
use extract::{PolygonKind, Topology, VertexRole};
use place::SortedCorners;

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
    /// IbC on the signed distance to the nearest sample of the other class (for 0/1 data,
    /// where the values themselves carry no position between samples).
    Distance,
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
    /// The [`mt::marked_regions`] number of the marked material inside ([`mt::NO_REGION`]
    /// when unknown).
    pub region: u32,
    /// The DMT surface of this body folded over itself (negative volume), so the body is
    /// the marching-tetrahedra surface of the same marked material instead.
    pub mt_fallback: bool,
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
    /// Places where samples are exactly at the threshold with none around them above it:
    /// they enclose no volume and form no body ([`mt::lower_point_touches`]).
    pub point_touches: usize,
}

/// A relaxed body whose balance misses its target by more than this share is balanced
/// again at the paper's positions.
const RELAXED_BALANCE_MISS: f64 = 1e-3;

/// Default lattice resolution `N` of the curvature placement.
pub const DEFAULT_CURVATURE_LATTICE: u32 = 7;

impl std::str::FromStr for Method {
    type Err = String;

    /// Parses `distance`, `curvature`, `ibc`, `coi`, `midpoint` or `mt` (case-insensitive).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "curvature" => Ok(Method::Dmt(Placement::Curvature {
                lattice: DEFAULT_CURVATURE_LATTICE,
            })),
            "ibc" => Ok(Method::Dmt(Placement::Ibc)),
            "coi" => Ok(Method::Dmt(Placement::Coi)),
            "midpoint" => Ok(Method::Dmt(Placement::Midpoint)),
            "distance" => Ok(Method::Dmt(Placement::Distance)),
            "mt" => Ok(Method::MarchingTetrahedra),
            other => Err(format!(
                "unknown method {other:?}: expected distance, curvature, ibc, coi, midpoint or mt"
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
            Method::Dmt(Placement::Distance) => "distance",
            Method::MarchingTetrahedra => "mt",
        }
    }
}

/// Why an extraction failed.
#[derive(Debug, thiserror::Error)]
pub enum DmtError {
    #[error("expected one value per mesh vertex ({expected}), got {got}")]
    ValueCount { expected: usize, got: usize },
    #[error("value of mesh vertex {0} is not a finite number")]
    NonFinite(usize),
    #[error("threshold {0} is not a finite number")]
    BadThreshold(f64),
    #[error("cancelled")]
    Cancelled,
}

/// At most this many placements in the bodies' volume balance (`distance::RootSearch`
/// usually needs far fewer).
const BALANCE_STEPS: usize = 12;

/// How the (non-planar) dual polygons are cut into triangles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Triangulation {
    /// By diagonals, the triangulation with the fewest slivers (smallest angle under 10
    /// degrees) and, among those, the largest smallest angle (dynamic programming per
    /// polygon), or the centroid star where that scores better. The default, chosen by
    /// measurement (docs/dmt.md): fewest slivers.
    #[default]
    MaxMinAngle,
    /// A star around the polygon's centroid (one added vertex per polygon of 4 or more
    /// corners).
    Star,
    /// A star around the crossing on the polygon's dual edge (the marching-tetrahedra
    /// vertex of that edge): slightly smaller volume error, more slivers.
    EdgeCrossing,
    /// A fan from the first corner: no added vertices, more slivers.
    Fan,
}

/// Extracts the DMT surface of `values >= threshold` on `mesh`, closed at the hull, split
/// into bodies (largest first) with their measures; IbC and CoI vertices are relaxed for
/// shape ([`relax::DEFAULT_SWEEPS`]).
///
/// `values` holds one finite value per mesh vertex (`mesh.points`).
pub fn extract_shell(
    mesh: &TetMesh,
    values: &[f64],
    threshold: f64,
    placement: Placement,
    triangulation: Triangulation,
    progress: &dyn Progress,
) -> Result<Shell, DmtError> {
    extract_shell_relaxed(
        mesh,
        values,
        threshold,
        placement,
        triangulation,
        relax::DEFAULT_SWEEPS,
        progress,
    )
}

/// [`extract_shell`] with `relax_sweeps` sweeps of the shape relaxation of IbC and CoI
/// vertices ([`relax`]; 0 keeps the paper's positions). Other placements ignore it.
pub fn extract_shell_relaxed(
    mesh: &TetMesh,
    values: &[f64],
    threshold: f64,
    placement: Placement,
    triangulation: Triangulation,
    relax_sweeps: usize,
    progress: &dyn Progress,
) -> Result<Shell, DmtError> {
    check_inputs(mesh, values, threshold)?;
    let lowered = mt::lower_point_touches(mesh, values, threshold);
    let (values, point_touches) = match &lowered {
        Some((lowered, count)) => (lowered.as_slice(), *count),
        None => (values, 0),
    };
    progress.report(Stage::Contour, 0.0);
    let marked: Vec<bool> = values.par_iter().map(|&v| v >= threshold).collect();
    let topo = extract::build(mesh, &marked);
    if progress.is_cancelled() {
        return Err(DmtError::Cancelled);
    }
    progress.report(Stage::Contour, CURVATURE_SHARE.0);

    let recipe = placement.recipe();
    let (field, level) = placement_field(mesh, values, threshold, &marked, recipe);
    let regions = mt::marked_regions(mesh, &marked);
    let ex = Extraction {
        mesh,
        topo: &topo,
        marked: &marked,
        regions: &regions,
        field: &field,
        level,
        recipe,
        triangulation,
    };
    let mut positions = vec![DVec3::ZERO; topo.roles.len()];
    place_vertices(&ex, &mut positions);
    let balanced = recipe
        .balanced
        .then(|| balance_bodies(&ex, values, threshold, relax_sweeps, &mut positions));
    if let Some(lattice) = recipe.curvature_lattice {
        // The search keeps to a band around the balanced field's zero.
        let corner_field = balanced.as_ref().map_or(&[][..], |b| &b.corner_field);
        curvature::optimize(&topo, mesh, corner_field, &mut positions, lattice, progress)?;
    }
    if progress.is_cancelled() {
        return Err(DmtError::Cancelled);
    }
    progress.report(Stage::Contour, CURVATURE_SHARE.1);

    let (positions, triangles, polygon_of) = output_triangles(&ex, positions, balanced);
    let bodies = bodies_of_material(&ex, values, threshold, &positions, &triangles, &polygon_of);
    let quality = measure::quality(
        bodies
            .iter()
            .map(|b| (b.positions.as_slice(), b.triangles.as_slice())),
    );
    progress.report(Stage::Contour, 1.0);
    Ok(Shell {
        threshold,
        bodies,
        counts: ShellCounts {
            marked_points: topo.marked_points,
            active_tets: topo.active_tets,
            active_edges: topo.active_edges,
            surface_vertices: topo.active_tets,
            surface_faces: topo.active_edges,
        },
        quality,
        point_touches,
    })
}

/// What the extraction does for a placement: the one place where placements differ, so a
/// new placement is one more arm of [`Placement::recipe`].
#[derive(Clone, Copy)]
struct Recipe {
    /// The vertices are placed on the signed distance to the other class (0/1 data, whose
    /// values carry no position between samples; module `distance`) instead of the values.
    on_class_distance: bool,
    /// The rule placing a DMT vertex among its tetrahedron's corners, at a level of the
    /// field.
    rule: fn(&SortedCorners, f64) -> DVec3,
    /// The rule as weights on the tetrahedron's crossings, for the placements the shape
    /// relaxation moves ([`relax`]; `None`: not relaxed).
    crossing_weights: Option<fn(&SortedCorners, f64) -> [f64; 4]>,
    /// Each body is balanced to the volume marching tetrahedra gives on the same
    /// tetrahedra (docs/dmt.md, *Volume balance*).
    balanced: bool,
    /// Hull vertices sit at their edge's midpoint instead of its crossing.
    hull_midpoints: bool,
    /// The lattice of the curvature search that moves the balanced vertices (their
    /// polygons are then cut again once, at the output).
    curvature_lattice: Option<u32>,
}

impl Placement {
    /// How the extraction treats this placement.
    fn recipe(self) -> Recipe {
        let plain = Recipe {
            on_class_distance: false,
            rule: place::ibc,
            crossing_weights: None,
            balanced: true,
            hull_midpoints: false,
            curvature_lattice: None,
        };
        match self {
            Placement::Ibc => Recipe {
                crossing_weights: Some(place::ibc_weights),
                ..plain
            },
            Placement::Coi => Recipe {
                rule: place::coi,
                crossing_weights: Some(place::coi_weights),
                ..plain
            },
            Placement::Midpoint => Recipe {
                rule: place::midpoint,
                balanced: false,
                hull_midpoints: true,
                ..plain
            },
            // IbC on the distance field; the curvature search starts from there.
            Placement::Distance => Recipe {
                on_class_distance: true,
                ..plain
            },
            Placement::Curvature { lattice } => Recipe {
                on_class_distance: true,
                curvature_lattice: Some(lattice),
                ..plain
            },
        }
    }
}

/// The field a placement's vertices are placed on, and its level: the signed distance to
/// the other class at 0, or the values, moved to level 0 for a balanced placement (the
/// balance scales the field's two sides about 0).
fn placement_field<'a>(
    mesh: &TetMesh,
    values: &'a [f64],
    threshold: f64,
    marked: &[bool],
    recipe: Recipe,
) -> (Cow<'a, [f64]>, f64) {
    if recipe.on_class_distance {
        // Its zero level set separates the same tetrahedra as the classification.
        (distance::signed_class_distance(mesh, marked).into(), 0.0)
    } else if recipe.balanced {
        let grade: Vec<f64> = values.par_iter().map(|&v| v - threshold).collect();
        (grade.into(), 0.0)
    } else {
        (values.into(), threshold)
    }
}

/// What every step of one extraction reads.
struct Extraction<'a> {
    mesh: &'a TetMesh,
    topo: &'a Topology,
    marked: &'a [bool],
    /// The [`mt::marked_regions`] number of each marked mesh vertex.
    regions: &'a [u32],
    /// The field the vertices are placed on (one value per mesh vertex) and its level
    /// ([`placement_field`]).
    field: &'a [f64],
    level: f64,
    recipe: Recipe,
    triangulation: Triangulation,
}

impl Extraction<'_> {
    /// The end points of the Delaunay edge `a -> b`.
    fn edge_ends(&self, a: u32, b: u32) -> (DVec3, DVec3) {
        (self.mesh.points[a as usize], self.mesh.points[b as usize])
    }

    /// The surface point on the active edge from marked vertex `a` to unmarked `b` before
    /// any balance: the field's crossing, or the midpoint.
    fn crossing(&self, a: u32, b: u32) -> DVec3 {
        hull_crossing(
            self.mesh,
            self.field,
            self.level,
            self.recipe.hull_midpoints,
            a,
            b,
        )
    }

    /// The crossing on the active edge `a -> b` with its body's balance `alpha`.
    fn balanced_crossing(&self, alpha: &[f64], a: u32, b: u32) -> DVec3 {
        distance::balanced_crossing(self.mesh, self.field, self.regions, alpha, a, b)
    }
}

/// The balanced vertices and the cut their volumes were balanced on.
struct BalancedCut {
    plan: Plan,
    /// The balanced field at the corners of each active tetrahedron.
    corner_field: Vec<[f64; 4]>,
    /// Each body's balance (see [`distance::place_balanced`]).
    alpha: Vec<f64>,
}

/// Balances every body to the volume marching tetrahedra encloses on the same tetrahedra
/// (the linear interpolation's superlevel set; for 0/1 data, crossings at edge midpoints),
/// relaxing IbC and CoI vertices for shape first; `positions` hold the unbalanced
/// placement and are left balanced.
///
/// Why: unbalanced, DMT's polygons are chords across convex surfaces (grade bodies 0.1-0.3
/// points smaller than MT's) and the distance field leans inwards at convex edges (0/1
/// bodies 3.6-8.9% small); docs/dmt.md. The balance is solved on exactly the triangles of
/// the cut chosen for the unbalanced vertices (a fan of the twisted polygons between drill
/// holes misjudges a body's volume by tens of percent).
fn balance_bodies(
    ex: &Extraction,
    values: &[f64],
    threshold: f64,
    relax_sweeps: usize,
    positions: &mut [DVec3],
) -> BalancedCut {
    let target = mt::region_volumes(ex.mesh, values, threshold, ex.regions);
    let edge_ends = |a: u32, b: u32| ex.edge_ends(a, b);
    let mut plan = plan_triangulation(ex.topo, positions, ex.triangulation, &edge_ends, None);
    let mut factors = match ex.recipe.crossing_weights {
        Some(rule_weights) if relax_sweeps > 0 => Some(relaxed_weight_factors(
            ex,
            &plan,
            rule_weights,
            relax_sweeps,
            positions,
        )),
        _ => None,
    };
    let mut balanced = balance_on(ex, &target, factors.as_deref(), &plan, positions);
    // A relaxed body whose balance finds no root (in the long, flat tetrahedra between
    // drill holes the relaxation can tip a small body over, or leave a large one out of
    // the balance's reach) is placed at the paper's positions and balanced again.
    if let Some(factors) = &mut factors
        && reset_unbalanced_bodies(factors, &balanced)
    {
        balanced = balance_on(ex, &target, Some(factors), &plan, positions);
    }
    // Polygons whose cut no longer suits the balanced vertices are cut again, and the
    // balance solved again on the new cut, so the output triangles carry the target
    // volumes (the curvature placement moves its vertices after the balance and is cut
    // again once, at the output).
    if ex.recipe.curvature_lattice.is_none() {
        let crossing = |a: u32, b: u32| ex.balanced_crossing(&balanced.alpha, a, b);
        let realized = plan.realize(ex.topo, positions.to_vec(), &crossing);
        if let Some(recut) = plan.cut_again_where_unsuited(ex, &realized) {
            plan = recut;
            balanced = balance_on(ex, &target, factors.as_deref(), &plan, positions);
        }
    }
    BalancedCut {
        plan,
        corner_field: balanced.corner_field,
        alpha: balanced.alpha,
    }
}

/// Relaxes the DMT vertices for shape ([`relax::relax`], moving `positions`) and returns
/// their weights on their crossings as factors on the rule's own weights: the rule keeps
/// its response to the balanced values (IbC's weights depend on them; with fixed weights
/// the balance of bodies in the long tetrahedra between drill holes can fail).
fn relaxed_weight_factors(
    ex: &Extraction,
    plan: &Plan,
    rule_weights: fn(&SortedCorners, f64) -> [f64; 4],
    sweeps: usize,
    positions: &mut [DVec3],
) -> Vec<[f64; 4]> {
    let paper: Vec<[f64; 4]> = (0..ex.topo.active_tets)
        .into_par_iter()
        .map(|v| rule_weights(&relax::corners(ex.topo, ex.mesh, ex.field, v), 0.0))
        .collect();
    let mut weights = paper.clone();
    let crossing = |a: u32, b: u32| ex.crossing(a, b);
    let edge_ends = |a: u32, b: u32| ex.edge_ends(a, b);
    let surface = relax::Surface {
        topo: ex.topo,
        mesh: ex.mesh,
        field: ex.field,
        plan,
        edge_crossing: &crossing,
        edge_ends: &edge_ends,
    };
    // The polygons keep the cut chosen for the paper's positions: the relaxation judges
    // its moves on it and keeps its edges passing through (a cut chosen again for the
    // moved vertices changed the sliver share by under 0.01 at twice the cost;
    // docs/dmt.md).
    relax::relax(&surface, &mut weights, positions, sweeps);
    weights.par_iter_mut().zip(&paper).for_each(|(w, base)| {
        for (x, &b) in w.iter_mut().zip(base) {
            *x = if b > 0.0 { *x / b } else { 0.0 };
        }
    });
    weights
}

/// Puts the vertices of every body whose relaxed balance missed its target back at the
/// paper's weights (factors 1); whether there was any.
fn reset_unbalanced_bodies(factors: &mut [[f64; 4]], balanced: &distance::Balanced) -> bool {
    let failed: Vec<bool> = balanced
        .missed
        .iter()
        .map(|&m| m > RELAXED_BALANCE_MISS)
        .collect();
    if !failed.contains(&true) {
        return false;
    }
    factors
        .par_iter_mut()
        .zip(&balanced.vertex_region)
        .for_each(|(w, &r)| {
            if failed[r as usize] {
                *w = [1.0; 4];
            }
        });
    true
}

/// One volume balance of every body on the triangles of `plan`, placing the DMT vertices
/// by the placement's rule, or by its crossing weights times the relaxation's `factors`.
fn balance_on(
    ex: &Extraction,
    target: &[f64],
    factors: Option<&[[f64; 4]]>,
    plan: &Plan,
    positions: &mut [DVec3],
) -> distance::Balanced {
    let solve = |rule: &(dyn Fn(usize, &SortedCorners) -> DVec3 + Sync),
                 positions: &mut [DVec3]| {
        distance::place_balanced(
            ex.topo,
            ex.mesh,
            ex.marked,
            ex.field,
            ex.regions,
            positions,
            distance::Balance {
                target,
                rule,
                steps: BALANCE_STEPS,
                plan,
            },
        )
    };
    match (factors, ex.recipe.crossing_weights) {
        (Some(factors), Some(rule_weights)) => solve(
            &|v: usize, c: &SortedCorners| {
                let base = rule_weights(c, 0.0);
                let f = factors[v];
                place::weighted(c, 0.0, &std::array::from_fn(|i| base[i] * f[i]))
            },
            positions,
        ),
        _ => {
            let rule = ex.recipe.rule;
            solve(&|_: usize, c: &SortedCorners| rule(c, 0.0), positions)
        }
    }
}

/// The output triangles: the cut the volumes were balanced on, except where it no longer
/// suits the final vertices, or a fresh cut for an unbalanced placement. Returns the
/// positions (surface vertices, then added ones), the triangles and the polygon each cuts.
fn output_triangles(
    ex: &Extraction,
    positions: Vec<DVec3>,
    balanced: Option<BalancedCut>,
) -> (Vec<DVec3>, Vec<[u32; 3]>, Vec<u32>) {
    let edge_ends = |a: u32, b: u32| ex.edge_ends(a, b);
    let Some(BalancedCut { plan, alpha, .. }) = balanced else {
        let crossing = |a: u32, b: u32| ex.crossing(a, b);
        return triangulate(ex.topo, positions, ex.triangulation, &crossing, &edge_ends);
    };
    let crossing = |a: u32, b: u32| ex.balanced_crossing(&alpha, a, b);
    let base = positions.len();
    let mut realized = plan.realize(ex.topo, positions, &crossing);
    match plan.cut_again_where_unsuited(ex, &realized) {
        Some(recut) => {
            realized.truncate(base);
            let positions = recut.realize(ex.topo, realized, &crossing);
            (positions, recut.triangles, recut.polygon_of)
        }
        None => (realized, plan.triangles, plan.polygon_of),
    }
}

/// The bodies of the surface: one per connected piece of marked material, its outer shell
/// together with the shells of its cavities (a surface-connectivity split would make each
/// cavity a body of negative volume); largest first.
fn bodies_of_material(
    ex: &Extraction,
    values: &[f64],
    threshold: f64,
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    polygon_of: &[u32],
) -> Vec<Body> {
    let label: Vec<u32> = polygon_of
        .iter()
        .map(|&k| ex.regions[polygon_marked_point(ex.topo, k as usize) as usize])
        .collect();
    let mut bodies = split_bodies(ex.topo, positions, triangles, &label);
    // A closed, consistently wound surface around marked material encloses a positive
    // volume; on the long, flat tetrahedra between drill holes a DMT surface can still
    // fold over itself. Such a body becomes the marching-tetrahedra surface of the same
    // marked material (embedded by construction), flagged `mt_fallback`.
    if bodies.iter().any(|b| b.volume <= 0.0) {
        let mut mt_bodies = mt::marching_tetrahedra(ex.mesh, values, threshold).bodies;
        for body in bodies.iter_mut().filter(|b| b.volume <= 0.0) {
            if let Some(i) = mt_bodies.iter().position(|m| m.region == body.region) {
                let mut replacement = mt_bodies.swap_remove(i);
                replacement.mt_fallback = true;
                *body = replacement;
            }
        }
        bodies.sort_by(|a, b| b.volume.total_cmp(&a.volume));
    }
    bodies
}

/// The checks every extraction makes on its inputs: one finite value per mesh vertex and a
/// finite threshold.
pub fn check_inputs(mesh: &TetMesh, values: &[f64], threshold: f64) -> Result<(), DmtError> {
    if values.len() != mesh.points.len() {
        return Err(DmtError::ValueCount {
            expected: mesh.points.len(),
            got: values.len(),
        });
    }
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(DmtError::NonFinite(i));
    }
    if !threshold.is_finite() {
        return Err(DmtError::BadThreshold(threshold));
    }
    Ok(())
}

/// Places every surface vertex: DMT vertices by the placement's rule on its field, hull
/// vertices by the crossing on their edge (midpoints for the midpoint rule).
fn place_vertices(ex: &Extraction, positions: &mut [DVec3]) {
    let (mesh, topo) = (ex.mesh, ex.topo);
    let rule = ex.recipe.rule;
    positions[..topo.active_tets]
        .par_iter_mut()
        .zip(&topo.roles[..topo.active_tets])
        .for_each(|(p, role)| {
            let VertexRole::Tet { tet } = *role else {
                unreachable!("the first vertices are DMT vertices")
            };
            let tv = mesh.tet(tet as usize);
            let corners = SortedCorners::new(
                tv.map(|v| mesh.points[v as usize]),
                tv.map(|v| ex.field[v as usize]),
            );
            *p = rule(&corners, ex.level);
        });
    let crossing = |a: u32, b: u32| ex.crossing(a, b);
    extract::place_hull_vertices(topo, mesh, ex.marked, &crossing, positions);
}

/// The surface point on the active edge from marked vertex `a` to unmarked `b`: the
/// linear-interpolation crossing, or the edge's midpoint.
fn hull_crossing(
    mesh: &TetMesh,
    values: &[f64],
    threshold: f64,
    midpoint: bool,
    a: u32,
    b: u32,
) -> DVec3 {
    let (pa, pb) = (mesh.points[a as usize], mesh.points[b as usize]);
    if midpoint {
        (pa + pb) * 0.5
    } else {
        place::crossing(pb, pa, values[b as usize], values[a as usize], threshold)
    }
}

/// Cuts every polygon into triangles, keeping orientation, and places the added vertices.
fn triangulate(
    topo: &Topology,
    positions: Vec<DVec3>,
    triangulation: Triangulation,
    edge_crossing: &dyn Fn(u32, u32) -> DVec3,
    edge_ends: &dyn Fn(u32, u32) -> (DVec3, DVec3),
) -> (Vec<DVec3>, Vec<[u32; 3]>, Vec<u32>) {
    let plan = plan_triangulation(topo, &positions, triangulation, edge_ends, None);
    let positions = plan.realize(topo, positions, edge_crossing);
    (positions, plan.triangles, plan.polygon_of)
}

/// A vertex a triangulation adds inside a polygon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Added {
    /// The centroid of polygon `k`'s corners.
    Centroid(u32),
    /// The crossing on the active edge `(marked, unmarked)`.
    Crossing(u32, u32),
}

/// How the polygons are cut into triangles, independent of where the vertices sit: the
/// triangles' volume can be re-evaluated as the vertices move (the volume balance).
pub struct Plan {
    /// Corners index the surface vertices (`< base`) or `added[i - base]`.
    pub triangles: Vec<[u32; 3]>,
    /// The polygon each triangle cuts.
    pub polygon_of: Vec<u32>,
    pub added: Vec<Added>,
    /// The number of surface vertices (the first added vertex's index).
    pub base: usize,
}

impl Plan {
    /// Where added vertex `a` sits for these surface vertex `positions`.
    pub fn added_position(
        topo: &Topology,
        positions: &[DVec3],
        a: Added,
        edge_crossing: &dyn Fn(u32, u32) -> DVec3,
    ) -> DVec3 {
        match a {
            Added::Centroid(k) => {
                let poly = topo.polygon(k as usize);
                poly.iter().map(|&v| positions[v as usize]).sum::<DVec3>() / poly.len() as f64
            }
            Added::Crossing(a, b) => edge_crossing(a, b),
        }
    }

    /// The triangles of polygon `k` are `ranges[k]..ranges[k + 1]`.
    pub(crate) fn polygon_ranges(&self, polygons: usize) -> Vec<usize> {
        let mut ranges = vec![0; polygons + 1];
        for &k in &self.polygon_of {
            ranges[k as usize + 1] += 1;
        }
        for k in 0..polygons {
            ranges[k + 1] += ranges[k];
        }
        ranges
    }

    /// Which polygons a [`Triangulation::MaxMinAngle`] cut no longer suits at the
    /// `realized` positions (surface vertices then added vertices): a triangle folded
    /// against the polygon's normal, or the polygon's edge no longer passing through it
    /// once from back to front. Stars around the edge's crossing always suit.
    fn unsuited(
        &self,
        topo: &Topology,
        realized: &[DVec3],
        edge_ends: &(dyn Fn(u32, u32) -> (DVec3, DVec3) + Sync),
    ) -> Vec<bool> {
        let ranges = self.polygon_ranges(topo.polygon_count());
        (0..topo.polygon_count())
            .into_par_iter()
            .map(|k| {
                if topo.kinds[k] != PolygonKind::Dual || topo.dual_open[k] {
                    return false;
                }
                let tris = &self.triangles[ranges[k]..ranges[k + 1]];
                let crossing_star = tris.iter().flatten().any(|&i| {
                    (i as usize) >= self.base
                        && matches!(self.added[i as usize - self.base], Added::Crossing(..))
                });
                if crossing_star {
                    return false;
                }
                let pts: Vec<DVec3> = topo
                    .polygon(k)
                    .iter()
                    .map(|&v| realized[v as usize])
                    .collect();
                let normal = newell_normal(&pts);
                let at = |t: &[u32; 3]| t.map(|i| realized[i as usize]);
                let folded = tris.iter().any(|t| {
                    let [a, b, c] = at(t);
                    triangle_score(a, b, c, normal) <= 0.0
                });
                let (a, b) = topo.dual_edges[k];
                let (pa, pb) = edge_ends(a, b);
                folded || !separates(pa, pb, tris.iter().map(at))
            })
            .collect()
    }

    /// The plan with the polygons whose [`Triangulation::MaxMinAngle`] cut no longer suits
    /// the `realized` positions ([`Plan::unsuited`]) cut again, the others kept; `None`
    /// when every cut still suits them or the triangulation is another.
    fn cut_again_where_unsuited(&self, ex: &Extraction, realized: &[DVec3]) -> Option<Plan> {
        if ex.triangulation != Triangulation::MaxMinAngle {
            return None;
        }
        let edge_ends = |a: u32, b: u32| ex.edge_ends(a, b);
        let unsuited = self.unsuited(ex.topo, realized, &edge_ends);
        if !unsuited.contains(&true) {
            return None;
        }
        Some(plan_triangulation(
            ex.topo,
            &realized[..self.base],
            ex.triangulation,
            &edge_ends,
            Some((self, &unsuited)),
        ))
    }

    /// `positions` (the surface vertices) followed by the added vertices.
    pub fn realize(
        &self,
        topo: &Topology,
        mut positions: Vec<DVec3>,
        edge_crossing: &dyn Fn(u32, u32) -> DVec3,
    ) -> Vec<DVec3> {
        debug_assert_eq!(positions.len(), self.base);
        positions.reserve(self.added.len());
        for &a in &self.added {
            let p = Self::added_position(topo, &positions[..self.base], a, edge_crossing);
            positions.push(p);
        }
        positions
    }
}

/// Plans the cut of every polygon into triangles, keeping orientation. Dual polygons of 4
/// or more corners get a centre vertex with [`Triangulation::Star`]; caps are fanned from
/// their `W_f` vertex, which sees the whole (planar) cap polygon.
///
/// With `keep`, polygon `k` keeps its cut from that plan unless `keep.1[k]` says to plan it
/// again.
fn plan_triangulation(
    topo: &Topology,
    positions: &[DVec3],
    triangulation: Triangulation,
    edge_ends: &dyn Fn(u32, u32) -> (DVec3, DVec3),
    keep: Option<(&Plan, &[bool])>,
) -> Plan {
    let mut plan = PlanBuilder::new(positions.len(), topo.corners.len() * 2);
    let old_ranges = keep.map(|(old, _)| old.polygon_ranges(topo.polygon_count()));
    for k in 0..topo.polygon_count() {
        if let (Some((old, replan)), Some(ranges)) = (keep, &old_ranges)
            && !replan[k]
        {
            plan.copy_cut(old, &old.triangles[ranges[k]..ranges[k + 1]]);
        } else {
            let before = plan.triangles.len();
            cut_polygon(&mut plan, topo, k, positions, triangulation, edge_ends);
            debug_assert!(plan.triangles.len() > before);
        }
        plan.polygon_of.resize(plan.triangles.len(), k as u32);
    }
    Plan {
        triangles: plan.triangles,
        polygon_of: plan.polygon_of,
        added: plan.added,
        base: plan.base,
    }
}

/// A [`Plan`] while its polygons are cut, one after the other.
struct PlanBuilder {
    triangles: Vec<[u32; 3]>,
    polygon_of: Vec<u32>,
    added: Vec<Added>,
    base: usize,
}

impl PlanBuilder {
    fn new(base: usize, capacity: usize) -> Self {
        Self {
            triangles: Vec::with_capacity(capacity),
            polygon_of: Vec::with_capacity(capacity),
            added: Vec::new(),
            base,
        }
    }

    /// Adds a vertex; its index.
    fn add(&mut self, a: Added) -> u32 {
        self.added.push(a);
        (self.base + self.added.len() - 1) as u32
    }

    /// A fan of the polygon from its corner `from`.
    fn fan(&mut self, poly: &[u32], from: usize) {
        let n = poly.len();
        for i in 1..n - 1 {
            self.triangles
                .push([poly[from], poly[(from + i) % n], poly[(from + i + 1) % n]]);
        }
    }

    /// A star of the polygon around vertex `centre`.
    fn star(&mut self, centre: u32, poly: &[u32]) {
        let n = poly.len();
        for i in 0..n {
            self.triangles.push([centre, poly[i], poly[(i + 1) % n]]);
        }
    }

    /// Copies one polygon's `triangles` from plan `old` (of the same surface vertices),
    /// adding its added vertex (at most one per polygon) again.
    fn copy_cut(&mut self, old: &Plan, triangles: &[[u32; 3]]) {
        debug_assert_eq!(old.base, self.base);
        let base = self.base;
        let mut mapped: Option<(u32, u32)> = None;
        for t in triangles {
            let t = t.map(|i| {
                if (i as usize) < base {
                    return i;
                }
                match mapped {
                    Some((from, to)) if from == i => to,
                    _ => {
                        let to = self.add(old.added[i as usize - base]);
                        mapped = Some((i, to));
                        to
                    }
                }
            });
            self.triangles.push(t);
        }
    }
}

/// Cuts polygon `k` into triangles by `triangulation` (see [`plan_triangulation`]).
fn cut_polygon(
    plan: &mut PlanBuilder,
    topo: &Topology,
    k: usize,
    positions: &[DVec3],
    triangulation: Triangulation,
    edge_ends: &dyn Fn(u32, u32) -> (DVec3, DVec3),
) {
    let poly = topo.polygon(k);
    let n = poly.len();
    let checked = triangulation == Triangulation::MaxMinAngle && topo.kinds[k] == PolygonKind::Dual;
    if n == 3 && !checked {
        plan.triangles.push([poly[0], poly[1], poly[2]]);
        return;
    }
    match topo.kinds[k] {
        // On the hull the crossing is already a corner (U_e): a fan from it.
        PolygonKind::Dual
            if topo.dual_open[k]
                && matches!(
                    triangulation,
                    Triangulation::EdgeCrossing | Triangulation::MaxMinAngle
                ) =>
        {
            plan.fan(poly, n - 2);
        }
        PolygonKind::Dual if triangulation == Triangulation::MaxMinAngle => {
            cut_max_min_angle(plan, topo, k, positions, edge_ends);
        }
        PolygonKind::Dual if triangulation == Triangulation::Fan => plan.fan(poly, 0),
        PolygonKind::Dual => {
            let c = plan.add(if triangulation == Triangulation::EdgeCrossing {
                let (a, b) = topo.dual_edges[k];
                Added::Crossing(a, b)
            } else {
                Added::Centroid(k as u32)
            });
            plan.star(c, poly);
        }
        PolygonKind::Cap => {
            let w = poly
                .iter()
                .position(|&v| {
                    matches!(
                        topo.roles.get(v as usize),
                        Some(VertexRole::HullFace { .. })
                    )
                })
                .unwrap_or(0);
            plan.fan(poly, w);
        }
    }
}

/// Cuts the closed dual polygon `k` by [`Triangulation::MaxMinAngle`]: the best cut by
/// diagonals, else a star around its centroid, else a star around its edge's crossing.
///
/// The dual polygon must separate its edge's marked end from its unmarked end: a cut is
/// taken only if the edge passes through exactly one of its triangles, from the back to
/// the front. On the long, flat tetrahedra between drill holes a triangulation can miss
/// the edge altogether, and the body then folds (negative volumes measured on real drill
/// holes). The star around the edge's crossing always separates.
fn cut_max_min_angle(
    plan: &mut PlanBuilder,
    topo: &Topology,
    k: usize,
    positions: &[DVec3],
    edge_ends: &dyn Fn(u32, u32) -> (DVec3, DVec3),
) {
    let poly = topo.polygon(k);
    let n = poly.len();
    let pts: Vec<DVec3> = poly.iter().map(|&v| positions[v as usize]).collect();
    let (a, b) = topo.dual_edges[k];
    let (pa, pb) = edge_ends(a, b);
    let normal = newell_normal(&pts);
    let (mut best, diagonals) = if n == 3 {
        let t = [0, 1, 2];
        let score = triangle_score(pts[0], pts[1], pts[2], normal);
        (CutScore::triangle(score), vec![t])
    } else {
        max_min_angle_triangulation(&pts, normal)
    };
    if !best.folded() && !separates(pa, pb, diagonals.iter().map(|t| t.map(|i| pts[i]))) {
        best = CutScore::FOLDED;
    }
    let pts = &pts;
    let star = |centre: DVec3| (0..n).map(move |i| [centre, pts[i], pts[(i + 1) % n]]);
    let centroid = pts.iter().sum::<DVec3>() / n as f64;
    let mut centroid_score = star(centroid)
        .map(|[c, p, q]| CutScore::triangle(triangle_score(c, p, q, normal)))
        .fold(CutScore::EMPTY, CutScore::join);
    if !centroid_score.folded() && !separates(pa, pb, star(centroid)) {
        centroid_score = CutScore::FOLDED;
    }
    if !best.folded() && !centroid_score.better_than(best) {
        for [a, b, c] in diagonals {
            plan.triangles.push([poly[a], poly[b], poly[c]]);
        }
    } else {
        let c = plan.add(if !centroid_score.folded() {
            Added::Centroid(k as u32)
        } else {
            Added::Crossing(a, b)
        });
        plan.star(c, poly);
    }
}

/// Newell's normal of a (non-planar) polygon: twice its vector area.
fn newell_normal(pts: &[DVec3]) -> DVec3 {
    let n = pts.len();
    (0..n).fold(DVec3::ZERO, |acc, i| acc + pts[i].cross(pts[(i + 1) % n]))
}

/// The sine of a triangle's smallest angle (at most 60 degrees, so the sine orders
/// triangles as the angle does, without trigonometry), or -1 when it faces against
/// `normal` or is degenerate (so a fold scores below every triangle that does not fold).
fn triangle_score(a: DVec3, b: DVec3, c: DVec3, normal: DVec3) -> f64 {
    let cross = (b - a).cross(c - a);
    if cross.dot(normal) <= 0.0 {
        return -1.0;
    }
    // Twice the area over the two longer edges, which meet at the smallest angle.
    let [e0, e1, e2] = [
        (b - a).length_squared(),
        (c - b).length_squared(),
        (a - c).length_squared(),
    ];
    let shortest = e0.min(e1).min(e2);
    let longer = e0.max(e1).max(e2) * (e0 + e1 + e2 - e0.max(e1).max(e2) - shortest);
    let sine = cross.length() / longer.sqrt();
    if sine.is_finite() {
        sine.min(1.0)
    } else {
        -1.0
    }
}

/// Whether the segment `a -> b` passes through exactly one of `triangles`, entering at
/// its back (the side its winding's normal points away from) and leaving at its front.
/// Touching an edge or corner of a triangle counts as a failure.
fn separates(a: DVec3, b: DVec3, triangles: impl Iterator<Item = [DVec3; 3]>) -> bool {
    let d = b - a;
    let mut crossings = 0;
    for [p, q, r] in triangles {
        // Signs of the segment's passage around each triangle edge (Plücker-style
        // triple products): all positive or all negative means it passes through.
        let s0 = d.dot((q - a).cross(r - a));
        let s1 = d.dot((r - a).cross(p - a));
        let s2 = d.dot((p - a).cross(q - a));
        let through = (s0 > 0.0 && s1 > 0.0 && s2 > 0.0) || (s0 < 0.0 && s1 < 0.0 && s2 < 0.0);
        if !through {
            if s0 == 0.0 || s1 == 0.0 || s2 == 0.0 {
                // On an edge line: undecided, take the safe triangulation.
                let n = (q - p).cross(r - p);
                if n.dot(a - p).signum() != n.dot(b - p).signum() {
                    return false;
                }
            }
            continue;
        }
        // The line passes through the triangle; does the segment reach its plane?
        let n = (q - p).cross(r - p);
        let (ha, hb) = (n.dot(a - p), n.dot(b - p));
        if ha == 0.0 || hb == 0.0 {
            return false;
        }
        if ha < 0.0 && hb > 0.0 {
            crossings += 1;
        } else if ha > 0.0 && hb < 0.0 {
            return false;
        }
    }
    crossings == 1
}

/// The triangulation of the polygon `pts` (by diagonals, no added vertex) whose smallest
/// triangle angle is largest among those with no triangle facing against the polygon's
/// normal (dynamic programming over sub-polygons, O(n^3)); triangles as corner indices
/// wound like the polygon, and that smallest angle (-1 when every triangulation folds).
fn max_min_angle_triangulation(pts: &[DVec3], normal: DVec3) -> (CutScore, Vec<[usize; 3]>) {
    let n = pts.len();
    let score = |a, b, c| CutScore::triangle(triangle_score(a, b, c, normal));
    // best[i][j]: the best cut of the sub-polygon i..=j.
    let mut best = vec![CutScore::EMPTY; n * n];
    let mut split = vec![0usize; n * n];
    for len in 2..n {
        for i in 0..n - len {
            let j = i + len;
            let mut b: Option<CutScore> = None;
            for k in i + 1..j {
                let v = best[i * n + k].join(best[k * n + j]);
                if let Some(b) = b
                    && !b.folded()
                    && !v.could_beat(b)
                {
                    // The new triangle cannot make this split better than the best so far.
                    continue;
                }
                let v = v.join(score(pts[i], pts[k], pts[j]));
                if b.is_none_or(|b| v.better_than(b)) {
                    b = Some(v);
                    split[i * n + j] = k;
                }
            }
            best[i * n + j] = b.expect("a sub-polygon of 3 or more corners has a split");
        }
    }
    let mut out = Vec::with_capacity(n - 2);
    let mut stack = vec![(0usize, n - 1)];
    while let Some((i, j)) = stack.pop() {
        if j - i < 2 {
            continue;
        }
        let k = split[i * n + j];
        out.push([i, k, j]);
        stack.push((i, k));
        stack.push((k, j));
    }
    (best[n - 1], out)
}

/// Triangles whose smallest angle is under 10 degrees count as slivers (its sine).
const SLIVER_SINE: f64 = 0.173_648_177_666_930_33;

/// How good a cut of a polygon is: no triangle folded against the polygon's normal, then
/// the fewest slivers, then the largest smallest angle (as a sine, see [`triangle_score`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct CutScore {
    slivers: u32,
    min: f64,
}

impl CutScore {
    const EMPTY: Self = Self {
        slivers: 0,
        min: f64::INFINITY,
    };
    const FOLDED: Self = Self {
        slivers: 0,
        min: -1.0,
    };

    fn triangle(score: f64) -> Self {
        Self {
            slivers: u32::from(score < SLIVER_SINE),
            min: score,
        }
    }

    fn join(self, other: Self) -> Self {
        Self {
            slivers: self.slivers + other.slivers,
            min: self.min.min(other.min),
        }
    }

    fn folded(self) -> bool {
        self.min <= 0.0
    }

    fn better_than(self, other: Self) -> bool {
        match (self.folded(), other.folded()) {
            (false, true) => true,
            (true, false) => false,
            (true, true) => self.min > other.min,
            (false, false) => {
                self.slivers < other.slivers
                    || (self.slivers == other.slivers && self.min > other.min)
            }
        }
    }

    /// Whether adding one more triangle to this partial cut can still beat `other` (which
    /// is not folded): joining only adds slivers and lowers the smallest angle.
    fn could_beat(self, other: Self) -> bool {
        !self.folded()
            && (self.slivers < other.slivers
                || (self.slivers == other.slivers && self.min > other.min))
    }
}

/// Splits the triangles into connected bodies with compact vertex arrays and measures,
/// largest volume first.
fn split_bodies(
    topo: &Topology,
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    label: &[u32],
) -> Vec<Body> {
    let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
    order.par_sort_by_key(|&t| label[t as usize]);
    // Compact vertex numbering per body; bodies share no vertex, so one map serves all.
    let mut local = vec![u32::MAX; positions.len()];
    // (positions, triangles, truncated, region) of each body.
    type Part = (Vec<DVec3>, Vec<[u32; 3]>, bool, u32);
    let parts: Vec<Part> = order
        .chunk_by(|&a, &b| label[a as usize] == label[b as usize])
        .map(|group| {
            let mut body_positions = Vec::new();
            let mut truncated = false;
            let body_triangles = group
                .iter()
                .map(|&t| {
                    triangles[t as usize].map(|v| {
                        if local[v as usize] == u32::MAX {
                            let role = topo.roles.get(v as usize);
                            truncated |= role.is_some_and(|r| !matches!(r, VertexRole::Tet { .. }));
                            local[v as usize] = body_positions.len() as u32;
                            body_positions.push(positions[v as usize]);
                        }
                        local[v as usize]
                    })
                })
                .collect();
            (
                body_positions,
                body_triangles,
                truncated,
                label[group[0] as usize],
            )
        })
        .collect();
    let mut bodies: Vec<Body> = parts
        .into_par_iter()
        .map(|(positions, triangles, truncated, region)| Body {
            volume: measure::volume(&positions, &triangles),
            area: measure::area(&positions, &triangles),
            closed: measure::is_closed_and_oriented(&triangles),
            truncated,
            bbox: measure::bbox(&positions),
            positions,
            triangles,
            region,
            mt_fallback: false,
        })
        .collect();
    bodies.sort_by(|a, b| b.volume.total_cmp(&a.volume));
    bodies
}

/// A marked mesh vertex of polygon `k`: the marked end of a dual polygon's edge, or a
/// marked hull corner of a cap.
pub(crate) fn polygon_marked_point(topo: &Topology, k: usize) -> u32 {
    match topo.kinds[k] {
        PolygonKind::Dual => topo.dual_edges[k].0,
        PolygonKind::Cap => topo
            .polygon(k)
            .iter()
            .find_map(|&v| match topo.roles[v as usize] {
                VertexRole::HullPoint { point } => Some(point),
                _ => None,
            })
            .expect("a cap holds a marked hull corner"),
    }
}

#[cfg(test)]
pub(crate) mod tests;
