//! Helpers shared by the integration tests: the real binary on port 0
//! ([`server`], [`process`]), the coordinator in this process
//! ([`inprocess`]), vessel links ([`link`]), positions placed by
//! geographiclib ([`geo`]), and network namespaces as a radio medium with
//! the Python observer of peer fleets ([`netns`], [`peer`]), and ArduPilot
//! SITL boats with a ground station on each ([`sitl`]); the lock that
//! keeps the heavy ones from running side by side ([`machine`]). Some helpers
//! serve only tests that skip without their tool (ArduPilot, chromium,
//! root), hence `dead_code` is allowed.
#![allow(dead_code)]

pub mod browser;
pub mod fleet;
pub mod geo;
pub mod inprocess;
pub mod link;
pub mod machine;
pub mod netns;
pub mod paper;
pub mod peer;
pub mod process;
pub mod server;
pub mod sitl;
