//! `seacover sim safety-study`: the harbour scenario from many random starts,
//! each run twice — safety filter on and off — measuring collisions,
//! incursions, closest approaches, interventions and the final H.
//!
//! Every run is an ordinary [`run`](super::run) of the built-in `harbour-8`
//! or `harbour-30` scenario with [`Config::with_random_starts`] for its seed
//! in the harbour's staging area (the seed also seeds the disturbances),
//! without Lloyd's baseline. Runs are
//! independent, so they may be spread over threads; the results are sorted,
//! so the report does not depend on how many.
//!
//! Collisions, incursions and breaches count the episodes that began
//! during a run; those already under way at t = 0 are counted apart
//! (`*_at_start`) and the table shows them only when there are any (legal
//! random starts, D apart and D_s + 3 m off the shore, have none).

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use serde::Serialize;

use super::monitor::SafetyRecord;
use super::{Config, Run, SimError, load_scenario};

/// One run of the study.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StudyRun {
    pub vessels: usize,
    pub seed: u64,
    pub filter: bool,
    /// Episodes that began after t = 0.
    pub collisions: usize,
    pub incursions: usize,
    pub safety_distance_breaches: usize,
    pub shore_distance_breaches: usize,
    /// Episodes already under way at t = 0.
    pub collisions_at_start: usize,
    pub incursions_at_start: usize,
    pub safety_distance_breaches_at_start: usize,
    pub shore_distance_breaches_at_start: usize,
    pub min_pair_distance: f64,
    pub min_shore_clearance: f64,
    pub intervention_rate: f64,
    #[serde(rename = "H_end")]
    pub h_end: f64,
    pub goal_distance_max_end: f64,
}

impl StudyRun {
    fn new(vessels: usize, seed: u64, config: &Config, run: &Run) -> StudyRun {
        let r: &SafetyRecord = &run.safety;
        let last = run.ticks.last().expect("a run has a last tick");
        StudyRun {
            vessels,
            seed,
            filter: config.safety.filter,
            collisions: r.collisions,
            incursions: r.incursions,
            safety_distance_breaches: r.pair_breaches,
            shore_distance_breaches: r.shore_breaches,
            collisions_at_start: r.collisions_at_start,
            incursions_at_start: r.incursions_at_start,
            safety_distance_breaches_at_start: r.pair_breaches_at_start,
            shore_distance_breaches_at_start: r.shore_breaches_at_start,
            min_pair_distance: r.min_pair_distance,
            min_shore_clearance: r.min_shore_clearance,
            intervention_rate: r.intervention_rate(),
            h_end: last.h,
            goal_distance_max_end: last.vessels.iter().map(|v| v.command.e).fold(0.0, f64::max),
        }
    }
}

/// The configuration of one study run.
pub fn study_config(
    vessels: usize,
    seed: u64,
    filter: bool,
    duration: f64,
) -> Result<Config, SimError> {
    let name = format!("harbour-{vessels}");
    let (scenario, headings) = load_scenario(&name)?;
    let mut config = Config::new(scenario, headings, duration);
    config.seed = seed;
    config.lloyd = false;
    config.safety.filter = filter;
    config.snapshots = vec![duration];
    config.with_random_starts(seed, super::staging_zone(&name))
}

/// Runs `fleets × seeds × {filter on, off}` on `jobs` threads; `progress`
/// is told each finished run. Results sorted by fleet, seed, filter (on
/// first).
pub fn run_study(
    fleets: &[usize],
    seeds: &[u64],
    duration: f64,
    jobs: usize,
    progress: impl Fn(&StudyRun) + Sync,
) -> Result<Vec<StudyRun>, SimError> {
    let mut work: Vec<(usize, u64, bool)> = Vec::new();
    for &v in fleets {
        for &seed in seeds {
            for filter in [true, false] {
                work.push((v, seed, filter));
            }
        }
    }
    // Biggest fleets first, so the threads finish together.
    work.sort_by_key(|&(v, seed, filter)| (std::cmp::Reverse(v), seed, !filter));
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Result<StudyRun, SimError>>> = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1) {
            scope.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&(v, seed, filter)) = work.get(k) else {
                        break;
                    };
                    let outcome = study_config(v, seed, filter, duration).and_then(|config| {
                        let run = super::run(&config, |_| {})?;
                        Ok(StudyRun::new(v, seed, &config, &run))
                    });
                    if let Ok(r) = &outcome {
                        progress(r);
                    }
                    results
                        .lock()
                        .expect("no thread panics holding it")
                        .push(outcome);
                }
            });
        }
    });
    let mut runs = results
        .into_inner()
        .expect("no thread panics holding it")
        .into_iter()
        .collect::<Result<Vec<_>, _>>()?;
    runs.sort_by_key(|r| (r.vessels, r.seed, !r.filter));
    Ok(runs)
}

/// Aggregates of one fleet size.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FleetSummary {
    pub vessels: usize,
    pub seeds: usize,
    pub on: Side,
    pub off: Side,
    /// Mean and worst of (H_on − H_off) / H_off over seeds.
    pub h_relative_mean: f64,
    pub h_relative_worst: f64,
}

/// Aggregates of one fleet size with the filter on or off.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Side {
    /// Episodes that began after t = 0, summed over the runs.
    pub collisions: usize,
    pub incursions: usize,
    /// Runs with a collision or an incursion that began after t = 0.
    pub seeds_with_collision_or_incursion: usize,
    pub safety_distance_breaches: usize,
    pub shore_distance_breaches: usize,
    /// Episodes already under way at t = 0, summed over the runs.
    pub collisions_at_start: usize,
    pub incursions_at_start: usize,
    pub safety_distance_breaches_at_start: usize,
    pub shore_distance_breaches_at_start: usize,
    pub min_pair_distance: f64,
    pub min_shore_clearance: f64,
    pub h_end_mean: f64,
    pub intervention_rate_mean: f64,
    pub goal_distance_max_end: f64,
}

fn side(runs: &[&StudyRun]) -> Side {
    let n = runs.len().max(1) as f64;
    Side {
        collisions: runs.iter().map(|r| r.collisions).sum(),
        incursions: runs.iter().map(|r| r.incursions).sum(),
        seeds_with_collision_or_incursion: runs
            .iter()
            .filter(|r| r.collisions + r.incursions > 0)
            .count(),
        safety_distance_breaches: runs.iter().map(|r| r.safety_distance_breaches).sum(),
        shore_distance_breaches: runs.iter().map(|r| r.shore_distance_breaches).sum(),
        collisions_at_start: runs.iter().map(|r| r.collisions_at_start).sum(),
        incursions_at_start: runs.iter().map(|r| r.incursions_at_start).sum(),
        safety_distance_breaches_at_start: runs
            .iter()
            .map(|r| r.safety_distance_breaches_at_start)
            .sum(),
        shore_distance_breaches_at_start: runs
            .iter()
            .map(|r| r.shore_distance_breaches_at_start)
            .sum(),
        min_pair_distance: runs
            .iter()
            .map(|r| r.min_pair_distance)
            .fold(f64::INFINITY, f64::min),
        min_shore_clearance: runs
            .iter()
            .map(|r| r.min_shore_clearance)
            .fold(f64::INFINITY, f64::min),
        h_end_mean: runs.iter().map(|r| r.h_end).sum::<f64>() / n,
        intervention_rate_mean: runs.iter().map(|r| r.intervention_rate).sum::<f64>() / n,
        goal_distance_max_end: runs
            .iter()
            .map(|r| r.goal_distance_max_end)
            .fold(0.0, f64::max),
    }
}

/// Per fleet size: the filter on against off, seed by seed.
pub fn summarize(runs: &[StudyRun]) -> Vec<FleetSummary> {
    let mut sizes: Vec<usize> = runs.iter().map(|r| r.vessels).collect();
    sizes.dedup();
    sizes
        .into_iter()
        .map(|v| {
            let on: Vec<&StudyRun> = runs.iter().filter(|r| r.vessels == v && r.filter).collect();
            let off: Vec<&StudyRun> = runs
                .iter()
                .filter(|r| r.vessels == v && !r.filter)
                .collect();
            let rel: Vec<f64> = on
                .iter()
                .filter_map(|a| {
                    off.iter()
                        .find(|b| b.seed == a.seed)
                        .map(|b| (a.h_end - b.h_end) / b.h_end)
                })
                .collect();
            FleetSummary {
                vessels: v,
                seeds: on.len(),
                on: side(&on),
                off: side(&off),
                h_relative_mean: rel.iter().sum::<f64>() / rel.len().max(1) as f64,
                h_relative_worst: rel
                    .iter()
                    .copied()
                    .fold(0.0, |w, x| if x.abs() > w.abs() { x } else { w }),
            }
        })
        .collect()
}

/// A count of episodes that began during the runs, with those under way at
/// t = 0 after it when there are any: `3 (+2 at start)`.
fn count(later: usize, at_start: usize) -> String {
    match at_start {
        0 => later.to_string(),
        n => format!("{later} (+{n} at start)"),
    }
}

/// The Markdown table of `docs/safety.md`. Counts are of episodes that
/// began during the runs; any under way at t = 0 follow in parentheses.
pub fn table(summaries: &[FleetSummary]) -> String {
    let mut out = String::new();
    out.push_str("| vessels | seeds | filter | collisions | incursions | runs with either | safety-distance breaches (pair / shore) | min pair distance (m) | min shore clearance (m) | H end (mean) | ΔH on vs off (mean / worst) | intervention rate | max goal distance at end (m) |\n");
    out.push_str("|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for s in summaries {
        for (name, side) in [("on", &s.on), ("off", &s.off)] {
            let dh = if name == "on" {
                format!(
                    "{:+.3} % / {:+.3} %",
                    100.0 * s.h_relative_mean,
                    100.0 * s.h_relative_worst
                )
            } else {
                "—".to_string()
            };
            let rate = if name == "on" {
                format!("{:.2} %", 100.0 * side.intervention_rate_mean)
            } else {
                "—".to_string()
            };
            out.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} | {} / {} | {:.2} | {:.2} | {:.1} | {} | {} | {:.2} |\n",
                s.vessels,
                s.seeds,
                name,
                count(side.collisions, side.collisions_at_start),
                count(side.incursions, side.incursions_at_start),
                side.seeds_with_collision_or_incursion,
                count(
                    side.safety_distance_breaches,
                    side.safety_distance_breaches_at_start
                ),
                count(
                    side.shore_distance_breaches,
                    side.shore_distance_breaches_at_start
                ),
                side.min_pair_distance,
                side.min_shore_clearance,
                side.h_end_mean,
                dh,
                rate,
                side.goal_distance_max_end,
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(seed: u64, filter: bool) -> StudyRun {
        StudyRun {
            vessels: 8,
            seed,
            filter,
            collisions: 0,
            incursions: 0,
            safety_distance_breaches: 0,
            shore_distance_breaches: 0,
            collisions_at_start: 0,
            incursions_at_start: 0,
            safety_distance_breaches_at_start: 0,
            shore_distance_breaches_at_start: 0,
            min_pair_distance: 9.0,
            min_shore_clearance: 5.0,
            intervention_rate: 0.01,
            h_end: 100.0,
            goal_distance_max_end: 1.0,
        }
    }

    #[test]
    fn the_table_tells_the_starts_from_the_runs() {
        // Seed 1 without the filter starts two hulls ashore and collides
        // once later; seed 2 without it starts clean and runs aground.
        let mut off_1 = run(1, false);
        off_1.incursions_at_start = 2;
        off_1.shore_distance_breaches_at_start = 2;
        off_1.collisions = 1;
        off_1.safety_distance_breaches = 1;
        let mut off_2 = run(2, false);
        off_2.incursions = 1;
        off_2.shore_distance_breaches = 1;
        let runs = [run(1, true), off_1, run(2, true), off_2];
        let s = summarize(&runs);
        assert_eq!(s.len(), 1);
        let off = &s[0].off;
        assert_eq!((off.collisions, off.incursions), (1, 1));
        assert_eq!((off.collisions_at_start, off.incursions_at_start), (0, 2));
        assert_eq!(off.seeds_with_collision_or_incursion, 2);
        assert_eq!(s[0].on.seeds_with_collision_or_incursion, 0);
        let table = table(&s);
        let rows: Vec<&str> = table.lines().skip(2).collect();
        assert!(
            rows[0].starts_with("| 8 | 2 | on | 0 | 0 | 0 | 0 / 0 |"),
            "{}",
            rows[0]
        );
        assert!(
            rows[1].starts_with("| 8 | 2 | off | 1 | 1 (+2 at start) | 2 | 1 / 1 (+2 at start) |"),
            "{}",
            rows[1]
        );
    }
}
