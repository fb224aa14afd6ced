//! seacover: coverage control for fleets of unmanned surface vessels.
//!
//! Code map:
//! - [`geometry`] and [`coverage`]: the pure core (no I/O, deterministic,
//!   cannot fail on validated input): region, power partition, quadrature,
//!   mass / centroid / H(P);
//! - [`protocol`]: the serde types of everything that crosses the wire or the
//!   command line, and nothing else;
//! - [`scenario`]: the shell that turns a scenario document into validated core
//!   types and an evaluation back into its document;
//! - [`georef`]: WGS84 documents (GeoJSON, lat/lon) in and GeoJSON out,
//!   through the mission's local plane;
//! - [`demo`]: `seacover demo`, the coordinator and eight simulated vessels
//!   on loopback in one process;
//! - [`load`]: `seacover bench load`, a load benchmark of a running coordinator;
//! - [`recorder`]: every run recorded as MCAP on a thread of its own, and
//!   read back (replay, `seacover record`).

pub mod agent;
pub mod demo;
pub mod load;
pub mod mission;
pub mod protocol;
pub mod recorder;
pub mod server;
pub mod sim;

pub use seacover_engine::{control, coverage, geometry};
