//! Why a peer process could not start.

use std::path::PathBuf;

use crate::mission::MissionError;

/// Why a peer process could not start.
#[derive(Debug, thiserror::Error)]
pub enum PeerError {
    #[error("--fleet must match [A-Za-z0-9_.-]{{1,64}}")]
    Fleet,
    #[error("zenoh configuration: {0}")]
    Config(String),
    #[error("cannot read {path}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("the mission in {path}")]
    Mission { path: PathBuf, source: MissionError },
    #[error("the raster the mission in {path} names")]
    Raster {
        path: PathBuf,
        source: crate::raster::RasterError,
    },
    #[error(
        "a peer fleet's vessel id is at most 7 characters of [A-Za-z0-9_.-] (the beacon's 96 bytes): {0:?}"
    )]
    Id(String),
    #[error("zenoh: {0}")]
    Zenoh(String),
    #[error(
        "the fleet's mission revision {revision} could not be taken ({message}); \
         nothing was published: start with --replace-fleet-mission to replace it"
    )]
    Adopt { revision: u32, message: String },
}
