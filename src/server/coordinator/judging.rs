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
pub const LOG_EVERY: f64 = 10.0;

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
}

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
    pub fn held(&self) -> bool {
        self.held.is_some()
    }

    /// The quarantine as `GET /api/v1/vessels` shows it.
    pub fn quarantine(&self) -> Option<QuarantineDocument> {
        self.held.as_ref().map(|h| h.document.clone())
    }

    /// Judges vessel `id`'s `pose`.
    pub fn judge(&mut self, id: &str, pose: &PoseDocument, bench: &Bench<'_>) -> Judged {
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
                held.document.refused += 1;
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
    pub fn hold_command(&self, tick: u64, at: Option<&PoseDocument>) -> Option<CommandDocument> {
        let held = self.held.as_ref()?;
        Some(CommandDocument {
            tick,
            u_d: 0.0,
            r_d: 0.0,
            u_d_dot: 0.0,
            r_d_dot: 0.0,
            centroid: at.map_or([0.0, 0.0], |p| [p.x, p.y]),
            e: 0.0,
            psi_e: 0.0,
            hold: Some(held.document.reason.clone()),
        })
    }
}
