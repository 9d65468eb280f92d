//! wellmesh: closed ore-body surfaces from well logs and drill holes.
//!
//! The pipeline, one room per stage (see `docs/architecture.md`):
//!
//! ```text
//! wells  -> SampleSet (points relative to a local origin, values, "don't know")
//! tet    -> TetMesh   (exact 3D Delaunay of the distinct sample points)
//! dmt    -> Shell     (Dual Marching Tetrahedra: closed, oriented bodies + measures)
//! export -> GLB, summary JSON and other formats
//! ```
//!
//! [`contour::run`] is the one function that the CLI, the service workers and the
//! tests all call. Geometry rooms (`wells`, `tet`, `dmt`, `export`) know nothing of
//! HTTP, async runtimes or databases.
#![deny(unsafe_code)]

pub mod api;
pub mod contour;
pub mod dmt;
pub mod export;
pub mod field;
pub mod grid;
pub mod jobs;
pub mod process;
pub mod progress;
pub mod report;
pub mod startup;
pub mod tet;
pub mod wells;
