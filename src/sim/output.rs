//! Files a run leaves behind: `timeseries.csv`, `summary.json` and
//! `safety.json`.

use std::io::Write;
use std::path::Path;

use serde::Serialize;

use super::{Config, Run};

/// `summary.json`, with exactly the keys docs/reproducing-the-paper.md lists.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Summary {
    pub guidance: String,
    pub preset: String,
    pub duration: f64,
    pub seed: u64,
    #[serde(rename = "H_start")]
    pub h_start: f64,
    #[serde(rename = "H_end")]
    pub h_end: f64,
    #[serde(rename = "E_max_end")]
    pub e_max_end: f64,
    pub observer_error_max_after_10s: f64,
    pub velocity_error_max_after_20s: VelocityErrors,
    /// What the on-board governor held back of the commands after 20 s:
    /// the largest gap between the command line and the reference tracked.
    pub command_lag_max_after_20s: VelocityErrors,
    #[serde(rename = "T1_observer_s")]
    pub t1_observer_s: f64,
    pub lloyd: LloydSummary,
    pub wall_seconds: f64,
}

#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct VelocityErrors {
    pub u: f64,
    pub r: f64,
}

#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct LloydSummary {
    #[serde(rename = "H_end")]
    pub h_end: f64,
    #[serde(rename = "E_max_end")]
    pub e_max_end: f64,
}

impl Summary {
    pub fn new(config: &Config, run: &Run, wall_seconds: f64) -> Summary {
        let first = run.ticks.first().expect("a run has a first tick");
        let last = run.ticks.last().expect("a run has a last tick");
        let e_max_end = last.vessels.iter().map(|v| v.command.e).fold(0.0, f64::max);
        // Lloyd's E at the end: distance of each Lloyd vessel to its centroid,
        // which the last tick's positions and the engine give.
        let lloyd_e = lloyd_e_max(config, last);
        Summary {
            guidance: config.guidance.mode.name().to_string(),
            preset: config.preset.clone(),
            duration: config.duration,
            seed: config.seed,
            h_start: first.h,
            h_end: last.h,
            e_max_end,
            observer_error_max_after_10s: run.measures.observer_error_max_after_10s,
            velocity_error_max_after_20s: VelocityErrors {
                u: run.measures.u_error_max_after_20s,
                r: run.measures.r_error_max_after_20s,
            },
            command_lag_max_after_20s: VelocityErrors {
                u: run.measures.u_lag_max_after_20s,
                r: run.measures.r_lag_max_after_20s,
            },
            t1_observer_s: run.measures.t1_observer,
            lloyd: LloydSummary {
                h_end: last.lloyd_h,
                e_max_end: lloyd_e,
            },
            wall_seconds,
        }
    }
}

fn lloyd_e_max(config: &Config, tick: &super::Tick) -> f64 {
    let Some(fleet) = super::run::fleet_at(config, tick.lloyd_positions.iter().copied()) else {
        return f64::NAN;
    };
    let eval = crate::coverage::evaluate(
        &config.scenario.region,
        &config.scenario.risk,
        &fleet,
        &crate::coverage::Options::default(),
    );
    eval.cells
        .iter()
        .zip(&tick.lloyd_positions)
        .map(|(c, p)| crate::geometry::norm2(c.centroid - *p).sqrt())
        .fold(0.0, f64::max)
}

/// `safety.json`: what the safety watch measured (`docs/safety.md`). Kept
/// apart from `summary.json`, whose keys are fixed.
///
/// Each count of episodes comes twice: `collisions`, `incursions`, … count
/// those that began during the run; `…_at_start` those already under way at
/// t = 0, where the scenario's starts put the vessels (the paper's two
/// vessels 0.42 m from the edge).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SafetySummary {
    pub filter: bool,
    pub reachable_goals: bool,
    pub safety_distance: f64,
    pub shore_distance: f64,
    pub hull_radius: f64,
    pub collisions: usize,
    pub collisions_at_start: usize,
    pub incursions: usize,
    pub incursions_at_start: usize,
    pub safety_distance_breaches: usize,
    pub safety_distance_breaches_at_start: usize,
    pub shore_distance_breaches: usize,
    pub shore_distance_breaches_at_start: usize,
    pub min_pair_distance: Option<f64>,
    pub min_shore_clearance: f64,
    pub intervention_rate: f64,
    #[serde(rename = "H_end")]
    pub h_end: f64,
    /// Largest remaining route length to a goal at the end [m].
    pub goal_distance_max_end: f64,
}

impl SafetySummary {
    pub fn new(config: &Config, run: &Run) -> SafetySummary {
        let r = &run.safety;
        let last = run.ticks.last().expect("a run has a last tick");
        SafetySummary {
            filter: config.safety.filter,
            reachable_goals: config.safety.reachable_goals,
            safety_distance: config.safety.safety_distance,
            shore_distance: config.safety.shore_distance,
            hull_radius: config.hull_radius,
            collisions: r.collisions,
            collisions_at_start: r.collisions_at_start,
            incursions: r.incursions,
            incursions_at_start: r.incursions_at_start,
            safety_distance_breaches: r.pair_breaches,
            safety_distance_breaches_at_start: r.pair_breaches_at_start,
            shore_distance_breaches: r.shore_breaches,
            shore_distance_breaches_at_start: r.shore_breaches_at_start,
            min_pair_distance: r
                .min_pair_distance
                .is_finite()
                .then_some(r.min_pair_distance),
            min_shore_clearance: r.min_shore_clearance,
            intervention_rate: r.intervention_rate(),
            h_end: last.h,
            goal_distance_max_end: last.vessels.iter().map(|v| v.command.e).fold(0.0, f64::max),
        }
    }
}

/// Writes `safety.json`.
pub fn write_safety(path: &Path, safety: &SafetySummary) -> std::io::Result<()> {
    let text = serde_json::to_string_pretty(safety).expect("summaries serialize");
    std::fs::write(path, text + "\n")
}

/// Writes `timeseries.csv`: one row per tick and vessel.
pub fn write_timeseries(path: &Path, config: &Config, run: &Run) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        w,
        "t,vessel,x,y,psi,u,v,r,u_d,r_d,u_ref,r_ref,u_e_peak,r_e_peak,E,psi_e,tau_ud,tau_vd,tau_rd,tau_ud_hat,tau_vd_hat,tau_rd_hat,H"
    )?;
    for tick in &run.ticks {
        for (v, id) in tick.vessels.iter().zip(&config.scenario.ids) {
            let s = &v.state;
            writeln!(
                w,
                "{:.3},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6}",
                tick.t,
                id,
                s.x,
                s.y,
                s.psi,
                s.vel.x,
                s.vel.y,
                s.vel.z,
                v.command.u_d,
                v.command.r_d,
                v.reference.0,
                v.reference.1,
                v.peak_error.0,
                v.peak_error.1,
                v.command.e,
                v.command.psi_e,
                v.tau_d.x,
                v.tau_d.y,
                v.tau_d.z,
                v.estimate.x,
                v.estimate.y,
                v.estimate.z,
                tick.h
            )?;
        }
    }
    w.flush()
}

/// Writes `summary.json`.
pub fn write_summary(path: &Path, summary: &Summary) -> std::io::Result<()> {
    let text = serde_json::to_string_pretty(summary).expect("summaries serialize");
    std::fs::write(path, text + "\n")
}

/// `learning.json`, for a scenario with a truth (docs/learning.md): what
/// the fleet covered, how it sampled and learned, and H judged on the
/// truth against H★, the truth's H where the clairvoyant fleet (the same
/// run covering the truth itself) ends.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct LearningSummary {
    /// `learned`, `prior` (no learning) or `truth` (the clairvoyant).
    pub cover: &'static str,
    /// The optimism at first, and its time constant [s].
    pub kappa: f64,
    pub fade_s: f64,
    /// Noise σ as a share of the truth's range.
    pub noise: f64,
    pub outliers: f64,
    pub sample_rate_hz: f64,
    pub refit_s: f64,
    pub lattice_m: f64,
    /// The prior's spread of each lattice weight.
    pub weight_sd: f64,
    pub samples: usize,
    pub fits: usize,
    #[serde(rename = "H_true_end")]
    pub h_true_end: f64,
    #[serde(rename = "H_star")]
    pub h_star: f64,
    /// H_true / H★ at the end.
    pub share_end: f64,
    /// From when on H_true stays at or above 99.5 % and 99 % of H★ [s].
    pub t_99_5: Option<f64>,
    pub t_99: Option<f64>,
}

impl LearningSummary {
    /// `None` without a truth.
    pub fn new(config: &Config, run: &Run, h_star: f64) -> Option<LearningSummary> {
        let l = config.learning.as_ref()?;
        let learned = run.learned?;
        let last = run.ticks.last().expect("a run has a last tick");
        let since = |share: f64| {
            let below = run.ticks.iter().rposition(|t| t.h_true < share * h_star);
            match below {
                None => run.ticks.first().map(|t| t.t),
                Some(i) => run.ticks.get(i + 1).map(|t| t.t),
            }
        };
        Some(LearningSummary {
            cover: match l.cover {
                super::Cover::Learned => "learned",
                super::Cover::Prior => "prior",
                super::Cover::Truth => "truth",
                super::Cover::Schwager => "schwager",
                super::Cover::GridLloyd => "grid-lloyd",
            },
            kappa: l.kappa,
            fade_s: l.fade,
            noise: l.noise,
            outliers: l.outliers,
            sample_rate_hz: l.rate,
            refit_s: l.refit,
            weight_sd: l.weight_sd,
            lattice_m: l.spacing,
            samples: learned.samples,
            fits: learned.fits,
            h_true_end: last.h_true,
            h_star,
            share_end: last.h_true / h_star,
            t_99_5: since(0.995),
            t_99: since(0.99),
        })
    }
}

/// Writes `learning.json`.
pub fn write_learning(path: &Path, summary: &LearningSummary) -> std::io::Result<()> {
    let text = serde_json::to_string_pretty(summary).expect("summaries serialize");
    std::fs::write(path, text + "\n")
}

/// Writes `learning.csv`: one row per tick, H of what the fleet covers,
/// H on the truth and its share of H★.
pub fn write_learning_series(path: &Path, run: &Run, h_star: f64) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(w, "t,H,H_true,share")?;
    for tick in &run.ticks {
        writeln!(
            w,
            "{:.3},{:.6},{:.6},{:.6}",
            tick.t,
            tick.h,
            tick.h_true,
            tick.h_true / h_star
        )?;
    }
    w.flush()
}
