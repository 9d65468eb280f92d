//! Temporary until the Delaunay room lands.
use glam::DVec3;

use super::TetMesh;
use crate::progress::Progress;

#[derive(Debug, thiserror::Error)]
pub enum TetError {
    #[error("not built yet")]
    NotBuilt,
}

pub fn delaunay(_points: &[DVec3], _progress: &dyn Progress) -> Result<TetMesh, TetError> {
    Err(TetError::NotBuilt)
}
