//! `seacover sim`: the closed loop in one process (dynamics, observer,
//! controller, guidance, coverage), written as CSV, JSON and figures; and
//! `sim safety-study`, the harbour's collision and incursion study.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, ensure};
use seacover::control::guidance::GuidanceMode;
use seacover::sim::{Config, DisturbanceKind, load_scenario, run_to_dir, study};

use crate::shell::Preset;

#[derive(clap::Args)]
pub(crate) struct Args {
    #[command(subcommand)]
    study: Option<Study>,
    /// `paper`, `harbour-8`, `harbour-30` (built in) or a scenario JSON
    /// file.
    #[arg(long, value_name = "NAME|FILE", default_value = "paper")]
    scenario: String,
    /// Start where the scenario says (`scenario`) or at random legal
    /// starts drawn with --seed (`random`; the harbour's fleets leave
    /// from its staging area west of the pier).
    #[arg(long, value_enum, default_value = "scenario")]
    starts: Starts,
    /// `on`: reachable goals, routes round islands and the safety filter
    /// (collision and shore avoidance); `off`: goals and routes without
    /// the filter; `none`: straight at the centroids, no filter (the
    /// paper's pipeline, for reproducing it).
    #[arg(long, value_enum, default_value = "on")]
    safety: Safety,
    /// Least distance between two vessels' centres [m].
    #[arg(long, value_name = "M", default_value_t = seacover::control::safety::SafetyParams::default().safety_distance)]
    safety_distance: f64,
    /// Least distance from a vessel's centre to the shore [m].
    #[arg(long, value_name = "M", default_value_t = seacover::control::safety::SafetyParams::default().shore_distance)]
    shore_distance: f64,
    /// Simulated seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 200.0)]
    duration: f64,
    /// Where the CSV, JSON and figures are written.
    #[arg(long, value_name = "DIR", default_value = "sim-out")]
    out: PathBuf,
    /// Guidance law: `course` (converges) or `paper` (the literal law).
    #[arg(long, value_enum, default_value = "course")]
    guidance: Guidance,
    /// Inside this distance of its settled centroid a `course` vessel stops
    /// turning and keeps station (until twice as far); 0 never does.
    #[arg(long, value_name = "M", default_value_t = seacover::control::guidance::GuidanceGains::default().hold_radius)]
    hold_radius: f64,
    /// Vessel preset: `paper` or `otter`.
    #[arg(long, value_enum, default_value = "paper")]
    preset: Preset,
    /// Seed of the random disturbances and of random starts.
    #[arg(long, value_name = "N", default_value_t = 1)]
    seed: u64,
    /// Disturbances: `paper`, `gusts`, `current` or `none`.
    #[arg(long, value_enum, default_value = "paper")]
    disturbance: Disturbance,
    /// Skip the figures (CSV and JSON only).
    #[arg(long)]
    no_figures: bool,
    /// Also record the run as MCAP, in a new file in this directory (named
    /// by its UTC start, as every recording is): the coordinator's channels
    /// plus each vessel's truth, disturbance and observer estimate.
    #[arg(long, value_name = "DIR")]
    record: Option<PathBuf>,
    #[command(flatten)]
    learning: Learning,
}

/// Sampling and learning, for a scenario with a `truth` (docs/learning.md).
#[derive(clap::Args)]
#[command(next_help_heading = "Learning (a scenario with a truth)")]
struct Learning {
    /// What the fleet covers: the belief learned from samples (`learned`),
    /// the scenario's risk alone (`prior`: no learning), the truth
    /// itself (`truth`: the clairvoyant), or for comparison Schwager's
    /// adaptive law (`schwager`) or Lloyd on a map gridded from the
    /// samples (`grid-lloyd`).
    #[arg(long, value_enum, default_value = "learned")]
    cover: Cover,
    /// Optimism: posterior standard deviations added to the belief (0:
    /// the mean).
    #[arg(long, value_name = "K", default_value_t = 0.0)]
    kappa: f64,
    /// The optimism's time constant: κ fades as κ·exp(−t / SECONDS).
    #[arg(long, value_name = "SECONDS", default_value_t = seacover::learning::FADE)]
    fade: f64,
    /// Sample noise σ, as a share of the truth's range.
    #[arg(long, value_name = "SHARE", default_value_t = 0.05)]
    noise: f64,
    /// Share of samples replaced by gross outliers.
    #[arg(long, value_name = "SHARE", default_value_t = 0.0)]
    outliers: f64,
    /// Samples per second per vessel.
    #[arg(long, value_name = "HZ", default_value_t = 1.0)]
    sample_rate: f64,
    /// Seconds between fits of the belief.
    #[arg(long, value_name = "SECONDS", default_value_t = 5.0)]
    refit: f64,
    /// Spacing of the belief's lattice of Gaussians (and their spread).
    #[arg(long, value_name = "M", default_value_t = 10.0)]
    lattice: f64,
    /// The prior's spread of each lattice weight (the density's units).
    #[arg(long, value_name = "SD", default_value_t = seacover::learning::WEIGHT_SD)]
    weight_sd: f64,
}

impl Learning {
    /// The flags onto a run's learning settings.
    fn apply(&self, l: &mut seacover::sim::LearningConfig) -> anyhow::Result<()> {
        l.cover = match self.cover {
            Cover::Learned => seacover::sim::Cover::Learned,
            Cover::Prior => seacover::sim::Cover::Prior,
            Cover::Truth => seacover::sim::Cover::Truth,
            Cover::Schwager => seacover::sim::Cover::Schwager,
            Cover::GridLloyd => seacover::sim::Cover::GridLloyd,
        };
        (l.kappa, l.fade) = (self.kappa, self.fade);
        (l.noise, l.outliers) = (self.noise, self.outliers);
        (l.rate, l.refit, l.spacing) = (self.sample_rate, self.refit, self.lattice);
        l.weight_sd = self.weight_sd;
        l.validate().map_err(anyhow::Error::msg)
    }
}

/// The line `sim` prints about a run that learned.
fn learned(l: &seacover::sim::output::LearningSummary) -> String {
    format!(
        "learning (cover {}): H on the truth {:.2}, {:.2} % of H★ {:.2} at the end; at or above 99.5 % from {}; {} samples, {} fits (learning.json, learning.csv)",
        l.cover,
        l.h_true_end,
        100.0 * l.share_end,
        l.h_star,
        l.t_99_5
            .map_or("never".to_string(), |t| format!("{t:.1} s")),
        l.samples,
        l.fits
    )
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Cover {
    Learned,
    Prior,
    Truth,
    Schwager,
    GridLloyd,
}

#[derive(clap::Subcommand)]
enum Study {
    /// A scenario with a truth covered six ways per seed (the
    /// clairvoyant, no learning, the mean belief, an optimistic one,
    /// Schwager's adaptive law, Lloyd on a map gridded from the samples),
    /// each judged on the truth as a share of H★: table.md, study.json and
    /// the figure learning.png / .svg of the first seed (docs/learning.md).
    LearningStudy {
        /// A scenario file with a `truth`.
        #[arg(
            long,
            value_name = "FILE",
            default_value = "examples/paper-learning.json"
        )]
        scenario: String,
        /// Seeds 1..=N.
        #[arg(long, value_name = "N", default_value_t = 5)]
        seeds: u64,
        /// Simulated seconds per run.
        #[arg(long, value_name = "SECONDS", default_value_t = 300.0)]
        duration: f64,
        /// The optimistic fleet's κ.
        #[arg(long, value_name = "K", default_value_t = 1.0)]
        kappa: f64,
        /// The optimism's time constant: κ fades as κ·exp(−t / SECONDS).
        #[arg(long, value_name = "SECONDS", default_value_t = seacover::learning::FADE)]
        fade: f64,
        /// The prior's spread of each lattice weight, for both learning
        /// fleets.
        #[arg(long, value_name = "SD", default_value_t = seacover::learning::WEIGHT_SD)]
        weight_sd: f64,
        /// Where to write the table, the JSON and the figure.
        #[arg(long, value_name = "DIR", default_value = "learning-study")]
        out: PathBuf,
    },
    /// The harbour with 8 and 30 vessels from random starts, each seed with
    /// the safety filter on and off: collisions, incursions, closest
    /// approaches, H and interventions (docs/safety.md).
    SafetyStudy {
        /// Seeds 1..=N.
        #[arg(long, value_name = "N", default_value_t = 50)]
        seeds: u64,
        /// Simulated seconds per run.
        #[arg(long, value_name = "SECONDS", default_value_t = 400.0)]
        duration: f64,
        /// Where to write study.json, table.md and the trails figure.
        #[arg(long, value_name = "DIR", default_value = "safety-study")]
        out: PathBuf,
        /// Runs at once (threads).
        #[arg(long, value_name = "N", default_value_t = 1)]
        jobs: usize,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Starts {
    Scenario,
    Random,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Safety {
    On,
    Off,
    None,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Guidance {
    Course,
    Paper,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Disturbance {
    Paper,
    Gusts,
    Current,
    None,
}

pub(crate) fn run(args: Args) -> ExitCode {
    let (name, result) = match args.study {
        Some(Study::SafetyStudy {
            seeds,
            duration,
            ref out,
            jobs,
        }) => ("sim safety-study", safety_study(seeds, duration, out, jobs)),
        Some(Study::LearningStudy {
            ref scenario,
            seeds,
            duration,
            kappa,
            fade,
            weight_sd,
            ref out,
        }) => (
            "sim learning-study",
            learning_study(scenario, seeds, duration, (kappa, fade, weight_sd), out),
        ),
        None => ("sim", simulate(&args)),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("seacover {name}: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn simulate(args: &Args) -> anyhow::Result<()> {
    ensure!(
        args.duration.is_finite() && args.duration > 0.0 && args.duration <= 86_400.0,
        "--duration must be in (0, 86400] s"
    );
    let (filter, reachable_goals) = match args.safety {
        Safety::On => (true, true),
        Safety::Off => (false, true),
        Safety::None => (false, false),
    };
    let (loaded, headings) = load_scenario(&args.scenario)?;
    let mut config = Config::new(loaded, headings, args.duration);
    config.guidance.mode = match args.guidance {
        Guidance::Course => GuidanceMode::Course,
        Guidance::Paper => GuidanceMode::Paper,
    };
    ensure!(
        args.hold_radius.is_finite() && args.hold_radius >= 0.0,
        "--hold-radius must be a finite number >= 0"
    );
    config.guidance.hold_radius = args.hold_radius;
    config.vessel = args.preset.params();
    config.preset = args.preset.name().to_string();
    config.seed = args.seed;
    config.disturbance = match args.disturbance {
        Disturbance::Paper => DisturbanceKind::Paper,
        Disturbance::Gusts => DisturbanceKind::Gusts,
        Disturbance::Current => DisturbanceKind::Current,
        Disturbance::None => DisturbanceKind::None,
    };
    config.safety.filter = filter;
    config.safety.reachable_goals = reachable_goals;
    config.safety.safety_distance = args.safety_distance;
    config.safety.shore_distance = args.shore_distance;
    config.safety.validate()?;
    if let Some(l) = &mut config.learning {
        args.learning.apply(l)?;
    }
    ensure!(
        args.record.is_none() || !matches!(args.learning.cover, Cover::Schwager | Cover::GridLloyd),
        "--record records the learner's beliefs: not with --cover schwager or grid-lloyd"
    );
    let config = match args.starts {
        Starts::Scenario => config,
        Starts::Random => {
            config.with_random_starts(args.seed, seacover::sim::staging_zone(&args.scenario))?
        }
    };

    let bar = std::io::IsTerminal::is_terminal(&std::io::stderr()).then(|| {
        let bar = indicatif::ProgressBar::new(1000);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {percent:>3}% simulated, eta {eta}")
                .expect("a valid template"),
        );
        bar
    });
    let document = match &args.record {
        Some(_) => Some(seacover::sim::load_scenario_document(&args.scenario)?),
        None => None,
    };
    let record = args.record.as_deref().zip(document.as_ref());
    let written = run_to_dir(&config, &args.out, !args.no_figures, record, |f| {
        if let Some(bar) = &bar {
            bar.set_position((f * 1000.0) as u64);
        }
    })?;
    let (summary, safety) = (written.summary, written.safety);
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    println!("{}", serde_json::to_string_pretty(&summary)?);
    // What the starts put there is told apart from what the run did.
    let episodes = |what: &str, at_start: usize, later: usize, why: String| match at_start {
        0 => format!("{later} {what}"),
        n => format!("{n} {what} present at the start ({why}), {later} after"),
    };
    eprintln!(
        "safety (filter {}): {}, {}, closest pair {:.2} m, closest to shore {:.2} m, interventions {:.2} % of vessel-ticks (safety.json)",
        if safety.filter { "on" } else { "off" },
        episodes(
            "collisions",
            safety.collisions_at_start,
            safety.collisions,
            format!(
                "the scenario's starts put hulls within {} m of each other",
                2.0 * safety.hull_radius
            ),
        ),
        episodes(
            "incursions",
            safety.incursions_at_start,
            safety.incursions,
            format!(
                "the scenario's starts are within the hull radius, {} m, of the shore",
                safety.hull_radius
            ),
        ),
        safety.min_pair_distance.unwrap_or(f64::INFINITY),
        safety.min_shore_clearance,
        100.0 * safety.intervention_rate,
    );
    if let Some(l) = &written.learning {
        eprintln!("{}", learned(l));
    }
    if let Some(file) = written.recording {
        eprintln!("recorded: {}", file.display());
    }
    Ok(())
}

fn safety_study(seeds: u64, duration: f64, out: &Path, jobs: usize) -> anyhow::Result<()> {
    ensure!(
        (1..=10_000).contains(&seeds),
        "--seeds must be in [1, 10000]"
    );
    ensure!(
        duration.is_finite() && duration > 0.0 && duration <= 86_400.0,
        "--duration must be in (0, 86400] s"
    );
    ensure!((1..=64).contains(&jobs), "--jobs must be in [1, 64]");
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let started = std::time::Instant::now();
    let seed_list: Vec<u64> = (1..=seeds).collect();
    let runs = study::run_study(&[8, 30], &seed_list, duration, jobs, |r| {
        eprintln!(
            "  {:>2} vessels, seed {:>3}, filter {:<3}: {} collisions, {} incursions, H {:.1}",
            r.vessels,
            r.seed,
            if r.filter { "on" } else { "off" },
            r.collisions,
            r.incursions,
            r.h_end
        );
    })?;
    let summaries = study::summarize(&runs);
    let table = study::table(&summaries);
    let doc = serde_json::json!({"seeds": seeds, "duration": duration, "summaries": summaries, "runs": runs});
    std::fs::write(
        out.join("study.json"),
        serde_json::to_string_pretty(&doc)? + "\n",
    )?;
    std::fs::write(out.join("table.md"), &table)?;
    // The figure: the first seed of the bigger fleet, filter on.
    let config = study::study_config(30, 1, true, duration)?;
    let run = seacover::sim::run(&config, |_| {})?;
    seacover::sim::figures::draw_trails(&out.join("harbour-30-trails"), &config, &run)
        .map_err(anyhow::Error::msg)?;
    print!("{table}");
    eprintln!(
        "{} runs in {:.0} s; study.json, table.md and harbour-30-trails.{{png,svg}} in {}",
        runs.len(),
        started.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}

fn learning_study(
    scenario: &str,
    seeds: u64,
    duration: f64,
    (kappa, fade, weight_sd): (f64, f64, f64),
    out: &Path,
) -> anyhow::Result<()> {
    ensure!((1..=100).contains(&seeds), "--seeds must be in [1, 100]");
    ensure!(
        duration.is_finite() && duration > 0.0 && duration <= 86_400.0,
        "--duration must be in (0, 86400] s"
    );
    let optimism = seacover::learning::LearnSettings {
        kappa,
        fade,
        weight_sd,
        ..Default::default()
    };
    optimism.validate(|f| format!("--{}", f.replace('_', "-")))?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let seed_list: Vec<u64> = (1..=seeds).collect();
    let study = seacover::sim::learning_study::run_learning_study(
        scenario, &seed_list, duration, &optimism,
    )?;
    let table = seacover::sim::learning_study::table(&study, duration);
    std::fs::write(out.join("table.md"), &table)?;
    std::fs::write(
        out.join("study.json"),
        serde_json::to_string_pretty(&study.rows)? + "\n",
    )?;
    seacover::sim::figures::draw_series(
        &out.join("learning"),
        "H on the truth over H★ (seed 1)",
        "H_true / H★",
        duration,
        &study.curves,
    )
    .map_err(anyhow::Error::msg)?;
    print!("{table}");
    eprintln!(
        "learning study: table.md, study.json, learning.png and learning.svg in {}",
        out.display()
    );
    Ok(())
}
