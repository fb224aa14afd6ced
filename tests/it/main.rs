//! seacover's integration tests, one crate: the library is linked once, and
//! every file here is a module of this one test binary (`cargo test --test
//! it`; `cargo test --test it recording::` runs one file's tests).
//!
//! The tests start real processes (`seacover serve`, `agent`, `sim`,
//! ArduPilot's SITL, chromium), real sockets and real clients; what several
//! files share is in [`common`]: the binary on port 0, an in-process
//! coordinator, vessel links, and positions placed by geographiclib.

mod common;

mod api_docs;
mod architecture;
mod ardupilot_learning;
mod ardupilot_peer;
mod ardupilot_quiet;
mod ardupilot_samples;
mod ardupilot_sitl;
mod ardupilot_split;
mod cli;
mod curved;
mod dashboard;
mod dashboard_fleet;
mod dashboard_learning;
mod dashboard_ux;
mod docs_numbers;
mod engine;
mod faults;
mod first_hour;
mod geo;
mod geodesy;
mod http_edge;
mod learning_server;
mod load;
mod network;
mod peer_coordinator;
mod peer_faults;
mod peer_fleet;
mod peer_learning;
mod peer_medium;
mod peer_partition;
mod peer_scale;
mod peer_trust;
mod persistence;
mod properties;
mod recording;
mod risk_raster;
mod safety;
mod shutdown;
mod sim;
mod sim_learning;
mod sitl_script;
mod soak;
mod tidy;
mod tracking;
mod valid_inputs;
