//! `seacover serve --config FILE`: the mission and server settings as TOML.
//!
//! Every key is optional; what is missing comes from the paper's scenario
//! (region, risk, actuator), the default guidance gains, 10 Hz and the
//! default server settings. The mission part is validated exactly as a
//! mission stored or written over REST is ([`Mission::from_document`]), so a
//! file that `serve` accepts is one the API would have accepted.
//!
//! The file seeds a new data directory only: once the store holds a mission,
//! that mission is the truth (as a database's init scripts run on an empty
//! data directory only), and `serve` says so in its log.
//!
//! ```toml
//! tick_hz = 10.0
//! origin = { lat = -35.363261, lon = 149.16523 }   # WGS84, for GeoJSON and lat/lon
//!
//! [server]
//! liveness = 3.0       # mission seconds of silence before a vessel leaves
//! write_rate = 50      # writes per second (token bucket)
//! write_burst = 100
//!
//! [region]
//! polygon = [[0, 0], [100, 0], [100, 100], [0, 100]]
//! holes = [[[40, 40], [60, 40], [60, 60], [40, 60]]]
//!
//! [risk]
//! base = 0.1
//! objects = [{ id = "wreck", x = 20, y = 70, alpha = 5, sigma = 6 }]
//!
//! [actuator]
//! k = 0.5
//! beta = 0.001
//!
//! [guidance]
//! mode = "course"
//! max_speed = 1.5
//!
//! [learning]           # learn the risk map from samples (docs/learning.md)
//! kappa = 0.0          # optimism: posterior standard deviations added
//! fade = 30.0          # the optimism's time constant [mission s]
//! refit = 5.0          # mission seconds between fits
//! lattice = 10.0       # spacing and spread of the belief's Gaussians [m]
//! weight_sd = 5.0      # the prior's spread of each Gaussian's weight
//! ```

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::error::ApiError;
use crate::mission::Mission;
use crate::protocol::{ActuatorDocument, OriginDocument, RegionDocument, RiskDocument};

/// The file as written: everything optional.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConfigFile {
    pub tick_hz: Option<f64>,
    #[serde(default)]
    pub server: ServerSection,
    /// `{ lat, lon }`: the mission's geographic origin.
    pub origin: Option<OriginDocument>,
    pub region: Option<RegionDocument>,
    pub risk: Option<RiskDocument>,
    pub actuator: Option<ActuatorDocument>,
    #[serde(default)]
    pub guidance: GuidanceSection,
    #[serde(default)]
    pub safety: SafetySection,
    /// Present (even empty): learn the risk map from samples.
    pub learning: Option<LearningSection>,
}

/// `[learning]`, each key defaulting to
/// [`LearnSettings::default`](crate::server::LearnSettings).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LearningSection {
    pub kappa: Option<f64>,
    pub fade: Option<f64>,
    pub refit: Option<f64>,
    pub lattice: Option<f64>,
    pub weight_sd: Option<f64>,
}

/// The safety filter, each key defaulting to
/// [`SafetyParams::default`](crate::control::safety::SafetyParams).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SafetySection {
    pub filter: Option<bool>,
    pub safety_distance: Option<f64>,
    pub shore_distance: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServerSection {
    pub liveness: Option<f64>,
    pub write_rate: Option<u32>,
    pub write_burst: Option<u32>,
}

/// Guidance gains, each defaulting to [`GuidanceGains::default`](crate::control::guidance::GuidanceGains).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GuidanceSection {
    pub mode: Option<String>,
    pub k_r1: Option<f64>,
    pub k_r2: Option<f64>,
    pub b1: Option<f64>,
    pub k_u1: Option<f64>,
    pub k_u2: Option<f64>,
    pub b2: Option<f64>,
    pub arrival_radius: Option<f64>,
    pub max_speed: Option<f64>,
    pub max_yaw_rate: Option<f64>,
    pub filter_time: Option<f64>,
    pub yaw_accel: Option<f64>,
    pub surge_accel: Option<f64>,
    pub hold_radius: Option<f64>,
}

/// What a configuration file settles.
#[derive(Debug, Clone)]
pub struct Settings {
    pub mission: Mission,
    pub liveness: f64,
    pub write_rate: u32,
    pub write_burst: u32,
    /// `[learning]`, when present.
    pub learning: Option<crate::server::LearnSettings>,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            mission: Mission::paper(),
            liveness: 3.0,
            write_rate: 50,
            write_burst: 100,
            learning: None,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("reading {path}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}")]
    Syntax {
        path: PathBuf,
        source: Box<toml::de::Error>,
    },
    #[error("{path}")]
    Invalid { path: PathBuf, source: ApiError },
    #[error("{path}: its risk's raster")]
    Raster {
        path: PathBuf,
        source: crate::raster::RasterError,
    },
}

impl Settings {
    /// Reads and validates a configuration file.
    pub fn load(path: &Path) -> Result<Settings, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let text = Settings::with_raster(&text, path)?;
        Settings::parse(&text).map_err(|e| e.at(path))
    }

    /// `text` with a `[risk]` that names a raster (`raster = "FILE.tif"`,
    /// relative to the file's directory, and optionally `spacing = M`)
    /// replaced by the raster's fit in the file's region and origin
    /// (docs/rasters.md); any other text as it is.
    fn with_raster(text: &str, path: &Path) -> Result<String, ConfigError> {
        let Ok(mut table) = text.parse::<toml::Table>() else {
            return Ok(text.to_string());
        };
        let Some(risk) = table.get("risk").and_then(toml::Value::as_table) else {
            return Ok(text.to_string());
        };
        let Some(file) = risk.get("raster").and_then(toml::Value::as_str) else {
            return Ok(text.to_string());
        };
        let spacing = risk
            .get("spacing")
            .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)));
        let raster_path = path.parent().unwrap_or(Path::new(".")).join(file);
        table.remove("risk");
        let placed = Settings::parse(&table.to_string()).map_err(|e| e.at(path))?;
        let raster_error = |source| ConfigError::Raster {
            path: path.to_path_buf(),
            source,
        };
        let raster = crate::raster::Raster::read(&raster_path).map_err(raster_error)?;
        let fitted = crate::raster::fit(&raster, &placed.mission, spacing).map_err(raster_error)?;
        let doc = crate::mission::belief::risk_document(&fitted.risk);
        let value = toml::Value::try_from(&doc).expect("a risk document is TOML");
        table.insert("risk".to_string(), value);
        Ok(table.to_string())
    }

    /// Parses and validates the text of a configuration file.
    pub fn parse(text: &str) -> Result<Settings, ParseError> {
        let file: ConfigFile = toml::from_str(text).map_err(|e| ParseError::Syntax(Box::new(e)))?;
        Settings::from_file(file).map_err(ParseError::Invalid)
    }

    fn from_file(file: ConfigFile) -> Result<Settings, ApiError> {
        let defaults = Settings::default();
        let mut doc = defaults.mission.document();
        if file.origin.is_some() {
            doc.origin = file.origin;
        }
        if let Some(region) = file.region {
            doc.region = region;
        }
        if let Some(risk) = file.risk {
            doc.risk = risk;
        }
        if let Some(actuator) = file.actuator {
            doc.actuator = actuator;
        }
        if let Some(hz) = file.tick_hz {
            doc.tick_hz = hz;
        }
        let g = file.guidance;
        let d = &mut doc.guidance;
        if let Some(mode) = g.mode {
            d.mode = mode;
        }
        for (slot, value) in [
            (&mut d.k_r1, g.k_r1),
            (&mut d.k_r2, g.k_r2),
            (&mut d.b1, g.b1),
            (&mut d.k_u1, g.k_u1),
            (&mut d.k_u2, g.k_u2),
            (&mut d.b2, g.b2),
            (&mut d.arrival_radius, g.arrival_radius),
            (&mut d.max_speed, g.max_speed),
            (&mut d.max_yaw_rate, g.max_yaw_rate),
            (&mut d.filter_time, g.filter_time),
            (&mut d.yaw_accel, g.yaw_accel),
            (&mut d.surge_accel, g.surge_accel),
            (&mut d.hold_radius, g.hold_radius),
        ] {
            if let Some(v) = value {
                *slot = v;
            }
        }
        let s = file.safety;
        if let Some(filter) = s.filter {
            doc.safety.filter = filter;
        }
        if let Some(d) = s.safety_distance {
            doc.safety.safety_distance = d;
        }
        if let Some(d) = s.shore_distance {
            doc.safety.shore_distance = d;
        }
        let mission = Mission::from_document(&doc)?;
        let liveness = file.server.liveness.unwrap_or(defaults.liveness);
        if !(liveness.is_finite() && liveness > 0.0 && liveness <= 3600.0) {
            return Err(ApiError::Invalid(
                "server.liveness: must be in (0, 3600] s".into(),
            ));
        }
        let write_rate = file.server.write_rate.unwrap_or(defaults.write_rate);
        let write_burst = file.server.write_burst.unwrap_or(defaults.write_burst);
        if write_rate == 0 || write_burst == 0 {
            return Err(ApiError::Invalid(
                "server.write_rate and server.write_burst: must be > 0".into(),
            ));
        }
        let learning = match &file.learning {
            Some(l) => Some(learning(l, &mission)?),
            None => None,
        };
        Ok(Settings {
            mission,
            liveness,
            write_rate,
            write_burst,
            learning,
        })
    }
}

/// `[learning]` checked against the mission's region.
fn learning(
    l: &LearningSection,
    mission: &Mission,
) -> Result<crate::server::LearnSettings, ApiError> {
    let d = crate::server::LearnSettings::default();
    let s = crate::server::LearnSettings {
        kappa: l.kappa.unwrap_or(d.kappa),
        fade: l.fade.unwrap_or(d.fade),
        refit: l.refit.unwrap_or(d.refit),
        lattice: l.lattice.unwrap_or(d.lattice),
        weight_sd: l.weight_sd.unwrap_or(d.weight_sd),
    };
    s.validate(|f| format!("learning.{f}"))
        .map_err(|e| ApiError::Invalid(e.to_string()))?;
    let (min, max) = mission.region().bounds();
    match crate::learning::Lattice::over(min, max, s.lattice) {
        Ok(_) => {}
        Err(crate::coverage::InputError::Invalid { reason, .. }) => {
            return Err(ApiError::Invalid(format!("learning.lattice: {reason}")));
        }
        Err(e) => return Err(ApiError::Invalid(e.to_string())),
    }
    Ok(s)
}

/// Why a configuration text was refused.
#[derive(Debug, thiserror::Error)]
pub enum ParseError {
    #[error("{0}")]
    Syntax(Box<toml::de::Error>),
    #[error("{0}")]
    Invalid(ApiError),
}

impl ParseError {
    /// The error of the file at `path`.
    fn at(self, path: &Path) -> ConfigError {
        let path = path.to_path_buf();
        match self {
            ParseError::Syntax(source) => ConfigError::Syntax { path, source },
            ParseError::Invalid(source) => ConfigError::Invalid { path, source },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_empty_file_is_the_paper_mission() {
        let s = Settings::parse("").unwrap();
        assert_eq!(s.mission.document(), Mission::paper().document());
        assert_eq!(s.liveness, 3.0);
    }

    #[test]
    fn the_shipped_example_parses_and_overrides() {
        let s = Settings::parse(include_str!("../../examples/seacover.toml")).unwrap();
        let doc = s.mission.document();
        assert_eq!(doc.tick_hz, 10.0);
        assert_eq!(doc.region.holes.len(), 1);
        assert_eq!(doc.risk.objects[0].id.as_deref(), Some("wreck"));
        assert_eq!(doc.guidance.max_speed, 1.5);
        assert_eq!(s.write_rate, 50);
        assert_eq!(doc.safety.safety_distance, 8.0);
        assert!(doc.safety.filter);
        let off = Settings::parse("[safety]\nfilter = false\nsafety_distance = 12").unwrap();
        assert!(!off.mission.safety().filter);
        assert_eq!(off.mission.safety().safety_distance, 12.0);
    }

    #[test]
    fn the_load_benchmark_mission_is_the_fleet_1000_scenario() {
        let s = Settings::parse(include_str!("../../examples/fleet-1000.toml")).unwrap();
        let doc = s.mission.document();
        let scenario = crate::mission::scenario::parse_document(include_str!(
            "../../examples/fleet-1000.json"
        ))
        .unwrap();
        assert_eq!(Some(doc.region), scenario.region);
        // The mission names its objects; the scenario leaves them unnamed.
        let mut risk = doc.risk;
        for o in &mut risk.objects {
            o.id = None;
        }
        assert_eq!(Some(risk), scenario.risk);
    }

    #[test]
    fn an_origin_seeds_the_mission() {
        let s = Settings::parse("origin = { lat = -35.363261, lon = 149.16523 }").unwrap();
        let origin = s.mission.document().origin.unwrap();
        assert_eq!((origin.lat, origin.lon), (-35.363261, 149.16523));
        assert_eq!(Settings::parse("").unwrap().mission.origin(), None);
    }

    #[test]
    fn bad_files_name_the_key() {
        for (text, needle) in [
            ("tick_hz = 0", "tick_hz"),
            ("tick_hz = \"fast\"", "tick_hz"),
            ("[guidance]\nmode = \"zigzag\"", "guidance.mode"),
            ("[guidance]\nmax_speed = -1", "guidance.max_speed"),
            ("[risk]\nbase = -1", "base"),
            (
                "[risk]\nbase = 0.1\nobjects = [{x = 1, y = 1, alpha = 1, sigma = 0}]",
                "sigma",
            ),
            ("[region]\npolygon = [[0, 0], [1, 1], [2, 2]]", "polygon"),
            ("[actuator]\nk = 0\nbeta = 0.001", "actuator"),
            ("[server]\nliveness = 0", "server.liveness"),
            ("[learning]\nkappa = -1", "learning.kappa"),
            ("[learning]\nfade = 0", "learning.fade"),
            ("[learning]\nrefit = 0", "learning.refit"),
            ("[learning]\nlattice = 0.5", "learning.lattice"),
            ("[learning]\nweight_sd = 0", "learning.weight_sd"),
            ("[learning]\nspread = 5", "spread"),
            ("[safety]\nsafety_distance = -1", "safety.safety_distance"),
            ("[safety]\nbraking = 1", "braking"),
            ("[server]\nwrite_rate = 0", "write_rate"),
            ("origin = { lat = 95, lon = 0 }", "origin.lat"),
            ("origin = { lat = 45 }", "origin"),
            ("speed = 3", "speed"),
        ] {
            let err = Settings::parse(text).unwrap_err().to_string();
            assert!(err.contains(needle), "{text:?}: {err}");
        }
    }
}
