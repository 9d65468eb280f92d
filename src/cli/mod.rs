//! Subcommands of the `wellmesh` binary, one file each.

pub mod contour;
pub mod grid_input;
pub mod input;
pub mod inspect;
pub mod openapi;
pub mod outputs;
pub mod serve;
pub mod tetrahedralize;
pub mod worker;

/// Exit code for an error the user can fix (bad input, bad arguments are clap's 2).
pub const EXIT_FAILURE: u8 = 1;
