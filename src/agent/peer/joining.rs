//! Joining the fleet: when a vessel that hears its neighbours starts to
//! cover.
//!
//! Invariant: a vessel covers only after hearing no new member for
//! `stale_after` of mission time, or after three times that since it
//! began to hear the fleet, whichever comes first (docs/peer.md,
//! "Running it").

/// A vessel that has just started, or hears the fleet again after hearing
/// nobody, hears its neighbours one by one as their beacons (and, at
/// start, Zenoh's discovery) reach it. A cell computed from the first few
/// is far larger than its own and sends the boat across others' water; in
/// the paper's fleet it also decides which of two vessels takes a cell,
/// and so which optimum the fleet ends in. So it covers only once it has
/// heard no new member for `stale_after` (any vessel in range has
/// beaconed by then), and holds at most three times that.
#[derive(Debug, Clone, Copy)]
pub(super) struct Joining {
    /// Mission time it began to hear the fleet.
    pub(super) began: f64,
    /// Mission time the last new member was heard.
    pub(super) newest: f64,
    /// Members heard so far.
    pub(super) heard: usize,
}

impl Joining {
    /// How long joining lasts at most, in `stale_after`s.
    const LONGEST: f64 = 3.0;
    /// At start: joining begins at the first tick with a mission.
    pub(super) const START: Joining = Joining {
        began: f64::NAN,
        newest: f64::NAN,
        heard: 0,
    };

    /// Whether the vessel, hearing `heard` others at `t`, is done joining.
    pub(super) fn settled(&mut self, heard: usize, t: f64, stale_after: f64) -> bool {
        if self.began.is_nan() {
            (self.began, self.newest) = (t, t);
        }
        if heard > self.heard {
            self.heard = heard;
            self.newest = t;
        }
        t - self.newest >= stale_after || t - self.began >= Self::LONGEST * stale_after
    }
}

#[cfg(test)]
mod tests {
    use super::Joining;

    #[test]
    fn covers_once_no_new_member_is_heard_for_stale_after() {
        let mut j = Joining::START;
        assert!(!j.settled(1, 10.0, 3.0));
        assert!(!j.settled(3, 11.0, 3.0), "a new member restarts the wait");
        assert!(!j.settled(3, 13.9, 3.0));
        assert!(j.settled(3, 14.0, 3.0));
    }

    #[test]
    fn a_member_lost_and_heard_again_is_not_new() {
        let mut j = Joining::START;
        assert!(!j.settled(4, 0.0, 3.0));
        assert!(!j.settled(3, 1.0, 3.0));
        assert!(!j.settled(4, 2.0, 3.0));
        assert!(j.settled(4, 3.0, 3.0));
    }

    #[test]
    fn joining_lasts_at_most_three_stale_afters() {
        let mut j = Joining::START;
        for i in 0..9 {
            assert!(!j.settled(i + 1, f64::from(i as u8), 3.0), "at {i} s");
        }
        assert!(j.settled(10, 9.0, 3.0));
    }
}
