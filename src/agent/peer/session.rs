//! Zenoh's configuration from seacover's command line: a JSON5 file
//! (`--zenoh-config`, Zenoh's own format, for credentials and anything
//! else), then the mode and the endpoints given as flags, which win.
//!
//! Without endpoints a member finds the others by Zenoh's multicast
//! scouting (a LAN); `--zenoh-listen`/`--zenoh-connect` (`tcp/ADDR:PORT`,
//! `udp/…`, `tls/…`) cover networks where multicast does not pass.

use std::path::PathBuf;

use super::error::PeerError;

/// Which Zenoh role a process takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    #[default]
    Peer,
    /// Routes for members that reach it over a routed network (LTE, VPN).
    Router,
}

/// The Zenoh flags of `agent --peer` and `serve --peer`.
#[derive(Debug, Clone, Default)]
pub struct ZenohOptions {
    pub mode: Mode,
    pub listen: Vec<String>,
    pub connect: Vec<String>,
    pub config: Option<PathBuf>,
}

impl ZenohOptions {
    /// The Zenoh configuration these options make.
    pub fn config(&self) -> Result<zenoh::Config, PeerError> {
        let mut config = match &self.config {
            Some(path) => zenoh::Config::from_file(path.clone())
                .map_err(|e| PeerError::Config(format!("{}: {e}", path.display())))?,
            None => zenoh::Config::default(),
        };
        if let Some(path) = &self.config {
            resolve_dictionary(&mut config, path)?;
        }
        let mode = match self.mode {
            Mode::Peer => "\"peer\"",
            Mode::Router => "\"router\"",
        };
        config.insert_json5("mode", mode).map_err(bad)?;
        let list = |v: &[String]| serde_json::to_string(v).expect("strings serialize");
        if !self.listen.is_empty() {
            config
                .insert_json5("listen/endpoints", &list(&self.listen))
                .map_err(bad)?;
        }
        if !self.connect.is_empty() {
            config
                .insert_json5("connect/endpoints", &list(&self.connect))
                .map_err(bad)?;
        }
        Ok(config)
    }
}

fn bad(e: impl std::fmt::Display) -> PeerError {
    PeerError::Config(e.to_string())
}

/// A relative `transport/auth/usrpwd/dictionary_file` is read next to the
/// configuration file, not in the working directory, and so is an
/// absolute one that does not exist but has a namesake there: a
/// credentials directory works wherever it is copied.
fn resolve_dictionary(config: &mut zenoh::Config, path: &std::path::Path) -> Result<(), PeerError> {
    const KEY: &str = "transport/auth/usrpwd/dictionary_file";
    let Ok(json) = config.get_json(KEY) else {
        return Ok(());
    };
    let Ok(Some(file)) = serde_json::from_str::<Option<String>>(&json) else {
        return Ok(());
    };
    let file = std::path::Path::new(&file);
    let dir = path.parent().unwrap_or(std::path::Path::new("."));
    let beside = file.file_name().map(|name| dir.join(name));
    let moved = file.is_absolute() && !file.exists() && beside.as_ref().is_some_and(|b| b.exists());
    if file.is_relative() || moved {
        let full = if moved {
            beside.expect("checked")
        } else {
            dir.join(file)
        };
        let value = serde_json::to_string(&full.to_string_lossy()).expect("strings serialize");
        config.insert_json5(KEY, &value).map_err(bad)?;
    }
    Ok(())
}
