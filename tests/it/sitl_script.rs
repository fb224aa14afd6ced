//! `scripts/sitl-boats`, the project's own way to start ArduPilot SITL boats
//! (docs/ardupilot.md's walk-through): it starts N boats, prints each one's
//! ports, says `ready`, each primary port speaks MAVLink, and SIGTERM stops
//! every boat. Needs ArduPilot's SITL binary as the SITL tests do (skipped
//! with a message without it, failing under `CI=true`).

use std::io::{BufRead, BufReader, Read};
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::process::signal;

/// The script, stopped on drop the way a user stops it (SIGTERM, which its
/// trap passes on to the boats) rather than killed, which would orphan
/// them.
struct Stopped(std::process::Child);

impl Drop for Stopped {
    fn drop(&mut self) {
        if self.0.try_wait().ok().flatten().is_none() {
            signal(self.0.id(), "-TERM");
            let deadline = Instant::now() + Duration::from_secs(10);
            while self.0.try_wait().ok().flatten().is_none() && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(100));
            }
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

/// Instances far from the SITL tests' own (they take the first free ones).
const FIRST_INSTANCE: u32 = 40;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sitl_boats_starts_and_stops_boats() {
    let Some(ardupilot) = crate::ardupilot_sitl::ardupilot() else {
        return;
    };
    let _one_fleet = crate::ardupilot_sitl::one_sitl_fleet().await;
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/sitl-boats");
    let child = Command::new(script)
        .args(["2", "--speedup", "4", "--first-instance"])
        .arg(FIRST_INSTANCE.to_string())
        .arg("--sitl")
        .arg(&ardupilot.binary)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut script = Stopped(child);
    let mut lines = BufReader::new(script.0.stdout.take().unwrap()).lines();
    let mut ports = Vec::new();
    loop {
        let line = lines.next().expect("the script says ready").unwrap();
        if line == "ready" {
            break;
        }
        if line.starts_with("boat ") {
            let primary = line
                .split_whitespace()
                .skip_while(|w| *w != "primary")
                .nth(1)
                .unwrap()
                .to_string();
            ports.push(primary.trim_start_matches("tcp:").to_string());
        }
    }
    let expected: Vec<String> = (0..2)
        .map(|i| format!("127.0.0.1:{}", 5760 + 10 * (FIRST_INSTANCE + i)))
        .collect();
    assert_eq!(ports, expected);

    // Each primary port speaks MAVLink: after SITL's text banner, a frame's
    // start byte (0xFD v2, 0xFE v1) within 20 s of connecting.
    for address in &ports {
        let deadline = Instant::now() + Duration::from_secs(20);
        let mut stream = loop {
            match TcpStream::connect(address) {
                Ok(s) => break s,
                Err(e) => {
                    assert!(Instant::now() < deadline, "{address}: {e}");
                    std::thread::sleep(Duration::from_millis(200));
                }
            }
        };
        stream
            .set_read_timeout(Some(Duration::from_secs(20)))
            .unwrap();
        let mut seen = Vec::new();
        let mut buffer = [0u8; 512];
        while !seen.iter().any(|&b| b == 0xFD || b == 0xFE) {
            assert!(
                Instant::now() < deadline + Duration::from_secs(20),
                "{address}: no MAVLink in {:02x?}",
                seen
            );
            let n = stream.read(&mut buffer).unwrap();
            assert!(n > 0, "{address} closed after {seen:02x?}");
            seen.extend_from_slice(&buffer[..n]);
        }
    }

    // SIGTERM stops the script and its boats: the ports close.
    signal(script.0.id(), "-TERM");
    let deadline = Instant::now() + Duration::from_secs(10);
    while script.0.try_wait().unwrap().is_none() {
        assert!(Instant::now() < deadline, "the script stops within 10 s");
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(500));
    for address in &ports {
        assert!(
            TcpStream::connect(address).is_err(),
            "{address} still open after the script stopped"
        );
    }
}
