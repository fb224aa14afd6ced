//! `seacover sim learning-study` (docs/learning.md): a scenario with a
//! truth run six ways per seed — covering the truth itself (the
//! clairvoyant, whose end defines H★), the prior alone (no learning), the
//! mean belief, an optimistic one, and for comparison Schwager's adaptive
//! law and Lloyd on a map gridded from the samples — each judged on the
//! truth as H_true / H★ over time.
//!
//! Every run is an ordinary [`run`](super::run) of the same scenario,
//! seed and disturbances with only the learning's `cover` and `kappa`
//! changed, so the six differ only in what the fleet covers.

use serde::Serialize;

use super::learn::Cover;
use super::{Config, Run, SimError, load_scenario, run};
use crate::learning::LearnSettings;

/// One way of covering, for one seed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StudyRow {
    /// `clairvoyant`, `no learning`, `learning (mean)`, `learning (κ =
    /// K, fade F s)`, `schwager` or `grid Lloyd`.
    pub fleet: String,
    pub seed: u64,
    /// H_true / H★ at the end.
    pub share_end: f64,
    /// From when on H_true stays at or above 99.5 % and 99 % of H★ [s].
    pub t_99_5: Option<f64>,
    pub t_99: Option<f64>,
}

/// The study: its rows, and seed `seeds[0]`'s six curves (t, share).
pub struct LearningStudy {
    pub rows: Vec<StudyRow>,
    pub curves: Vec<(String, Vec<(f64, f64)>)>,
}

/// Runs the study of `scenario` (which must have a truth) for `seeds`,
/// `duration` seconds each, the optimistic fleet at `settings.kappa`
/// fading over `settings.fade` seconds; both learning fleets with the
/// prior's `settings.weight_sd`.
pub fn run_learning_study(
    scenario: &str,
    seeds: &[u64],
    duration: f64,
    settings: &LearnSettings,
) -> Result<LearningStudy, SimError> {
    let (kappa, fade) = (settings.kappa, settings.fade);
    let (loaded, headings) = load_scenario(scenario)?;
    let base = Config::new(loaded, headings, duration);
    if base.learning.is_none() {
        return Err(SimError::Io(format!(
            "{scenario} has no truth: the learning study needs one (docs/learning.md)"
        )));
    }
    let ways = [
        ("clairvoyant".to_string(), Cover::Truth, 0.0),
        ("no learning".to_string(), Cover::Prior, 0.0),
        ("learning (mean)".to_string(), Cover::Learned, 0.0),
        (
            format!("learning (κ = {kappa}, fade {fade} s)"),
            Cover::Learned,
            kappa,
        ),
        ("schwager".to_string(), Cover::Schwager, 0.0),
        ("grid Lloyd".to_string(), Cover::GridLloyd, 0.0),
    ];
    let mut rows = Vec::new();
    let mut curves = Vec::new();
    for &seed in seeds {
        let mut runs: Vec<(String, Run)> = Vec::new();
        for (name, cover, k) in &ways {
            let mut config = base.clone();
            config.seed = seed;
            config.snapshots.clear();
            if let Some(l) = &mut config.learning {
                (l.cover, l.kappa, l.fade) = (*cover, *k, fade);
                l.weight_sd = settings.weight_sd;
            }
            runs.push((name.clone(), run(&config, |_| {})?));
        }
        // H★: where the clairvoyant (the first way) ends.
        let h_star = runs[0].1.ticks.last().map_or(f64::NAN, |t| t.h_true);
        for (name, r) in &runs {
            let share: Vec<(f64, f64)> = r.ticks.iter().map(|t| (t.t, t.h_true / h_star)).collect();
            let since = |level: f64| {
                let below = share.iter().rposition(|&(_, s)| s < level);
                match below {
                    None => share.first().map(|p| p.0),
                    Some(i) => share.get(i + 1).map(|p| p.0),
                }
            };
            rows.push(StudyRow {
                fleet: name.clone(),
                seed,
                share_end: share.last().map_or(f64::NAN, |p| p.1),
                t_99_5: since(0.995),
                t_99: since(0.99),
            });
            if seed == seeds[0] {
                curves.push((name.clone(), share));
            }
        }
    }
    Ok(LearningStudy { rows, curves })
}

/// The study's table in Markdown: one row per way of covering, each
/// seed's share of H★ at the end and from when on it stays at or above
/// 99.5 % and 99 %.
pub fn table(study: &LearningStudy, duration: f64) -> String {
    let mut fleets: Vec<&str> = Vec::new();
    for r in &study.rows {
        if !fleets.contains(&r.fleet.as_str()) {
            fleets.push(&r.fleet);
        }
    }
    let mut out = format!(
        "| fleet | H_true / H★ at {duration} s, each seed | at or above 99.5 % from, each seed | at or above 99 % from, each seed |\n| --- | --- | --- | --- |\n"
    );
    let since = |t: Option<f64>| t.map_or("never".into(), |t| format!("{t:.1} s"));
    for fleet in fleets {
        let rows: Vec<&StudyRow> = study.rows.iter().filter(|r| r.fleet == fleet).collect();
        let shares: Vec<String> = rows
            .iter()
            .map(|r| format!("{:.2}", 100.0 * r.share_end))
            .collect();
        let t_99_5: Vec<String> = rows.iter().map(|r| since(r.t_99_5)).collect();
        let t_99: Vec<String> = rows.iter().map(|r| since(r.t_99)).collect();
        out += &format!(
            "| {fleet} | {} % | {} | {} |\n",
            shares.join(", "),
            t_99_5.join(", "),
            t_99.join(", ")
        );
    }
    out
}
