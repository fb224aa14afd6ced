//! Helpers shared by the integration tests: the real binary on port 0
//! ([`server`], [`process`]), the coordinator in this process
//! ([`inprocess`]), vessel links ([`link`]) and positions placed by
//! geographiclib ([`geo`]). Some helpers serve only tests that skip without
//! their tool (ArduPilot, chromium), hence `dead_code` is allowed.
#![allow(dead_code)]

pub mod browser;
pub mod geo;
pub mod inprocess;
pub mod link;
pub mod process;
pub mod server;
