//! The mission as a peer fleet shares it: every member keeps the highest
//! valid revision it has seen and answers queries with it.
//!
//! Invariants: the board's mission only ever moves to a higher revision; a
//! document that fails the mission layer's validation
//! (`Mission::from_document`, the same as a REST write) is refused and
//! changes nothing; the bytes it answers with are the document it took.

use std::sync::Arc;

use super::wire::Refusal;
use crate::mission::Mission;
use crate::protocol::peer::PeerMissionDocument;

/// One revision of the mission.
#[derive(Debug, Clone)]
pub struct Revision {
    pub revision: u32,
    pub mission: Mission,
    /// Its JSON, as published and answered.
    pub json: Arc<Vec<u8>>,
}

/// The newest valid revision, if any.
#[derive(Debug, Default)]
pub struct Board {
    current: Option<Arc<Revision>>,
}

impl Board {
    pub fn current(&self) -> Option<Arc<Revision>> {
        self.current.clone()
    }

    /// Takes `doc` if it is valid and newer; `Ok(true)` when it replaced
    /// the mission, `Ok(false)` when it is the revision already held.
    pub fn offer(&mut self, doc: PeerMissionDocument) -> Result<bool, Refusal> {
        if let Some(c) = &self.current {
            if doc.revision == c.revision && doc.mission == c.mission.document() {
                return Ok(false);
            }
            if doc.revision <= c.revision {
                return Err(Refusal::MissionOlder);
            }
        }
        let mission = Mission::from_document(&doc.mission).map_err(|_| Refusal::MissionInvalid)?;
        let json = serde_json::to_vec(&doc).expect("documents serialize");
        self.current = Some(Arc::new(Revision {
            revision: doc.revision,
            mission,
            json: Arc::new(json),
        }));
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn doc(revision: u32) -> PeerMissionDocument {
        PeerMissionDocument {
            revision,
            mission: Mission::paper().document(),
            by: None,
            at: None,
        }
    }

    #[test]
    fn higher_revisions_win_and_invalid_ones_change_nothing() {
        let mut board = Board::default();
        assert_eq!(board.offer(doc(3)), Ok(true));
        assert_eq!(board.offer(doc(3)), Ok(false));
        assert_eq!(board.offer(doc(2)), Err(Refusal::MissionOlder));
        let mut bad = doc(9);
        bad.mission.tick_hz = -1.0;
        assert_eq!(board.offer(bad), Err(Refusal::MissionInvalid));
        assert_eq!(board.current().unwrap().revision, 3);
        assert_eq!(board.offer(doc(4)), Ok(true));
        assert_eq!(board.current().unwrap().revision, 4);
    }
}
