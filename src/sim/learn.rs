//! Learning the risk map in the simulated loop (docs/learning.md): the
//! scenario's hidden `truth` is sampled at every hull's true position, the
//! fleet covers the belief fitted to those samples, and every tick is also
//! judged on the truth.
//!
//! Invariants: the truth reaches the fleet only through samples; the noise
//! is seeded, so a run is deterministic for its seed; a vessel's samples
//! are drawn in the fleet's order at every sampling instant.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::coverage::{Fleet, InputError, RiskField, grid_lloyd};
use crate::geometry::{Point, Region};
use crate::learning::{
    Adaptive, FADE, Gains, GridMap, Lattice, LearnSettings, Learner, Quadrature, Sample, WEIGHT_SD,
};

/// How the simulated fleet measures and learns the field.
#[derive(Debug, Clone)]
pub struct LearningConfig {
    /// The field the vessels measure (never given to the fleet).
    pub truth: RiskField,
    /// Samples per second per vessel [Hz].
    pub rate: f64,
    /// Noise σ as a share of the truth's range over the region.
    pub noise: f64,
    /// Share of samples replaced by a gross outlier (a value anywhere in
    /// [0, 5 × range]).
    pub outliers: f64,
    /// Seconds between fits.
    pub refit: f64,
    /// The lattice's spacing (and each Gaussian's spread) [m].
    pub spacing: f64,
    /// The prior's spread of each lattice weight (`LearnSettings::weight_sd`).
    pub weight_sd: f64,
    /// Optimism κ: posterior standard deviations added (0: the mean) at
    /// first.
    pub kappa: f64,
    /// The optimism's time constant [s] (`LearnSettings::kappa_at`).
    pub fade: f64,
    /// What the fleet covers: the belief, or (for comparison) the prior
    /// alone or the truth itself.
    pub cover: Cover,
    /// Keep every sample and every belief with its uncertainty (for the
    /// recording: [`LearnLog`]).
    pub log: bool,
}

/// Every sample a run took and every belief it covered, in time order.
#[derive(Debug, Clone, Default)]
pub struct LearnLog {
    pub samples: Vec<LoggedSample>,
    /// The time of each fit, the density covered from then on, and the
    /// mean belief's uncertainty.
    pub beliefs: Vec<(f64, RiskField, crate::protocol::UncertaintyDocument)>,
}

/// One sample as a sensor would have reported it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoggedSample {
    pub t: f64,
    /// Its vessel's index in the fleet.
    pub vessel: usize,
    pub at: Point,
    pub value: f64,
    pub sd: f64,
}

/// What the simulated fleet covers when the scenario has a truth.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cover {
    /// The belief learned from samples, the scenario's risk as its prior.
    Learned,
    /// The scenario's risk, samples ignored (no learning).
    Prior,
    /// The truth (the clairvoyant fleet that defines H★).
    Truth,
    /// Schwager's adaptive law over the same lattice (gains `SCHWAGER`),
    /// for comparison.
    Schwager,
    /// Lloyd's algorithm on a map gridded from the samples (`GRID`), for
    /// comparison.
    GridLloyd,
}

/// Schwager's gains in `seacover sim` (docs/learning.md, "Against
/// Schwager's law and a grid Lloyd": the best of those tried on the
/// paper's map): Γ, γ and a_min.
pub(super) const SCHWAGER: (f64, f64, f64) = (0.001, 70.0, 0.01);

/// The grid Lloyd's map: spacing and each sample's reach [m] (the same
/// page: the reach is the best of those tried).
pub(super) const GRID: (f64, f64) = (1.0, 15.0);

/// What turns samples into the density a fleet covers.
enum Estimator {
    /// The Bayesian learner, fitted every `refit` seconds.
    Bayes(Learner),
    /// Schwager's law, stepped every tick; the time of its last step.
    Schwager(Box<(Adaptive, Quadrature)>, f64),
    /// The grid map, whose centroids replace the covered density's.
    Grid(GridMap),
    /// Nothing: the fleet covers the prior or the truth.
    None,
}

impl LearningConfig {
    /// The defaults of docs/learning.md: 1 Hz, σ 5 % of the range, no
    /// outliers, a fit every 5 s, a 10 m lattice of weights of spread
    /// [`WEIGHT_SD`], the mean (an optimism fading over [`FADE`] when set).
    pub fn new(truth: RiskField) -> Self {
        LearningConfig {
            truth,
            rate: 1.0,
            noise: 0.05,
            outliers: 0.0,
            refit: 5.0,
            spacing: 10.0,
            weight_sd: WEIGHT_SD,
            kappa: 0.0,
            fade: FADE,
            cover: Cover::Learned,
            log: false,
        }
    }
}

impl LearningConfig {
    /// Checks every setting's range; errors name the `seacover sim` flag.
    pub fn validate(&self) -> Result<(), String> {
        self.settings()
            .validate(|f| format!("--{}", f.replace('_', "-")))
            .map_err(|e| e.to_string())?;
        let check = |ok: bool, what: &str| if ok { Ok(()) } else { Err(what.to_string()) };
        check(
            self.noise > 0.0 && self.noise <= 1.0,
            "--noise must be in (0, 1]",
        )?;
        check(
            (0.0..=0.5).contains(&self.outliers),
            "--outliers must be in [0, 0.5]",
        )?;
        check(
            self.rate > 0.0 && self.rate <= 10.0,
            "--sample-rate must be in (0, 10] Hz",
        )
    }

    /// The learner's settings as a coordinator's would be.
    pub(crate) fn settings(&self) -> LearnSettings {
        LearnSettings {
            kappa: self.kappa,
            fade: self.fade,
            refit: self.refit,
            lattice: self.spacing,
            weight_sd: self.weight_sd,
        }
    }
}

/// The learning side of one run.
pub(super) struct Learning {
    config: LearningConfig,
    estimator: Estimator,
    rng: ChaCha8Rng,
    /// σ of every sample (the noise is known to the simulated sensor).
    sd: f64,
    range: f64,
    next_sample: f64,
    next_fit: f64,
    /// What the fleet covers now.
    pub(super) cover: RiskField,
    pub(super) samples: usize,
    pub(super) fits: usize,
    /// The region's bounding box (where the uncertainty is mapped).
    bounds: (Point, Point),
    pub(super) log: Option<LearnLog>,
}

impl Learning {
    pub(super) fn new(
        config: &LearningConfig,
        region: &Region,
        prior: &RiskField,
        seed: u64,
    ) -> Result<Learning, InputError> {
        let (min, max) = region.bounds();
        let lattice = Lattice::over(min, max, config.spacing)?;
        let range = config.truth.range_over(min, max);
        // A flat truth has no range: its noise is then a share of its level.
        let scale = if range > 0.0 {
            range
        } else {
            config.truth.value(min).abs().max(1e-9)
        };
        let cover = match config.cover {
            Cover::Truth => config.truth.clone(),
            _ => prior.clone(),
        };
        let estimator = match config.cover {
            Cover::Learned => Estimator::Bayes(Learner::new(
                lattice,
                prior.clone(),
                config.settings().params(),
            )),
            Cover::Schwager => {
                let (adaptation, data, a_min) = SCHWAGER;
                let gains = Gains::new(adaptation, data, a_min)?;
                let quadrature = Quadrature::over(region, &lattice);
                let law = Adaptive::new(lattice, prior.base(), gains);
                Estimator::Schwager(Box::new((law, quadrature)), 0.0)
            }
            Cover::GridLloyd => Estimator::Grid(GridMap::over(region, prior, GRID.0, GRID.1)?),
            Cover::Prior | Cover::Truth => Estimator::None,
        };
        Ok(Learning {
            estimator,
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x5eac_0fe4),
            sd: config.noise.max(1e-6) * scale,
            range: scale,
            next_sample: 0.0,
            next_fit: 0.0,
            cover,
            samples: 0,
            fits: 0,
            bounds: (min, max),
            log: config.log.then(LearnLog::default),
            config: config.clone(),
        })
    }

    /// The learner's settings as a coordinator's would be.
    fn settings(&self) -> LearnSettings {
        self.config.settings()
    }

    /// The truth (what H_true is judged on).
    pub(super) fn truth(&self) -> &RiskField {
        &self.config.truth
    }

    pub(super) fn covers_truth(&self) -> bool {
        self.config.cover == Cover::Truth
    }

    /// At tick time `t` with the hulls at `at` moving at `velocities`
    /// (over ground) as `fleet`: samples when due, then a fit when due
    /// (the learner) or a step of the law (Schwager's).
    pub(super) fn tick(&mut self, t: f64, at: &[Point], velocities: &[Point], fleet: &Fleet) {
        // Only a learning fleet samples: the others would ignore it.
        if matches!(self.estimator, Estimator::None) {
            return;
        }
        while self.next_sample <= t + 1e-9 {
            for (vessel, &q) in at.iter().enumerate() {
                let value = self.measure(q);
                if let Ok(s) = Sample::new(q, value, self.sd) {
                    self.take(s);
                    if let Some(log) = &mut self.log {
                        log.samples.push(LoggedSample {
                            t,
                            vessel,
                            at: q,
                            value,
                            sd: self.sd,
                        });
                    }
                }
            }
            self.next_sample += 1.0 / self.config.rate;
        }
        match &mut self.estimator {
            Estimator::Bayes(_) => self.refit(t),
            Estimator::Schwager(law, last) => {
                let (law, quadrature) = &mut **law;
                let mut coupling = Vec::new();
                quadrature.coupling(fleet, velocities, &mut coupling);
                law.step(&coupling, t - *last);
                *last = t;
                self.cover = law.density();
            }
            Estimator::Grid(_) | Estimator::None => {}
        }
    }

    /// One sample into whatever learns from samples.
    fn take(&mut self, s: Sample) {
        self.samples += 1;
        match &mut self.estimator {
            Estimator::Bayes(learner) => learner.add(s),
            // Each sample stands for the seconds until the next one.
            Estimator::Schwager(law, _) => law.0.observe(&s, 1.0 / self.config.rate),
            Estimator::Grid(map) => map.add(&s),
            Estimator::None => {}
        }
    }

    /// The learner's fit, when one is due.
    fn refit(&mut self, t: f64) {
        let Estimator::Bayes(learner) = &self.estimator else {
            return;
        };
        if self.next_fit > t + 1e-9 {
            return;
        }
        while self.next_fit <= t + 1e-9 {
            self.next_fit += self.config.refit;
        }
        let belief = learner.fit();
        // Every vessel samples from the first tick on: the oldest sample
        // is as old as the run.
        self.cover = belief.density(self.settings().kappa_at(t));
        self.fits += 1;
        if let Some(log) = &mut self.log {
            let (min, max) = self.bounds;
            let grid = crate::mission::belief::uncertainty(&belief, min, max);
            log.beliefs.push((t, self.cover.clone(), grid));
        }
    }

    /// The grid Lloyd's centroids for `fleet`, which replace those of the
    /// density covered (the prior); none for the other fleets.
    pub(super) fn centroids(&self, fleet: &Fleet) -> Option<Vec<Point>> {
        match &self.estimator {
            Estimator::Grid(map) => Some(grid_lloyd::centroids(fleet, map.cells())),
            _ => None,
        }
    }

    /// One noisy reading of the truth at `q`.
    fn measure(&mut self, q: Point) -> f64 {
        // Box–Muller.
        let (u1, u2): (f64, f64) = (self.rng.random::<f64>().max(1e-300), self.rng.random());
        let noise = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
        let outlier: f64 = self.rng.random();
        let wild: f64 = self.rng.random();
        if outlier < self.config.outliers {
            wild * 5.0 * self.range
        } else {
            self.config.truth.value(q) + self.sd * noise
        }
    }
}
