//! The tick task's answers to a hello and to an operator's change: what
//! may join the fleet, and what a change of mission tells the fleet.
//!
//! Invariants: an entry's actuator and agility are within the engine's
//! bounds; a change is durable before it is applied and answered; a
//! coordinator whose mission is only its start-up default re-tasks no
//! vessel that names another mission, until an operator changes it.

use super::{
    Coordinator, CoordinatorError, Entry, Hello, Outgoing, Request, judging, mission_name,
};
use crate::control::guidance::{Agility, Guidance};
use crate::mission::{ChangeResult, MissionChange};
use crate::protocol::{AgilityDocument, CoordinatorMessage};

/// The largest `station_radius` a hello may declare [m]: a vessel handed
/// its goal from farther would cross water the coordinator no longer
/// steers it through.
const MAX_STATION_RADIUS: f64 = 20.0;

/// A link hears of its refused samples at most this often [mission s].
const SAMPLE_NOTICE_EVERY: f64 = 10.0;

fn agility(declared: Option<AgilityDocument>) -> Result<Agility, CoordinatorError> {
    let Some(a) = declared else {
        return Ok(Agility::UNDECLARED);
    };
    let ok = |x: f64| x.is_finite() && x > 0.0;
    if !(ok(a.yaw_accel) && ok(a.surge_accel)) {
        return Err(CoordinatorError::Hello(
            "agility: yaw_accel and surge_accel must be finite numbers > 0".into(),
        ));
    }
    Ok(Agility {
        yaw_accel: a.yaw_accel,
        surge_accel: a.surge_accel,
    })
}

impl Coordinator {
    /// Judges vessel `id`'s hello and makes (or finds) its entry; a link it
    /// had before is told it is replaced. The caller gives it its link.
    pub(super) fn register(
        &mut self,
        id: String,
        hello: Hello,
    ) -> Result<&mut Entry, CoordinatorError> {
        let actuator = hello.actuator.unwrap_or(self.mission.actuator());
        let agility = agility(hello.agility)?;
        if let Some(r) = hello.station_radius
            && !(r.is_finite() && r > 0.0 && r <= MAX_STATION_RADIUS)
        {
            return Err(CoordinatorError::Hello(format!(
                "station_radius: must be a finite number in (0, {MAX_STATION_RADIUS}] m, got {r}"
            )));
        }
        // The engine's bounds: a vessel outside them would make every
        // tick's fleet invalid. Vessels may have different β (cells with
        // curved edges).
        use crate::coverage::fleet::{MAX_BETA, MAX_K, MAX_VESSELS};
        let out_of_range = [("k", actuator.k, MAX_K), ("beta", actuator.beta, MAX_BETA)]
            .into_iter()
            .find(|&(_, x, max)| !(x.is_finite() && x > 0.0 && x <= max));
        if let Some((field, value, max)) = out_of_range {
            return Err(CoordinatorError::Hello(format!(
                "actuator.{field}: must be a finite number in (0, {max:e}], got {value}"
            )));
        }
        if !self.vessels.contains_key(&id) && self.vessels.len() >= MAX_VESSELS {
            return Err(CoordinatorError::Full(MAX_VESSELS));
        }
        let time = self.time();
        let gains = self.mission.guidance();
        let entry = self.vessels.entry(id.clone()).or_insert_with(|| Entry {
            actuator,
            link: None,
            pose: None,
            last_seen_tick: None,
            guidance: Guidance::new(gains),
            last_command: None,
            neighbours: None,
            standing: judging::Standing::default(),
            sample_notice: None,
        });
        if let Some(old) = entry.link.take() {
            let _ = old.tx.try_send(
                CoordinatorMessage::Error {
                    code: "replaced".into(),
                    message: "another link for this vessel connected".into(),
                }
                .into(),
            );
        }
        entry.actuator = actuator;
        entry.guidance.ahead_only = !hello.astern;
        entry.guidance.agility = agility;
        entry.guidance.station_radius = hello.station_radius;
        if let Some(followed) = hello.mission.as_deref()
            && self.provisional
            && followed != self.name
            && !entry.standing.is_stray()
        {
            entry
                .standing
                .hold_stray(&id, followed, time, &self.recorder);
        }
        Ok(entry)
    }

    /// Applies an operator's change: stored first (a change the store
    /// refuses is not applied, and one that is answered survives a crash),
    /// then applied, recorded, named to every link, and shown to readers
    /// at once. The commit blocks this task for one fsync (a few ms);
    /// writes are rate-limited, so the tick loses at most that, and
    /// changes stay in one order.
    pub(super) fn change(
        &mut self,
        change: &MissionChange,
    ) -> Result<ChangeResult, CoordinatorError> {
        let (next, answer) = self.mission.changed(change)?;
        if let Some(store) = &self.store {
            store.apply(change, &answer).map_err(|e| {
                tracing::error!(error = %crate::chain::Chain(&e), "a mission change could not be stored");
                CoordinatorError::Storage(e)
            })?;
        }
        self.mission = next;
        if let Some(l) = &mut self.learning {
            l.mission_changed();
        }
        let document = self.mission.document();
        self.name = mission_name(&document);
        let time = self.time();
        self.recorder.mission(time, document);
        // An operator's act makes the mission the fleet's: vessels held
        // for following another take this one.
        let released = std::mem::take(&mut self.provisional);
        for (id, entry) in &mut self.vessels {
            if released {
                entry.standing.unstray(id, time, &self.recorder);
            }
            if let Some(link) = &entry.link {
                let named = CoordinatorMessage::Mission {
                    mission: self.name.clone(),
                };
                let _ = link.tx.try_send(Outgoing::Notice(named));
            }
        }
        let live = self.live_ids();
        let evaluation = self.evaluate_live(&live);
        self.publish(time, &live, evaluation.as_ref());
        Ok(answer)
    }

    /// A sample from vessel `vessel`'s link, stamped with the mission's
    /// time; a refusal (or a coordinator that does not learn) is answered
    /// on that link as an `error` that leaves it open.
    pub(super) fn link_sample(&mut self, vessel: String, s: crate::protocol::LinkSampleDocument) {
        let now = self.time();
        let doc = crate::protocol::SampleDocument {
            vessel: vessel.clone(),
            t: now,
            x: s.x,
            y: s.y,
            value: s.value,
            sd: s.sd,
        };
        // A sample is where its vessel is: while the vessel's own poses are
        // refused (or none has been believed yet), so is its samples'
        // position.
        let unplaced = self
            .vessels
            .get(&vessel)
            .is_none_or(|e| e.standing.held() || e.pose.is_none());
        let refusal = match &mut self.learning {
            Some(_) if unplaced => {
                metrics::counter!(crate::server::metrics::SAMPLES, "outcome" => "unplaced")
                    .increment(1);
                Some((
                    "unplaced".to_string(),
                    "the vessel's poses are refused (or none believed yet): so are its samples"
                        .to_string(),
                ))
            }
            Some(l) => l
                .take(vec![doc], &self.mission, now, &self.recorder)
                .refused
                .pop()
                .map(|r| (r.code, r.reason)),
            None => Some((
                "not_learning".to_string(),
                CoordinatorError::NotLearning.to_string(),
            )),
        };
        let Some(entry) = self.vessels.get_mut(&vessel) else {
            return;
        };
        // Every refusal is counted; the link hears of them at most once
        // every SAMPLE_NOTICE_EVERY mission seconds (a sensor at 1 Hz would
        // otherwise fill its log).
        let quiet = entry
            .sample_notice
            .is_some_and(|at| now - at < SAMPLE_NOTICE_EVERY);
        if let (Some((code, message)), Some(link), false) = (refusal, &entry.link, quiet) {
            let error = CoordinatorMessage::Error {
                code: format!("sample_{code}"),
                message,
            };
            let _ = link.tx.try_send(Outgoing::Notice(error));
            entry.sample_notice = Some(now);
        }
    }

    /// The learner's requests: samples posted, the newest samples, the
    /// belief.
    pub(super) fn on_learning_request(&mut self, request: Request) {
        match request {
            Request::Samples { samples, reply } => {
                let now = self.time();
                let outcome = match &mut self.learning {
                    Some(l) => Ok(l.take(samples, &self.mission, now, &self.recorder)),
                    None => Err(CoordinatorError::NotLearning),
                };
                let _ = reply.send(outcome);
            }
            Request::RecentSamples { reply } => {
                let recent = match &self.learning {
                    Some(l) => Ok(l.recent()),
                    None => Err(CoordinatorError::NotLearning),
                };
                let _ = reply.send(recent);
            }
            Request::Belief { reply } => {
                let doc = match &self.learning {
                    Some(l) => l.document(&self.mission),
                    None => super::learning::Learning::unlearned(&self.mission),
                };
                let _ = reply.send(doc);
            }
            _ => {}
        }
    }
}
