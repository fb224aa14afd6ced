//! Helpers shared by the integration tests: the real binary on port 0
//! ([`server`], [`process`]), the coordinator in this process
//! ([`inprocess`]), vessel links ([`link`]), positions placed by
//! geographiclib ([`geo`]), and network namespaces as a radio medium with
//! the Python observer of peer fleets ([`netns`], [`peer`]) and what their
//! encryption is judged by ([`secure`]), and ArduPilot
//! SITL boats with a ground station on each ([`sitl`]), also each with its
//! bridge in a namespace of its own on a medium ([`sitl_medium`]), and how
//! still they are ([`sitl_quiet`]); the lock
//! that keeps the heavy ones from running side by side ([`machine`]). Some
//! helpers serve only tests that skip without their tool (ArduPilot,
//! chromium, root), hence `dead_code` is allowed.
#![allow(dead_code)]

pub(crate) mod browser;
pub(crate) mod fleet;
pub(crate) mod geo;
pub(crate) mod inprocess;
pub(crate) mod link;
pub(crate) mod machine;
pub(crate) mod netns;
pub(crate) mod paper;
pub(crate) mod peer;
pub(crate) mod process;
pub(crate) mod range;
pub(crate) mod schema;
pub(crate) mod secure;
pub(crate) mod server;
pub(crate) mod sitl;
pub(crate) mod sitl_medium;
pub(crate) mod sitl_quiet;
