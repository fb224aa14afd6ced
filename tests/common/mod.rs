//! Helpers shared by the integration tests. Each file under `tests/` is a
//! crate of its own and uses a part of them, hence `dead_code` is allowed.
#![allow(dead_code)]

pub mod geo;
pub mod link;
pub mod process;
pub mod server;
