//! Learning the risk map in the coordinator (docs/learning.md): samples
//! judged per vessel, a window of the newest, fits on a thread of their
//! own beside the tick, and the belief the fleet covers.
//!
//! Invariants:
//! - a refused sample is never learned from; each refusal is answered by
//!   its index and code, and counted by code in
//!   `seacover_samples_total{outcome}`;
//! - one vessel's flood is refused for that vessel alone (a token bucket
//!   each, in mission time);
//! - memory is bounded: at most [`WINDOW`] samples (the newest), their
//!   [`RECENT`] newest as documents for the dashboard, and [`MAX_SOURCES`]
//!   buckets;
//! - the recording holds every sample taken and every refused one but
//!   floods (those only counted: a flooding sensor must not fill the
//!   disk), and every belief as it is taken up;
//! - the tick never waits on a fit: a fit runs on the learner's thread
//!   and its belief is taken up by the first tick after it ends; the
//!   mission's own risk is covered until the first fit, and is the fit's
//!   prior.

use std::collections::{HashMap, VecDeque};
use std::sync::mpsc;

use crate::coverage::RiskField;
use crate::geometry::Point;
pub use crate::learning::LearnSettings;
use crate::learning::{Lattice, Learner, Params, Sample};
use crate::mission::Mission;
use crate::mission::belief::{risk_document, uncertainty};
use crate::protocol::{
    BeliefDocument, SampleDocument, SampleRefusalDocument, SamplesAnswerDocument, SamplesDocument,
    UncertaintyDocument,
};
use crate::recorder::Recorder;

/// The newest samples the learner keeps.
const WINDOW: usize = 20_000;
/// The newest samples kept as documents (`GET /api/v1/samples`).
const RECENT: usize = 500;
/// Vessels (sample sources) whose rate is tracked at once.
const MAX_SOURCES: usize = 4_096;
/// A vessel's samples per mission second, and its burst.
const RATE: f64 = 20.0;
const BURST: f64 = 200.0;
/// Samples this far outside the region's bounding box are refused [m].
const MARGIN: f64 = 50.0;
/// Samples older than this are refused as stale [mission s].
const MAX_AGE: f64 = 600.0;
/// Samples from later than this ahead of the mission's clock are refused
/// as from the future [mission s].
const MAX_AHEAD: f64 = 5.0;

/// A vessel's token bucket.
#[derive(Debug, Clone, Copy)]
struct Bucket {
    tokens: f64,
    at: f64,
}

/// What the learner's thread is asked to fit.
struct Job {
    lattice: Lattice,
    prior: RiskField,
    params: Params,
    samples: Vec<Sample>,
    kappa: f64,
    at: f64,
    /// The region's bounding box, where the uncertainty is mapped.
    bounds: (Point, Point),
}

/// A fit's result.
struct Fitted {
    density: RiskField,
    kappa: f64,
    uncertainty: UncertaintyDocument,
    at: f64,
}

/// The learner's thread: one fit at a time.
struct Worker {
    jobs: Option<mpsc::SyncSender<Job>>,
    results: mpsc::Receiver<Fitted>,
    busy: bool,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Worker {
    fn start() -> Worker {
        let (jobs, inbox) = mpsc::sync_channel::<Job>(1);
        let (done, results) = mpsc::channel();
        let thread = std::thread::Builder::new()
            .name("seacover-learner".into())
            .spawn(move || {
                while let Ok(job) = inbox.recv() {
                    let mut learner = Learner::new(job.lattice, job.prior, job.params);
                    for s in job.samples {
                        learner.add(s);
                    }
                    let belief = learner.fit();
                    let (min, max) = job.bounds;
                    if done
                        .send(Fitted {
                            density: belief.density(job.kappa),
                            kappa: job.kappa,
                            uncertainty: uncertainty(&belief, min, max),
                            at: job.at,
                        })
                        .is_err()
                    {
                        return;
                    }
                }
            })
            .expect("a thread for the learner");
        Worker {
            jobs: Some(jobs),
            results,
            busy: false,
            thread: Some(thread),
        }
    }
}

impl Drop for Worker {
    /// Ends the thread once its fit (if any) is done.
    fn drop(&mut self) {
        self.jobs = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The coordinator's learner.
pub(super) struct Learning {
    settings: LearnSettings,
    /// The newest samples, each with its own time [mission s].
    window: VecDeque<(f64, Sample)>,
    recent: VecDeque<SampleDocument>,
    buckets: HashMap<String, Bucket>,
    worker: Worker,
    belief: Option<RiskField>,
    uncertainty: Option<UncertaintyDocument>,
    fits: u64,
    fitted_at: Option<f64>,
    /// The optimism the belief covered was fitted with.
    kappa: f64,
    next_fit: f64,
    /// Samples taken since the newest fit began.
    fresh: bool,
}

impl Learning {
    pub(super) fn new(settings: LearnSettings) -> Learning {
        Learning {
            settings,
            window: VecDeque::new(),
            recent: VecDeque::new(),
            buckets: HashMap::new(),
            worker: Worker::start(),
            belief: None,
            uncertainty: None,
            fits: 0,
            fitted_at: None,
            kappa: 0.0,
            next_fit: 0.0,
            fresh: false,
        }
    }

    /// The density the fleet covers, once a fit has come.
    pub(super) fn belief(&self) -> Option<&RiskField> {
        self.belief.as_ref()
    }

    /// The mission changed its region or risk: the belief is fitted again
    /// with the new prior and lattice before it is covered.
    pub(super) fn mission_changed(&mut self) {
        self.belief = None;
        self.uncertainty = None;
        self.fresh = !self.window.is_empty();
        self.next_fit = 0.0;
    }

    /// Judges a batch at mission time `now`; takes the good samples.
    pub(super) fn take(
        &mut self,
        batch: Vec<SampleDocument>,
        mission: &Mission,
        now: f64,
        recorder: &Recorder,
    ) -> SamplesAnswerDocument {
        let (min, max) = mission.region().bounds();
        let mut answer = SamplesAnswerDocument {
            accepted: 0,
            refused: Vec::new(),
        };
        for (index, s) in batch.into_iter().enumerate() {
            match self.judge(&s, (min, max), now) {
                Ok(sample) => {
                    self.window.push_back((s.t, sample));
                    if self.window.len() > WINDOW {
                        self.window.pop_front();
                    }
                    recorder.sample(now, &s, "accepted");
                    self.recent.push_back(s);
                    if self.recent.len() > RECENT {
                        self.recent.pop_front();
                    }
                    self.fresh = true;
                    answer.accepted += 1;
                    metrics::counter!(crate::server::metrics::SAMPLES, "outcome" => "accepted")
                        .increment(1);
                }
                Err((code, reason)) => {
                    if code != "flood" {
                        recorder.sample(now, &s, code);
                    }
                    metrics::counter!(crate::server::metrics::SAMPLES, "outcome" => code)
                        .increment(1);
                    answer.refused.push(SampleRefusalDocument {
                        index: index as u64,
                        code: code.to_string(),
                        reason,
                    });
                }
            }
        }
        if !answer.refused.is_empty() {
            tracing::debug!(
                refused = answer.refused.len(),
                first = %answer.refused[0].reason,
                "samples refused"
            );
        }
        answer
    }

    fn judge(
        &mut self,
        s: &SampleDocument,
        (min, max): (Point, Point),
        now: f64,
    ) -> Result<Sample, (&'static str, String)> {
        if !crate::mission::scenario::valid_id(&s.vessel) {
            return Err((
                "invalid",
                "vessel: must match [A-Za-z0-9_.-]{1,64}".to_string(),
            ));
        }
        let sample = Sample::new(Point { x: s.x, y: s.y }, s.value, s.sd)
            .map_err(|e| ("invalid", e.to_string()))?;
        if !s.t.is_finite() {
            return Err(("invalid", "t: must be finite".to_string()));
        }
        let outside = (min.x - s.x)
            .max(s.x - max.x)
            .max(min.y - s.y)
            .max(s.y - max.y);
        if outside > MARGIN {
            return Err((
                "outside_region",
                format!("({}, {}) is {outside:.0} m outside the region", s.x, s.y),
            ));
        }
        if s.t > now + MAX_AHEAD {
            return Err((
                "future",
                format!("t {} is ahead of the mission's clock, {now:.1} s", s.t),
            ));
        }
        if s.t < now - MAX_AGE {
            return Err((
                "stale",
                format!("t {} is older than {MAX_AGE} s at {now:.1} s", s.t),
            ));
        }
        if !self.spend(&s.vessel, now) {
            return Err((
                "flood",
                format!("{}: over {RATE} samples a second", s.vessel),
            ));
        }
        Ok(sample)
    }

    /// One token from `vessel`'s bucket, if it has one.
    fn spend(&mut self, vessel: &str, now: f64) -> bool {
        if !self.buckets.contains_key(vessel) && self.buckets.len() >= MAX_SOURCES {
            // Forget the sources whose buckets have filled again: they are
            // as if new.
            self.buckets
                .retain(|_, b| b.tokens + (now - b.at).max(0.0) * RATE < BURST);
            if self.buckets.len() >= MAX_SOURCES {
                return false;
            }
        }
        let b = self.buckets.entry(vessel.to_string()).or_insert(Bucket {
            tokens: BURST,
            at: now,
        });
        b.tokens = (b.tokens + (now - b.at).max(0.0) * RATE).min(BURST);
        b.at = b.at.max(now);
        if b.tokens < 1.0 {
            return false;
        }
        b.tokens -= 1.0;
        true
    }

    /// At mission time `now`: takes a finished fit, and starts one when
    /// due and new samples have come.
    pub(super) fn poll(&mut self, mission: &Mission, now: f64, recorder: &Recorder) {
        while let Ok(fitted) = self.worker.results.try_recv() {
            self.worker.busy = false;
            self.belief = Some(fitted.density);
            self.uncertainty = Some(fitted.uncertainty);
            self.fits += 1;
            self.fitted_at = Some(fitted.at);
            self.kappa = fitted.kappa;
            metrics::counter!(crate::server::metrics::FITS).increment(1);
            if recorder.is_on() {
                recorder.belief(now, self.document(mission));
            }
        }
        if self.worker.busy || !self.fresh || now < self.next_fit {
            return;
        }
        let (min, max) = mission.region().bounds();
        let Ok(lattice) = Lattice::over(min, max, self.settings.lattice) else {
            // Validated at start-up for the mission's region; a region
            // changed since to one too large for the lattice keeps the
            // mission's own risk.
            return;
        };
        // The optimism fades with the age of the oldest sample held
        // (docs/learning.md, "Optimism that fades").
        let oldest = self.window.iter().map(|w| w.0).fold(now, f64::min);
        let job = Job {
            lattice,
            prior: mission.risk().clone(),
            params: self.settings.params(),
            samples: self.window.iter().map(|w| w.1).collect(),
            kappa: self.settings.kappa_at(now - oldest),
            at: now,
            bounds: (min, max),
        };
        if let Some(jobs) = &self.worker.jobs
            && jobs.try_send(job).is_ok()
        {
            self.worker.busy = true;
            self.fresh = false;
            self.next_fit = now + self.settings.refit;
        }
    }

    /// `GET /api/v1/risk` without learning: the mission's risk.
    pub(super) fn unlearned(mission: &Mission) -> BeliefDocument {
        BeliefDocument {
            source: "mission".to_string(),
            risk: mission.document().risk,
            samples: 0,
            fits: 0,
            fitted_at: None,
            kappa: 0.0,
            learning: false,
            uncertainty: None,
        }
    }

    /// `GET /api/v1/samples`: the newest samples taken, oldest first.
    pub(super) fn recent(&self) -> SamplesDocument {
        SamplesDocument {
            samples: self.recent.iter().cloned().collect(),
        }
    }

    /// `GET /api/v1/risk`: the density covered and the learner's state.
    pub(super) fn document(&self, mission: &Mission) -> BeliefDocument {
        let (source, risk) = match &self.belief {
            Some(b) => ("learned", risk_document(b)),
            None => ("mission", mission.document().risk),
        };
        BeliefDocument {
            source: source.to_string(),
            risk,
            samples: self.window.len() as u64,
            fits: self.fits,
            fitted_at: self.fitted_at,
            kappa: self.kappa,
            learning: true,
            uncertainty: self.uncertainty.clone(),
        }
    }
}
