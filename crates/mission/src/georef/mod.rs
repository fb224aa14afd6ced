//! Geo-referenced documents: the shell between WGS84 and the mission's
//! local plane, on both sides of the engine. [`input`] places what clients
//! give in WGS84 (GeoJSON regions, risk objects and vessels at `lat`,
//! `lon`) in the plane; [`output`] draws a partition back as GeoJSON for
//! GIS tools. The plane itself is [`seacover_engine::geometry::geodesy`].
//!
//! Invariants:
//! - everything stored, computed and streamed stays in the local plane:
//!   conversion happens once, on the way in, and the stored documents are
//!   the local ones ([`seacover_protocol::RegionDocument`],
//!   [`seacover_protocol::RiskObjectDocument`]), so moving the origin moves
//!   nothing of the mission on the plane;
//! - a geographic position is used only within
//!   [`LocalFrame::RANGE`](seacover_engine::geometry::geodesy::LocalFrame::RANGE) of
//!   the origin, where the plane's distortion is documented; farther ones
//!   are refused naming the field;
//! - no I/O: documents in, documents out, like `mission::scenario`, which
//!   places a scenario's WGS84 parts through [`input`].

pub mod input;
pub mod output;
