//! What a vessel of this process answers on its status key: what it
//! hears, refused and follows, for dashboards and tests.

use std::sync::Arc;
use std::time::Instant;

use super::super::board::Revision;
use super::super::split::Split;
use super::super::table::{Ageing, Table};
use crate::coverage::split::Water;
use crate::protocol::peer::{PeerStatusDocument, SplitWater};

/// Vessel `id`'s status, before the fields only its loop knows (`alone`,
/// `partition_since`, `learning`, `step_time`).
pub(super) fn status_document(
    table: &Table,
    ageing: &Ageing,
    id: &str,
    current: &Option<Arc<Revision>>,
    controlled: bool,
    partition: usize,
    split: &Split,
) -> PeerStatusDocument {
    let mut heard = table.ages(Instant::now(), ageing);
    heard.remove(id);
    PeerStatusDocument {
        id: id.to_string(),
        revision: current.as_ref().map(|r| r.revision),
        controlled,
        neighbours: partition,
        heard,
        refused: table.refused(),
        quarantined: table.quarantined(),
        received: table.received(),
        split: split.others(),
        split_water: split.water().map(|w| match w {
            Water::Region => SplitWater::Region,
            Water::Own => SplitWater::Own,
        }),
        alone: false,
        partition_since: None,
        learning: None,
        step_time: None,
    }
}
