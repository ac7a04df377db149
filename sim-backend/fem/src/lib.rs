//! A 2-D finite-element model of soft tissue with tumours and arteries.
//!
//! It reproduces the two seed FEM papers (`seeds/001`, `seeds/002`; DESIGN.md section 8):
//! plane stress or plane strain, 4-node bilinear quads with a mean-dilatation (B-bar)
//! treatment against locking, a mesher for a rectangle with a circular feature of concentric
//! layers, prescribed displacements, lumen pressure, a rigid indenter in frictionless contact,
//! an optional finite-strain neo-Hookean solve, and von Mises recovered at the top-edge nodes.
//! A model can also be solved on a user's Gmsh mesh (`gmsh`).
//! It also produces the surface pressure kernel the simulator can use instead of the analytic
//! one: the simulator (`pulsetrack-sim`) and the CLI depend on this crate, never the other
//! way. See docs/fem.md.

#![allow(clippy::needless_range_loop)] // index loops read like the formulas

pub mod boundary;
pub mod collapse;
pub mod contact;
pub mod element;
pub mod finger_penalty;
pub mod finite;
pub mod follower_pressure;
pub mod gmsh;
pub mod gmsh_build;
pub mod gmsh_check;
pub mod gmsh_guard;
pub mod gmsh_names;
pub mod kernel;
pub mod linear;
pub mod llt;
pub mod lumen_wall;
pub mod material;
pub mod mesh;
pub mod mesher;
pub mod model;
pub mod neo_hookean;
pub mod nested_dissection;
pub mod recovery;
pub mod run;
pub mod self_contact;
pub mod solve_error;
pub mod sparse;
pub mod split_cholesky;
pub mod study;
pub mod tactile;
pub mod vertex_separator;
