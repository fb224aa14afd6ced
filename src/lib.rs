//! seacover: coverage control for fleets of unmanned surface vessels.
//!
//! Code map, in layers: each uses only the layers above it in this list
//! (`tests/it/architecture.rs` checks it).
//! - core, the [`seacover_engine`] crate, re-exported here as [`geometry`],
//!   [`coverage`] and [`control`]: region, power partition, quadrature,
//!   mass / centroid / H(P), the vessel model, observer, controller,
//!   guidance and safety layer; no async, no I/O, no serde, deterministic,
//!   cannot fail on validated input;
//! - [`protocol`], the [`seacover_protocol`] crate: the serde types of
//!   everything that crosses the wire or the command line, and nothing else;
//! - [`mission`], the [`seacover_mission`] crate: the mission model and its
//!   changes, documents ⇄ core types (scenarios, WGS84 documents), the
//!   mission clock and the built-in scenarios; no I/O, its own errors;
//! - [`recorder`]: every run recorded as MCAP on a thread of its own, and
//!   read back (replay, `seacover record`); nobody waits on its disk;
//! - the shell: [`sim`] (the closed loop in one process), [`agent`]
//!   (simulated vessels and the MAVLink bridge on coordinator links),
//!   [`server`] (the coordinator: one tick task owns the state), [`load`]
//!   (`seacover bench load`) and [`raster`] (GeoTIFF risk maps fitted as a
//!   mission's risk);
//! - [`demo`]: `seacover demo`, the coordinator and eight simulated vessels
//!   on loopback in one process.
//!
//! The binary (`src/bin/seacover/`) is one file per subcommand over this
//! library.

pub mod agent;
pub mod chain;
pub mod demo;
pub mod load;
pub mod raster;
pub mod recorder;
pub mod server;
pub mod sim;

pub use seacover_engine::{control, coverage, geometry, learning};
pub use seacover_mission as mission;
pub use seacover_protocol as protocol;
