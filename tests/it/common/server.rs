//! The real `seacover serve` binary on port 0, as an operator runs it.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use seacover::protocol::MissionDocument;
use serde_json::Value;

/// `seacover serve` on port 0 with this data directory and configuration.
pub(crate) fn serve_command(data: &Path, config: &Path) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_seacover"));
    command
        .args(["serve", "--bind", "127.0.0.1:0", "--data-dir"])
        .arg(data)
        .arg("--config")
        .arg(config)
        .stdout(Stdio::piped());
    command
}

/// `seacover serve` on port 0 with this data directory, the built-in
/// mission and no recording; stdout piped for [`start`].
pub(crate) fn serve_unrecorded(data: &Path) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_seacover"));
    command
        .args([
            "serve",
            "--bind",
            "127.0.0.1:0",
            "--no-record",
            "--data-dir",
        ])
        .arg(data)
        .stdout(Stdio::piped());
    command
}

/// Starts `command` and returns it with the address it printed.
pub(crate) fn start(command: Command) -> (Child, String) {
    start_saying(command, "seacover: serving on")
}

/// Starts `command`, whose first line must begin with `first`, and returns
/// it with the address that line ends with.
pub(crate) fn start_saying(mut command: Command, first: &str) -> (Child, String) {
    let mut child = command.spawn().unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    assert!(line.starts_with(first), "{line:?}");
    let addr = line.trim().rsplit("http://").next().unwrap().to_string();
    (child, addr)
}

/// Starts the real binary on port 0 and returns it with its address.
pub(crate) fn spawn_server(data: &Path, config: &Path) -> (Child, String) {
    let mut command = serve_command(data, config);
    command.stderr(Stdio::null());
    start(command)
}

/// GETs `url` and decodes its JSON body, unwrapping both.
pub(crate) async fn get_json<T: serde::de::DeserializeOwned>(
    http: &reqwest::Client,
    url: &str,
) -> T {
    http.get(url).send().await.unwrap().json().await.unwrap()
}

pub(crate) async fn mission(http: &reqwest::Client, addr: &str) -> MissionDocument {
    get_json(http, &format!("http://{addr}/api/v1/mission")).await
}

/// `GET /metrics` of the coordinator at `addr`, as text.
pub(crate) async fn metrics(http: &reqwest::Client, addr: &str) -> String {
    let response = http.get(format!("http://{addr}/metrics")).send().await;
    response.unwrap().text().await.unwrap()
}

/// A metric's value in `/metrics` text: the sum of the samples on every
/// line that starts with `name` (a name, or a name and the start of its
/// labels) and contains `label`.
pub(crate) fn metric_sum(text: &str, name: &str, label: &str) -> f64 {
    text.lines()
        .filter(|l| l.starts_with(name) && l.contains(label))
        .filter_map(|l| l.rsplit(' ').next()?.parse::<f64>().ok())
        .sum()
}

/// A density document's value at (x, y): its base plus every Gaussian
/// object (`GET /api/v1/risk`'s `risk`, a mission's `risk`).
pub(crate) fn density_at(risk: &Value, x: f64, y: f64) -> f64 {
    let objects = risk["objects"].as_array().unwrap();
    risk["base"].as_f64().unwrap()
        + objects
            .iter()
            .map(|o| {
                let f = |k: &str| o[k].as_f64().unwrap();
                let d2 = (x - f("x")).powi(2) + (y - f("y")).powi(2);
                f("alpha") * (-d2 / (2.0 * f("sigma").powi(2))).exp()
            })
            .sum::<f64>()
}

/// Polls `check` every 100 ms for up to `secs`.
pub(crate) async fn eventually<F, Fut>(secs: u64, what: &str, mut check: F)
where
    F: FnMut() -> Fut,
    Fut: std::future::Future<Output = bool>,
{
    let deadline = tokio::time::Instant::now() + Duration::from_secs(secs);
    while !check().await {
        assert!(tokio::time::Instant::now() < deadline, "timed out: {what}");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// `seacover sim` of the paper's scenario for 6 s, recorded: its figures
/// and CSV in `dir/name`, the recording in `dir/name-recording/`, whose
/// one file it returns.
pub(crate) fn record_sim(dir: &Path, name: &str) -> PathBuf {
    record_scenario(dir, name, Path::new("paper"), 6.0)
}

/// `seacover sim --scenario SCENARIO` (built-in name or file) for
/// `seconds`, recorded as [`record_sim`] does.
pub(crate) fn record_scenario(dir: &Path, name: &str, scenario: &Path, seconds: f64) -> PathBuf {
    let recordings = dir.join(format!("{name}-recording"));
    let ok = Command::new(env!("CARGO_BIN_EXE_seacover"))
        .args(["sim", "--no-figures", "--duration", &seconds.to_string()])
        .arg("--scenario")
        .arg(scenario)
        .arg("--out")
        .arg(dir.join(name))
        .arg("--record")
        .arg(&recordings)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .unwrap()
        .success();
    assert!(ok, "seacover sim --record {}", recordings.display());
    let files: Vec<PathBuf> = std::fs::read_dir(&recordings)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    assert_eq!(
        files.len(),
        1,
        "one recording in {}: {files:?}",
        recordings.display()
    );
    files[0].clone()
}
