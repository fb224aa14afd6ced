//! seacover's engine: the pure core of coverage control for fleets of
//! unmanned surface vessels, usable as a library by itself.
//!
//! - [`geometry`]: the validated task region (convex or not, with islands),
//!   convex clipping, quadrature rules, the shore and its route map, WGS84 ⇄
//!   the mission's local plane;
//! - [`coverage`]: the risk density Φ, the vessels' actuators f_i, the
//!   generalized Voronoi (power) partition, each cell's mass, centroid, area
//!   and gradient, and the coverage metric H(P);
//! - [`control`]: the 3-DOF vessel model, disturbances, the finite-time
//!   disturbance observer, the robust controller, guidance, the on-board
//!   reference governor and the safety layer.
//! - [`learning`]: the risk density learned from point samples, as a base
//!   plus non-negative Gaussians with an uncertainty.
//!
//! The `evaluate` example builds a scenario with this API alone and prints
//! its partition, H and centroids:
//! `cargo run -p seacover-engine --example evaluate`.
//!
//! Invariants (the crate's dependencies enforce the first):
//! - no async, no I/O, no clocks, no serde: documents and processes live in
//!   the `seacover` crate above;
//! - deterministic: the same input gives bit-identical output, on one core
//!   or many;
//! - validation happens once, in constructors that return typed errors
//!   naming the field; after that, computations cannot fail: an empty cell
//!   is a result, never an error, a panic or a NaN.

// The engine is usable as a library by itself, so everything it exports says what it is.
#![warn(missing_docs)]

pub mod control;
pub mod coverage;
pub mod geometry;
pub mod learning;
