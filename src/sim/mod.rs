//! `seacover sim`: the whole closed loop in one process, no network,
//! deterministic for a seed (docs/reproducing-the-paper.md).
//!
//! Dynamics, observer and controller run at the dynamics step (1 kHz by
//! default); the coverage engine and guidance run at the coordinator's tick
//! (10 Hz), exactly as the networked system splits them: between ticks each
//! vessel follows its command's line (the command and its rates) through
//! the on-board governor ([`reference`](crate::control::reference)), as
//! `seacover agent` does. Lloyd's single-integrator fleet (paper Fig. 3b) runs from
//! the same start on the same ticks.
//!
//! Guidance goes through the same [`SafetyLayer`] as the coordinator's tick
//! (reachable goals, routes round islands, the barrier filter when it is on),
//! and [`monitor`] watches the true states at every dynamics step for
//! collisions and incursions.
//!
//! This module is the shell around the pure core: it owns files (CSV, JSON,
//! figures) and the progress bar; the loop itself is [`run`], which is pure.

mod config;
pub mod figures;
mod learn;
pub mod learning_study;
pub mod monitor;
pub mod output;
pub mod record;
mod run;
pub mod starts;
pub mod study;

pub use config::{
    Config, DEFAULT_HULL_RADIUS, DisturbanceKind, SimError, load_scenario, load_scenario_document,
    staging_zone,
};
pub use learn::{Cover, LearningConfig};
pub use run::{Learned, Measures, Run, Snapshot, Tick, VesselSample, run};

/// Runs `config` and writes `timeseries.csv`, `summary.json`, `safety.json`,
/// with a truth `learning.json` and `learning.csv` (after a second,
/// clairvoyant run for H★), and (with `figures`) the five figures into
/// `out`; with `record`, also a
/// recording in its directory (see [`record::record`]), whose file it
/// returns.
pub fn run_to_dir(
    config: &Config,
    out: &std::path::Path,
    figures: bool,
    record: Option<(&std::path::Path, &crate::mission::scenario::LocalScenario)>,
    progress: impl FnMut(f64),
) -> Result<Written, SimError> {
    let io = |e: std::io::Error| SimError::Io(format!("{}: {e}", out.display()));
    std::fs::create_dir_all(out).map_err(io)?;
    let started = std::time::Instant::now();
    // A recording holds every sample and belief: the run keeps them.
    let logged;
    let config = match (&record, &config.learning) {
        (Some(_), Some(l)) => {
            let mut c = config.clone();
            c.learning = Some(learn::LearningConfig {
                log: true,
                ..l.clone()
            });
            logged = c;
            &logged
        }
        _ => config,
    };
    let result = run(config, progress)?;
    let recording = match record {
        Some((dir, doc)) => Some(record::record(dir, config, doc, &result)?),
        None => None,
    };
    let wall = started.elapsed().as_secs_f64();
    let summary = output::Summary::new(config, &result, wall);
    let safety = output::SafetySummary::new(config, &result);
    output::write_timeseries(&out.join("timeseries.csv"), config, &result).map_err(io)?;
    output::write_summary(&out.join("summary.json"), &summary).map_err(io)?;
    output::write_safety(&out.join("safety.json"), &safety).map_err(io)?;
    if figures {
        figures::draw_all(out, config, &result).map_err(SimError::Figure)?;
    }
    let learning = match &config.learning {
        Some(_) => {
            let h_star = h_star(config, &result)?;
            output::write_learning_series(&out.join("learning.csv"), &result, h_star)
                .map_err(io)?;
            let s = output::LearningSummary::new(config, &result, h_star);
            if let Some(s) = &s {
                output::write_learning(&out.join("learning.json"), s).map_err(io)?;
            }
            s
        }
        None => None,
    };
    Ok(Written {
        summary,
        safety,
        learning,
        recording,
    })
}

/// What [`run_to_dir`] wrote.
pub struct Written {
    pub summary: output::Summary,
    pub safety: output::SafetySummary,
    /// `learning.json`, when the scenario has a truth.
    pub learning: Option<output::LearningSummary>,
    /// The recording's file, when it recorded.
    pub recording: Option<std::path::PathBuf>,
}

/// H★: the truth's H where the clairvoyant fleet ends, the same run
/// covering the truth itself (`run` already is that run when it covered
/// the truth).
fn h_star(config: &Config, result: &Run) -> Result<f64, SimError> {
    let Some(l) = &config.learning else {
        return Ok(f64::NAN);
    };
    let last = |r: &Run| r.ticks.last().map_or(f64::NAN, |t| t.h_true);
    if l.cover == learn::Cover::Truth {
        return Ok(last(result));
    }
    let mut clairvoyant = config.clone();
    clairvoyant.lloyd = false;
    clairvoyant.snapshots.clear();
    if let Some(c) = &mut clairvoyant.learning {
        c.cover = learn::Cover::Truth;
    }
    Ok(last(&run(&clairvoyant, |_| {})?))
}
