//! The `wellmesh` command line.
#![forbid(unsafe_code)]

fn main() {
    println!("wellmesh");
}
