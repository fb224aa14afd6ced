//! The `seacover` command: argument parsing and logging set-up over the library.

use std::io::Read;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use seacover::coverage::Options;
use seacover::coverage::integrate::Tolerance;
use seacover::protocol::{ErrorDetail, ErrorDocument};

#[derive(Parser)]
#[command(
    name = "seacover",
    version,
    about = "Coverage control for fleets of unmanned surface vessels"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Evaluate a scenario document (file or stdin): cells, centroids, H(P).
    Evaluate {
        /// Scenario JSON file; standard input when omitted or "-".
        file: Option<PathBuf>,
        /// Use adaptive quadrature to this estimated relative error (mass;
        /// centroid relative to the cell's size) instead of the default fixed
        /// resolution: slower, for reference results.
        #[arg(long)]
        tolerance: Option<f64>,
    },
    /// Simulate the closed loop (dynamics, observer, controller, guidance,
    /// coverage) in one process and write CSV, JSON and figures.
    Sim {
        /// `paper` (built in) or a scenario JSON file.
        #[arg(long, default_value = "paper")]
        scenario: String,
        /// Simulated seconds.
        #[arg(long, default_value_t = 200.0)]
        duration: f64,
        /// Output directory.
        #[arg(long, default_value = "sim-out")]
        out: PathBuf,
        /// Guidance law: `course` (converges) or `paper` (the literal law).
        #[arg(long, default_value = "course")]
        guidance: String,
        /// Vessel preset: `paper` or `otter`.
        #[arg(long, default_value = "paper")]
        preset: String,
        /// Seed of the random disturbances.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Disturbances: `paper`, `gusts`, `current` or `none`.
        #[arg(long, default_value = "paper")]
        disturbance: String,
        /// Skip the figures (CSV and JSON only).
        #[arg(long)]
        no_figures: bool,
    },
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    match cli.command {
        Command::Evaluate { file, tolerance } => evaluate(file, tolerance),
        Command::Sim {
            scenario,
            duration,
            out,
            guidance,
            preset,
            seed,
            disturbance,
            no_figures,
        } => match sim(
            &scenario,
            duration,
            &out,
            &guidance,
            &preset,
            seed,
            &disturbance,
            !no_figures,
        ) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("seacover sim: {e:#}");
                ExitCode::from(2)
            }
        },
    }
}

#[allow(clippy::too_many_arguments)]
fn sim(
    scenario: &str,
    duration: f64,
    out: &std::path::Path,
    guidance: &str,
    preset: &str,
    seed: u64,
    disturbance: &str,
    figures: bool,
) -> anyhow::Result<()> {
    use anyhow::{Context, bail};
    use seacover::control::guidance::GuidanceMode;
    use seacover::control::model::VesselParams;
    use seacover::sim::{Config, DisturbanceKind, load_scenario, run_to_dir};

    if !(duration.is_finite() && duration > 0.0 && duration <= 86_400.0) {
        bail!("--duration must be in (0, 86400] s");
    }
    let mode = GuidanceMode::parse(guidance)
        .with_context(|| format!("--guidance: unknown mode {guidance:?} (paper, course)"))?;
    let vessel = VesselParams::preset(preset).with_context(|| {
        format!(
            "--preset: unknown preset {preset:?} ({})",
            VesselParams::PRESETS.join(", ")
        )
    })?;
    let disturbance = DisturbanceKind::parse(disturbance).with_context(|| {
        format!("--disturbance: unknown model {disturbance:?} (paper, gusts, current, none)")
    })?;
    let (scenario, headings) = load_scenario(scenario)?;
    let mut config = Config::new(scenario, headings, duration);
    config.guidance.mode = mode;
    config.vessel = vessel;
    config.preset = preset.to_string();
    config.seed = seed;
    config.disturbance = disturbance;

    let bar = std::io::IsTerminal::is_terminal(&std::io::stderr()).then(|| {
        let bar = indicatif::ProgressBar::new(1000);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {percent:>3}% simulated, eta {eta}")
                .expect("a valid template"),
        );
        bar
    });
    let summary = run_to_dir(&config, out, figures, |f| {
        if let Some(bar) = &bar {
            bar.set_position((f * 1000.0) as u64);
        }
    })?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}

fn fail(code: &str, message: String) -> ExitCode {
    let doc = ErrorDocument {
        error: ErrorDetail {
            code: code.to_string(),
            message,
        },
    };
    eprintln!(
        "{}",
        serde_json::to_string(&doc).expect("error documents serialize")
    );
    ExitCode::from(2)
}

fn evaluate(file: Option<PathBuf>, tolerance: Option<f64>) -> ExitCode {
    let tolerance = match tolerance {
        None => Tolerance::default(),
        Some(t) if t.is_finite() && (1e-14..=1e-2).contains(&t) => Tolerance::adaptive(t),
        Some(t) => {
            return fail(
                "invalid",
                format!("--tolerance: must be in [1e-14, 1e-2], got {t}"),
            );
        }
    };
    let mut text = String::new();
    let read = match &file {
        Some(path) if path.as_os_str() != "-" => std::fs::read_to_string(path).map(|t| text = t),
        _ => std::io::stdin().read_to_string(&mut text).map(|_| ()),
    };
    if let Err(e) = read {
        return fail("io", format!("cannot read input: {e}"));
    }
    let options = Options { tolerance };
    match seacover::scenario::evaluate_text(&text, &options) {
        Ok(doc) => {
            println!(
                "{}",
                serde_json::to_string(&doc).expect("evaluations serialize")
            );
            ExitCode::SUCCESS
        }
        Err(e) => fail(e.code(), e.to_string()),
    }
}
