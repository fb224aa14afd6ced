//! The first hour of a new user, through the real binary: help for every
//! flag, errors that name what is at fault, a start that fails saying only
//! that it failed, and logs that say what the agent and the coordinator are
//! doing (connecting, connected, refused and why, retrying, link up and
//! down), without colour codes when they go to a file.

use std::io::{BufRead, BufReader, Read};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::process::{KillOnDrop, signal};
use crate::common::server::start;

fn seacover() -> Command {
    Command::new(env!("CARGO_BIN_EXE_seacover"))
}

/// Every subcommand, as its words.
const SUBCOMMANDS: &[&[&str]] = &[
    &["evaluate"],
    &["serve"],
    &["agent"],
    &["demo"],
    &["replay"],
    &["record", "info"],
    &["record", "export"],
    &["bench", "load"],
    &["sim"],
    &["sim", "safety-study"],
];

/// The entries (`--flag` or `<ARG>`) of a `--help` page that have no text.
fn undocumented(page: &str) -> Vec<String> {
    // An entry's text is on its line, after two or more spaces (short
    // help), or on the lines below it, indented further (long help).
    let lines: Vec<&str> = page.lines().collect();
    let mut missing = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let entry = line.trim_start();
        let indent = line.len() - entry.len();
        // Entries sit at most 6 columns in; deeper lines are text
        // (`[default: …]`, a value's `- name: …`).
        let is_entry = (1..=6).contains(&indent)
            && (entry.starts_with('-') || entry.starts_with('<') || entry.starts_with('['));
        if !is_entry {
            continue;
        }
        let next = lines.get(i + 1).copied().unwrap_or("");
        let next_indent = next.len() - next.trim_start().len();
        let same_line = entry
            .split_once("  ")
            .is_some_and(|(_, text)| !text.trim().is_empty());
        let documented = same_line || (!next.trim().is_empty() && next_indent > indent);
        if !documented && !entry.starts_with("-h, --help") && !entry.starts_with("-V") {
            missing.push(entry.to_string());
        }
    }
    missing
}

#[test]
fn every_flag_and_argument_has_help() {
    let mut missing = Vec::new();
    for words in SUBCOMMANDS {
        let out = seacover().args(*words).arg("--help").output().unwrap();
        assert!(out.status.success(), "{words:?} --help");
        let page = String::from_utf8(out.stdout).unwrap();
        missing.extend(
            undocumented(&page)
                .into_iter()
                .map(|e| format!("seacover {}: {e}", words.join(" "))),
        );
    }
    assert!(missing.is_empty(), "no help text:\n{}", missing.join("\n"));
    // The checker finds an entry without text.
    assert_eq!(
        undocumented(
            "Options:\n      --bare <X>\n\n      --told <Y>\n          Said.\n\n          [default: 1]\n  --short  Said too.\n  --none\n"
        ),
        ["--bare <X>", "--none"]
    );
}

#[test]
fn record_means_a_directory_everywhere() {
    for words in [&["serve"][..], &["demo"], &["sim"]] {
        let out = seacover().args(words).arg("--help").output().unwrap();
        let page = String::from_utf8(out.stdout).unwrap();
        assert!(page.contains("--record <DIR>"), "{words:?}:\n{page}");
    }
    let out = seacover().args(["serve", "--help"]).output().unwrap();
    assert!(
        String::from_utf8(out.stdout)
            .unwrap()
            .contains("--no-record")
    );
}

#[test]
fn errors_name_the_file_and_the_forms() {
    let out = seacover()
        .args(["evaluate", "/nonexistent/missing.json"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("/nonexistent/missing.json"), "{stderr}");

    let out = seacover()
        .args([
            "agent",
            "--server",
            "http://127.0.0.1:9",
            "--mavlink",
            "bogus:127.0.0.1:5760",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8(out.stderr).unwrap();
    for form in [
        "tcpout:HOST:PORT",
        "tcpin:ADDR:PORT",
        "udpin:ADDR:PORT",
        "udpout:HOST:PORT",
        "serial:DEVICE:BAUD",
    ] {
        assert!(stderr.contains(form), "{form}: {stderr}");
    }
    let out = seacover().args(["agent", "--help"]).output().unwrap();
    assert!(
        String::from_utf8(out.stdout)
            .unwrap()
            .contains("tcpin:ADDR:PORT")
    );
}

#[test]
fn a_refused_start_says_only_that_it_is_refused() {
    // Beyond loopback without a token.
    let data = tempfile::tempdir().unwrap();
    let out = seacover()
        .args(["serve", "--bind", "0.0.0.0:0", "--no-record", "--data-dir"])
        .arg(data.path())
        .env_remove("SEACOVER_TOKEN")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("without a token"), "{stderr}");

    // A data directory another coordinator holds.
    let mut first = crate::common::server::serve_unrecorded(data.path());
    first.stderr(Stdio::null());
    let (child, _) = start(first);
    let _first = KillOnDrop(child);
    let out = crate::common::server::serve_unrecorded(data.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(!out.stderr.is_empty());
}

/// Reads `child`'s stderr on a thread, line by line, until `until` has seen
/// what it waits for or `secs` pass; returns everything read.
fn stderr_until(child: &mut Child, secs: u64, until: impl Fn(&str) -> bool) -> String {
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let deadline = Instant::now() + Duration::from_secs(secs);
    let mut text = String::new();
    while Instant::now() < deadline {
        if let Ok(line) = rx.recv_timeout(Duration::from_millis(100)) {
            text.push_str(&line);
            text.push('\n');
            if until(&text) {
                break;
            }
        }
    }
    text
}

#[test]
fn an_agent_says_what_it_does_and_the_coordinator_too() {
    // No coordinator yet: the agent says it cannot reach it and when it
    // retries.
    let mut agent = seacover()
        .args(["agent", "--server", "http://127.0.0.1:9", "--vessels", "1"])
        .env_remove("RUST_LOG")
        .env_remove("SEACOVER_TOKEN")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let log = stderr_until(&mut agent, 10, |t| t.matches("retry_in_ms").count() >= 2);
    let _ = agent.kill();
    let _ = agent.wait();
    assert!(log.contains("connecting to the coordinator"), "{log}");
    assert!(log.contains("cannot reach the coordinator"), "{log}");
    assert!(log.contains("retry_in_ms"), "{log}");
    assert!(
        !log.contains('\u{1b}'),
        "no colour codes into a pipe: {log:?}"
    );

    // A coordinator with a token; an agent with the wrong one is told why.
    let data = tempfile::tempdir().unwrap();
    let mut serve = crate::common::server::serve_unrecorded(data.path());
    serve
        .env("SEACOVER_TOKEN", "right")
        .env_remove("RUST_LOG")
        .stderr(Stdio::piped());
    let (mut child, addr) = start(serve);
    let server_log = child.stderr.take().unwrap();
    let mut coordinator = KillOnDrop(child);
    let mut wrong = seacover()
        .args([
            "agent",
            "--server",
            &format!("http://{addr}"),
            "--vessels",
            "1",
        ])
        .env("SEACOVER_TOKEN", "wrong")
        .env_remove("RUST_LOG")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let log = stderr_until(&mut wrong, 10, |t| t.contains("refused"));
    let _ = wrong.kill();
    let _ = wrong.wait();
    assert!(log.contains("the coordinator refused the link"), "{log}");
    assert!(log.contains("401"), "{log}");
    assert!(log.contains("Bearer"), "the server's own message: {log}");

    // The right token: connected, and the coordinator logs the link up and
    // down, and the refusal before it.
    let mut right = seacover()
        .args([
            "agent",
            "--server",
            &format!("http://{addr}"),
            "--id",
            "usv-log",
        ])
        .env("SEACOVER_TOKEN", "right")
        .env_remove("RUST_LOG")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let log = stderr_until(&mut right, 10, |t| {
        t.contains("connected to the coordinator")
    });
    signal(right.id(), "-TERM");
    let _ = right.wait();
    assert!(log.contains("connected to the coordinator"), "{log}");
    assert!(log.contains("usv-log"), "{log}");
    std::thread::sleep(Duration::from_millis(500));
    signal(coordinator.0.id(), "-TERM");
    let _ = coordinator.0.wait();
    let mut text = String::new();
    BufReader::new(server_log)
        .read_to_string(&mut text)
        .unwrap();
    assert!(text.contains("vessel link refused"), "{text}");
    assert!(text.contains("status=401"), "{text}");
    assert!(text.contains("vessel link up"), "{text}");
    assert!(text.contains("vessel link down"), "{text}");
    assert!(text.contains("usv-log"), "{text}");
    assert!(!text.contains('\u{1b}'), "{text:?}");
    assert!(
        !text.contains("seeded with the configured mission"),
        "a serve without --config says where its mission came from: {text}"
    );
    assert!(text.contains("built-in paper scenario"), "{text}");
}
