//! The browser for the dashboard tests: Debian's chromium, headless, driven
//! through chromedriver (WebDriver) by fantoccini; finding them (or
//! skipping without them, but under `CI=true`), starting the driver on a
//! port it picks, a session with the console log on, and what the tests do
//! with the page: wait for a condition, screenshot, click, drag, read the
//! console.

use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use fantoccini::actions::{InputSource, MOUSE_BUTTON_LEFT, MouseActions, PointerAction};
use fantoccini::{Client, ClientBuilder};
use serde_json::{Value, json};

pub(crate) fn find(program: &str) -> Option<PathBuf> {
    std::env::var_os("PATH")?
        .to_str()?
        .split(':')
        .map(|dir| PathBuf::from(dir).join(program))
        .find(|p| p.is_file())
}

/// chromedriver and a chromium binary, or the reason they are missing.
pub(crate) fn browser() -> Result<(PathBuf, PathBuf), String> {
    let driver = find("chromedriver").ok_or("chromedriver is not installed")?;
    let chrome = ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .find_map(|p| find(p))
        .ok_or("chromium is not installed")?;
    Ok((driver, chrome))
}

/// The browser (chromedriver, chromium) and the machine
/// ([`super::machine`]: Chromium keeps both cores busy rendering; taken
/// before the test starts anything timed), or `None` after saying why the
/// test is skipped; under `CI=true` a missing browser fails the test
/// instead.
pub(crate) async fn browser_or_skip() -> Option<(PathBuf, PathBuf, super::machine::Heavy)> {
    match browser() {
        Ok((driver, chrome)) => Some((driver, chrome, super::machine::heavy_async().await)),
        Err(why) if std::env::var("CI").as_deref() == Ok("true") => {
            panic!("{why}: CI must install chromium and chromium-driver")
        }
        Err(why) => {
            eprintln!(
                "SKIPPED the dashboard browser test: {why} (apt-get install chromium chromium-driver)"
            );
            None
        }
    }
}

/// chromedriver, in a process group of its own with the browsers it
/// starts: dropped, the whole group is killed, so a test that fails before
/// it closes its session leaves no Chromium rendering beside the tests
/// after it.
pub(crate) struct Driver(Child);

impl Drop for Driver {
    fn drop(&mut self) {
        // The group's id is the driver's pid (`process_group(0)`).
        let _ = Command::new("kill")
            .args(["-KILL", "--", &format!("-{}", self.0.id())])
            .stderr(Stdio::null())
            .status();
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts chromedriver on a port it picks itself (`--port=0`) and reads
/// the port from its banner: a port picked here and then freed for the
/// driver could be taken by another test's listener in between.
pub(crate) async fn start_driver(driver: &PathBuf) -> (Driver, u16) {
    use std::io::{BufRead, BufReader};
    let mut child = Command::new(driver)
        .process_group(0)
        .arg("--port=0")
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("chromedriver starts");
    let stdout = child.stdout.take().expect("chromedriver's stdout");
    let (port_tx, port_rx) = tokio::sync::oneshot::channel();
    // Reads the banner, then drains the rest so that the driver never
    // blocks on a full pipe.
    std::thread::spawn(move || {
        let mut port_tx = Some(port_tx);
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            let port = line
                .strip_prefix("ChromeDriver was started successfully on port ")
                .and_then(|rest| rest.trim_end_matches('.').parse::<u16>().ok());
            if let Some(port) = port
                && let Some(tx) = port_tx.take()
            {
                let _ = tx.send(port);
            }
        }
    });
    let driver = Driver(child);
    let port = tokio::time::timeout(Duration::from_secs(20), port_rx)
        .await
        .expect("chromedriver did not report its port within 20 s")
        .expect("chromedriver exited before reporting its port");
    (driver, port)
}

pub(crate) async fn open_browser(port: u16, chrome: &std::path::Path) -> Client {
    let mut caps = serde_json::Map::new();
    caps.insert(
        "goog:chromeOptions".into(),
        json!({
            "binary": chrome,
            "args": ["--headless=new", "--no-sandbox", "--disable-gpu",
                     "--disable-dev-shm-usage", "--window-size=1400,900"],
        }),
    );
    // The console (what the page logs, and what the browser logs about it:
    // failed loads, refused connections), for [`console_log`].
    caps.insert("goog:loggingPrefs".into(), json!({"browser": "ALL"}));
    ClientBuilder::new(hyper_util::client::legacy::connect::HttpConnector::new())
        .capabilities(caps)
        .connect(&format!("http://127.0.0.1:{port}"))
        .await
        .expect("a browser session")
}

pub(crate) fn shots() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/dashboard");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

pub(crate) async fn screenshot(client: &Client, name: &str) {
    let png = client.screenshot().await.unwrap();
    std::fs::write(shots().join(format!("{name}.png")), png).unwrap();
}

/// Polls `check` (a JS expression) until it is true.
pub(crate) async fn until(client: &Client, what: &str, check: &str) {
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let v = client
            .execute(&format!("return !!({check});"), vec![])
            .await
            .unwrap();
        if v == Value::Bool(true) {
            return;
        }
        if Instant::now() > deadline {
            screenshot(client, "timeout").await;
            panic!("timed out waiting for {what} ({check})");
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// The viewport position of a world point on the map.
pub(crate) async fn screen_of(client: &Client, x: f64, y: f64) -> (f64, f64) {
    let v = client
        .execute(
            "const [sx, sy] = window.seacover.view.toScreen(arguments[0], arguments[1]);
             const r = document.getElementById('map').getBoundingClientRect();
             return [r.left + sx, r.top + sy];",
            vec![json!(x), json!(y)],
        )
        .await
        .unwrap();
    (v[0].as_f64().unwrap(), v[1].as_f64().unwrap())
}

pub(crate) async fn click_at(client: &Client, x: f64, y: f64) {
    let mouse = MouseActions::new("mouse".into())
        .then(PointerAction::MoveTo {
            duration: None,
            x: x.round(),
            y: y.round(),
        })
        .then(PointerAction::Down {
            button: MOUSE_BUTTON_LEFT,
        })
        .then(PointerAction::Up {
            button: MOUSE_BUTTON_LEFT,
        });
    client.perform_actions(mouse).await.unwrap();
}

pub(crate) async fn drag(client: &Client, from: (f64, f64), to: (f64, f64)) {
    let mut mouse = MouseActions::new("mouse".into())
        .then(PointerAction::MoveTo {
            duration: None,
            x: from.0.round(),
            y: from.1.round(),
        })
        .then(PointerAction::Down {
            button: MOUSE_BUTTON_LEFT,
        });
    for k in 1..=10 {
        let f = k as f64 / 10.0;
        mouse = mouse.then(PointerAction::MoveTo {
            duration: Some(Duration::from_millis(20)),
            x: (from.0 + f * (to.0 - from.0)).round(),
            y: (from.1 + f * (to.1 - from.1)).round(),
        });
    }
    mouse = mouse.then(PointerAction::Up {
        button: MOUSE_BUTTON_LEFT,
    });
    client.perform_actions(mouse).await.unwrap();
}

/// The browser's console since the last call (chromedriver's log endpoint
/// drains it), each entry `{level, message, source, timestamp}`: what the
/// page logged and what the browser logged about it, such as a failed
/// load's "the server responded with a status of 404".
pub(crate) async fn console_log(client: &Client, driver_port: u16) -> Vec<Value> {
    let session = client.session_id().await.unwrap().expect("a session");
    let answer: Value = reqwest::Client::new()
        .post(format!(
            "http://127.0.0.1:{driver_port}/session/{session}/se/log"
        ))
        .json(&json!({"type": "browser"}))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    answer["value"]
        .as_array()
        .unwrap_or_else(|| panic!("chromedriver's log: {answer}"))
        .clone()
}

/// The console's errors since the last call: entries at level `SEVERE`
/// (console.error, uncaught exceptions, failed loads and requests).
pub(crate) async fn console_errors(client: &Client, driver_port: u16) -> Vec<Value> {
    console_log(client, driver_port)
        .await
        .into_iter()
        .filter(|e| e["level"] == "SEVERE")
        .collect()
}
