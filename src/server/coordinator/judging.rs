//! Each vessel's poses judged on their own before the partition sees them
//! ([`crate::control::plausibility`]): a refused pose quarantines its vessel
//! alone (out of the partition, commanded to hold, shown with the reason in
//! `GET /api/v1/vessels`, the dashboard, `/metrics` and the recording) and
//! the rest of the fleet goes on; consistent poses bring it back.
//!
//! Invariants: only a pose [`Standing::judge`] believed becomes a vessel's
//! pose, so every position the partition is given is finite and inside the
//! engine's coordinates, and no vessel's input can make the fleet invalid;
//! every refusal is counted, answered on the vessel's link and recorded;
//! log lines are at most one per vessel per [`LOG_EVERY`] mission seconds.

use crate::control::plausibility::{Fault, Fix, Judge, Limits, Sample, Verdict};
use crate::geometry::region::Region;
use crate::protocol::{
    CommandDocument, CoordinatorMessage, FixDocument, PoseDocument, QuarantineDocument,
};
use crate::recorder::Recorder;
use crate::recorder::messages::{EventKind, EventRecord};

/// A vessel's repeated refusals are logged at most this often [mission s].
pub(super) const LOG_EVERY: f64 = 10.0;

/// What a pose is judged against, at one tick.
pub(super) struct Bench<'a> {
    pub limits: &'a Limits,
    pub region: &'a Region,
    /// Mission time of the tick [s].
    pub time: f64,
    pub recorder: &'a Recorder,
}

/// A vessel's standing: its judge and, while it lasts, its quarantine.
#[derive(Debug, Clone, Default)]
pub(super) struct Standing {
    judge: Judge,
    held: Option<Held>,
    /// Held because it follows a mission this coordinator does not hold
    /// (see [`Standing::hold_stray`]); its poses do not end it, an operator's
    /// change does.
    stray: Option<Stray>,
}

#[derive(Debug, Clone)]
struct Stray {
    document: QuarantineDocument,
    /// Where it is held: its first believed position once held (its poses
    /// are still believed, so the hold point must not follow them).
    anchor: Option<[f64; 2]>,
}

/// [`QuarantineDocument::code`] of a vessel held by [`Standing::hold_stray`].
pub(super) const UNKNOWN_MISSION: &str = "unknown_mission";

#[derive(Debug, Clone)]
struct Held {
    document: QuarantineDocument,
    /// Mission time of the last log line about it.
    logged: f64,
}

/// What became of one pose.
pub(super) struct Judged {
    /// Believed: it is the vessel's pose now.
    pub believed: bool,
    /// A refusal to answer on the vessel's link (not fatal: the link stays
    /// up, so that the vessel can be held and come back).
    pub notice: Option<CoordinatorMessage>,
}

fn sample(p: &PoseDocument) -> Sample {
    Sample {
        t: p.t,
        x: p.x,
        y: p.y,
        psi: p.psi,
        u: p.u,
        v: p.v,
        r: p.r,
    }
}

fn fix(p: &PoseDocument) -> Fix {
    match p.fix {
        None => Fix::Unreported,
        Some(FixDocument::Good) => Fix::Good,
        Some(FixDocument::NoFix) => Fix::NoFix,
        Some(FixDocument::Estimator) => Fix::Estimator,
    }
}

impl Standing {
    /// Out of the partition and held.
    pub(super) fn held(&self) -> bool {
        self.held.is_some() || self.stray.is_some()
    }

    /// The quarantine as `GET /api/v1/vessels` shows it: a stray mission
    /// first, since consistent poses do not end it.
    pub(super) fn quarantine(&self) -> Option<QuarantineDocument> {
        self.stray
            .as_ref()
            .map(|s| s.document.clone())
            .or_else(|| self.held.as_ref().map(|h| h.document.clone()))
    }

    /// Holds vessel `id`, which says it follows mission `followed`, not
    /// this coordinator's: a coordinator that only has its start-up
    /// default (a fresh store) must not re-task a fleet at sea.
    pub(super) fn hold_stray(&mut self, id: &str, followed: &str, time: f64, recorder: &Recorder) {
        let reason = format!(
            "follows mission {followed}, which this coordinator does not hold (it started \
             without a stored mission): put a mission to re-task the fleet"
        );
        tracing::warn!(vessel = %id, %reason, "held: it follows another mission");
        recorder.event(
            EventRecord::new(time, EventKind::Quarantined)
                .vessel(id)
                .code(UNKNOWN_MISSION)
                .detail(reason.clone()),
        );
        self.stray = Some(Stray {
            document: QuarantineDocument {
                code: UNKNOWN_MISSION.to_string(),
                reason,
                since: time,
                refused: 0,
            },
            anchor: None,
        });
    }

    /// Held by [`Standing::hold_stray`].
    pub(super) fn is_stray(&self) -> bool {
        self.stray.is_some()
    }

    /// Ends a [`Standing::hold_stray`] hold, if there is one (an operator
    /// changed the mission).
    pub(super) fn unstray(&mut self, id: &str, time: f64, recorder: &Recorder) {
        if self.stray.take().is_none() {
            return;
        }
        tracing::info!(vessel = %id, "the mission was put: no longer held for following another");
        recorder.event(
            EventRecord::new(time, EventKind::Released)
                .vessel(id)
                .code(UNKNOWN_MISSION),
        );
    }

    /// Judges vessel `id`'s `pose`.
    pub(super) fn judge(&mut self, id: &str, pose: &PoseDocument, bench: &Bench<'_>) -> Judged {
        let verdict = self
            .judge
            .judge(&sample(pose), fix(pose), bench.limits, Some(bench.region));
        match verdict {
            Verdict::Accepted => {
                if let Some(held) = self.held.take() {
                    tracing::info!(vessel = %id, refused = held.document.refused, "poses agree again: back in the partition");
                    bench.recorder.event(
                        EventRecord::new(bench.time, EventKind::Released)
                            .vessel(id)
                            .code(held.document.code),
                    );
                }
                Judged {
                    believed: true,
                    notice: None,
                }
            }
            Verdict::Probation(_) => Judged {
                believed: false,
                notice: None,
            },
            Verdict::Refused(fault) => Judged {
                believed: false,
                notice: Some(self.refused(id, fault, bench)),
            },
        }
    }

    fn refused(&mut self, id: &str, fault: Fault, bench: &Bench<'_>) -> CoordinatorMessage {
        let reason = format!("pose refused: {fault}");
        metrics::counter!(crate::server::metrics::POSES_REFUSED, "reason" => fault.code())
            .increment(1);
        match &mut self.held {
            Some(held) => {
                // The latest refusal is what the operator must fix now (a
                // jump may be followed by a lost fix); `since` keeps the first.
                held.document.refused += 1;
                held.document.code = fault.code().to_string();
                held.document.reason.clone_from(&reason);
                if bench.time - held.logged >= LOG_EVERY {
                    held.logged = bench.time;
                    tracing::warn!(vessel = %id, code = fault.code(), %reason, refused = held.document.refused, "still in quarantine");
                }
            }
            None => {
                tracing::warn!(vessel = %id, code = fault.code(), %reason, "quarantined: out of the partition and held");
                bench.recorder.event(
                    EventRecord::new(bench.time, EventKind::Quarantined)
                        .vessel(id)
                        .code(fault.code())
                        .detail(reason.clone()),
                );
                self.held = Some(Held {
                    document: QuarantineDocument {
                        code: fault.code().to_string(),
                        reason: reason.clone(),
                        since: bench.time,
                        refused: 1,
                    },
                    logged: bench.time,
                });
            }
        }
        CoordinatorMessage::Error {
            code: "implausible".into(),
            message: format!("{reason}; held until consistent poses come"),
        }
    }

    /// While quarantined, the command that holds the vessel where it was
    /// last believed to be (`at`: its believed pose, if it had one).
    pub(super) fn hold_command(
        &mut self,
        tick: u64,
        at: Option<&PoseDocument>,
    ) -> Option<CommandDocument> {
        let here = at.map(|p| [p.x, p.y]);
        let (reason, centroid) = match (&mut self.stray, &self.held) {
            (Some(stray), _) => {
                if stray.anchor.is_none() {
                    stray.anchor = here;
                }
                (stray.document.reason.clone(), stray.anchor)
            }
            (None, Some(held)) => (held.document.reason.clone(), here),
            (None, None) => return None,
        };
        Some(CommandDocument {
            tick,
            u_d: 0.0,
            r_d: 0.0,
            u_d_dot: 0.0,
            r_d_dot: 0.0,
            centroid: centroid.unwrap_or([0.0, 0.0]),
            e: 0.0,
            psi_e: 0.0,
            hold: Some(reason),
            station: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Point;

    fn pose(t: f64, x: f64) -> PoseDocument {
        PoseDocument {
            t,
            x,
            y: 50.0,
            psi: 0.0,
            u: 0.0,
            v: 0.0,
            r: 0.0,
            fix: None,
            controlled: None,
            telemetry: None,
        }
    }

    #[test]
    fn a_quarantine_shows_its_latest_refusal_and_when_it_began() {
        let p = |x, y| Point { x, y };
        let region = Region::new(
            vec![p(0.0, 0.0), p(100.0, 0.0), p(100.0, 100.0), p(0.0, 100.0)],
            vec![],
        )
        .unwrap();
        let recorder = Recorder::off();
        let limits = Limits::default();
        let bench = |time| Bench {
            limits: &limits,
            region: &region,
            time,
            recorder: &recorder,
        };
        let mut standing = Standing::default();
        for i in 0..5 {
            let t = f64::from(i) * 0.1;
            assert!(standing.judge("a", &pose(t, 50.0), &bench(t)).believed);
        }
        let jumped = standing.judge("a", &pose(0.5, 90.0), &bench(0.5));
        assert!(!jumped.believed && jumped.notice.is_some());
        assert_eq!(standing.quarantine().unwrap().code, "jump");
        let beyond = standing.judge("a", &pose(0.6, 2e7), &bench(0.6));
        assert!(!beyond.believed);
        let q = standing.quarantine().unwrap();
        assert_eq!(
            (q.code.as_str(), q.since, q.refused),
            ("out_of_range", 0.5, 2),
            "{q:?}"
        );
        assert!(q.reason.contains("1e7"), "{q:?}");
    }
}
