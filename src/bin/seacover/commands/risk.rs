//! `seacover risk`: risk maps from GIS. `risk fit FILE.tif --mission M`
//! fits a GeoTIFF as the mission's risk (docs/rasters.md), writes it as a
//! risk document and prints the fit's error against the raster.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use seacover::mission::Mission;
use seacover::raster::{Fit, Raster};

#[derive(clap::Subcommand)]
pub(crate) enum Command {
    /// Fit a single-band GeoTIFF (EPSG:4326 or a WGS84 UTM zone) as the
    /// mission's risk, a base plus Gaussians: the risk document goes to
    /// --out (standard output without it), the fit's RMS and largest error
    /// against the raster to standard error.
    Fit(FitArgs),
}

#[derive(clap::Args)]
pub(crate) struct FitArgs {
    /// The GeoTIFF.
    #[arg(value_name = "FILE.tif")]
    raster: PathBuf,
    /// The mission, which must have an origin: a `serve --config` TOML file,
    /// or a mission or scenario JSON document.
    #[arg(long, value_name = "FILE")]
    mission: PathBuf,
    /// Where to write the risk document (JSON); standard output when
    /// omitted.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Spacing and spread of the fit's Gaussians [m]; by default 30 across
    /// the region's longer side, and at least three pixels.
    #[arg(long, value_name = "M")]
    spacing: Option<f64>,
}

pub(crate) fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Fit(args) => fit(args),
    }
}

fn fit(args: FitArgs) -> anyhow::Result<()> {
    let mission = load_mission(&args.mission)?;
    let raster = Raster::read(&args.raster)?;
    let fit = seacover::raster::fit(&raster, &mission, args.spacing)?;
    let mut text =
        serde_json::to_string_pretty(&seacover::mission::belief::risk_document(&fit.risk))?;
    text.push('\n');
    match &args.out {
        Some(path) => {
            std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))?
        }
        None => std::io::stdout()
            .lock()
            .write_all(text.as_bytes())
            .context("writing standard output")?,
    }
    eprint!("{}", summary(&raster, &fit));
    Ok(())
}

/// A mission file: TOML as `serve --config` reads it, else JSON.
fn load_mission(path: &Path) -> anyhow::Result<Mission> {
    if path.extension().is_some_and(|e| e == "toml") {
        return Ok(seacover::server::config::Settings::load(path)?.mission);
    }
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    Mission::from_text(&text).with_context(|| path.display().to_string())
}

/// What was fitted and how well, for a person; the last line is the one
/// to quote (and the one tests read).
fn summary(raster: &Raster, fit: &Fit) -> String {
    let (width, height) = raster.size();
    format!(
        "{} ({}, {width} × {height} pixels): {} with data in the region's box, \
         {} samples (means of {b} × {b} pixels)\n\
         fit: base {:.4} + {} Gaussians of σ {:.2} m (of a lattice of {})\n\
         error at the {} pixels in the region, of their range {:.4}–{:.4}: \
         RMS {:.3} %, max {:.3} %\n",
        raster.path().display(),
        raster.crs().name(),
        fit.pixels,
        fit.samples,
        fit.risk.base(),
        fit.risk.objects().len(),
        fit.spacing,
        fit.gaussians,
        fit.measured,
        fit.min,
        fit.max,
        100.0 * fit.rms,
        100.0 * fit.worst,
        b = fit.block,
    )
}
