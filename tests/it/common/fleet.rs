//! A peer fleet in network namespaces for the tests: the radio medium, the
//! Python observers, eight vessel processes from the paper's starts, and
//! what the observers' records say of them (mission time from the beacons,
//! positions, the closest approach, the wire's faults, the bytes on each
//! link).

use std::collections::{BTreeMap, BTreeSet, HashSet};
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::thread::sleep;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use super::netns::{Medium, cleanup_stale, root_or_skip};
use super::paper::*;
use super::peer::{Observer, Tail, now, python_or_skip, wait_for};
use super::process::{KillOnDrop, signal};
use super::secure::{credentials, member_config};

// ---------------------------------------------------------------------------
// The fleet: the medium, the observers and the vessels.

/// libfaketime (Debian's `faketime`): a process's wall clock moved, its
/// monotonic clock left alone ([`Setup::clock_off`]).
pub(crate) const FAKETIME: &str = "/usr/lib/x86_64-linux-gnu/faketime/libfaketime.so.1";

pub(crate) struct Setup {
    /// Makes the fleet's name unique; names the test in messages.
    pub tag: String,
    pub warp: f64,
    /// 1: an observer in host 0; 2: and one in host n + 1.
    pub observers: usize,
    pub observer_args: Vec<String>,
    pub vessel_args: Vec<String>,
    /// One more host, after the observers', for a shore process
    /// ([`Fleet::shore`]).
    pub shore: bool,
    /// Whether the vessels start with the mission file (else they ask the
    /// fleet for it).
    pub mission_file: bool,
    /// The mission file (the paper's unless told).
    pub mission: &'static str,
    /// One vessel whose wall clock is off by this (libfaketime's offset,
    /// e.g. `+2s`; its monotonic clock untouched).
    pub clock_off: Option<(String, String)>,
    /// The fleet's credentials (`seacover fleet credentials`: mutual TLS
    /// over QUIC datagrams) for every vessel and observer.
    pub credentials: bool,
    /// Wall time between two vessels' starts [s] (0: all at once).
    pub launch_every: f64,
    /// The vessels' beacons per second of mission time (`--beacon-hz`
    /// where it is not the default).
    pub beacon_hz: f64,
    /// The part of the machine the fleet holds while it runs: half for
    /// the paper's eight vessels at a time warp of 10 (measured); `None`
    /// where the test holds the whole machine ([`super::machine::heavy`])
    /// for this fleet and another that runs beside it.
    pub part: Option<super::machine::Part>,
}

impl Setup {
    pub(crate) fn new(tag: &str, warp: f64) -> Setup {
        Setup {
            tag: tag.to_string(),
            warp,
            observers: 1,
            observer_args: vec!["--query-mission-every".into(), "5".into()],
            vessel_args: Vec::new(),
            shore: false,
            mission_file: true,
            mission: PAPER,
            clock_off: None,
            credentials: false,
            launch_every: 0.0,
            beacon_hz: BEACON_HZ,
            part: Some(super::machine::Part::Half),
        }
    }

    pub(crate) fn status_every(mut self, secs: f64) -> Setup {
        self.observer_args
            .extend(["--query-status-every".to_string(), secs.to_string()]);
        self
    }
}

pub(crate) struct Vessel {
    pub id: String,
    pub child: KillOnDrop,
    pub log: PathBuf,
}

/// The closest two vessels came, as the observer heard them.
#[derive(Debug, Clone)]
pub(crate) struct Approach {
    pub distance: f64,
    pub pair: (String, String),
    /// Mission seconds after the vessels started.
    pub at: f64,
}

pub(crate) struct Fleet {
    pub name: String,
    /// The vessels: the mission file's scenario's, usv-1 … usv-n in hosts
    /// 1 … n.
    pub n: usize,
    pub warp: f64,
    /// Beacons per second of mission time.
    pub beacon_hz: f64,
    /// UTC when the vessels were started.
    pub started: f64,
    pub vessel_args: Vec<String>,
    pub mission_file: bool,
    pub mission: &'static str,
    pub clock_off: Option<(String, String)>,
    /// The credentials' directory, with [`Setup::credentials`].
    pub credentials: Option<PathBuf>,
    pub launch_every: f64,
    /// The observers' flags (each adds its own credentials).
    pub observer_args: Vec<String>,
    /// The shore process's host, with [`Setup::shore`].
    pub shore: Option<usize>,
    // Fields drop in order: the processes before the medium.
    pub vessels: Vec<Vessel>,
    pub observers: Vec<Observer>,
    pub tails: Vec<Tail>,
    /// Every beacon record of every observer (each beacon once per
    /// observer that heard it).
    pub beacons: Vec<Value>,
    pub statuses: Vec<Value>,
    /// Every other record (undecodable, mission replies, liveliness, …).
    pub other: Vec<Value>,
    /// The newest beacon (by its `t`) of each vessel.
    pub latest: BTreeMap<String, Value>,
    pub logs: tempfile::TempDir,
    pub medium: Medium,
    /// Its part of the machine, until everything above is gone
    /// ([`Setup::part`]).
    _heavy: Option<super::machine::Heavy>,
}

impl Fleet {
    /// The medium (hosts 0 … n, and n + 1 with a second observer) and the
    /// observers, ready; no vessel yet ([`Fleet::launch`]).
    pub(crate) fn new(setup: Setup, python: &Path) -> Fleet {
        let heavy = setup.part.map(super::machine::part);
        let n = starts_in(&scenario(setup.mission)).len();
        let hosts = n + setup.observers + usize::from(setup.shore);
        let medium = Medium::new(hosts);
        let name = format!("pf{}{}", std::process::id(), setup.tag);
        let logs = tempfile::tempdir().unwrap();
        let observer_hosts = [0, n + 1];
        let credentials = setup
            .credentials
            .then(|| credentials(logs.path(), &name, &observer_hosts));
        let mut fleet = Fleet {
            name,
            n,
            warp: setup.warp,
            beacon_hz: setup.beacon_hz,
            started: 0.0,
            vessel_args: setup.vessel_args,
            mission_file: setup.mission_file,
            mission: setup.mission,
            clock_off: setup.clock_off,
            credentials,
            launch_every: setup.launch_every,
            observer_args: setup.observer_args,
            shore: setup.shore.then_some(hosts - 1),
            vessels: Vec::new(),
            observers: Vec::new(),
            tails: Vec::new(),
            beacons: Vec::new(),
            statuses: Vec::new(),
            other: Vec::new(),
            latest: BTreeMap::new(),
            logs,
            medium,
            _heavy: heavy,
        };
        for &h in &observer_hosts[..setup.observers] {
            fleet.start_observer(h, python);
        }
        fleet
    }

    /// Starts an observer in host `host` (with its credentials when the
    /// fleet has them) and reads what it writes from now on.
    pub(crate) fn start_observer(&mut self, host: usize, python: &Path) {
        let mut args = self.observer_args.clone();
        if let Some(dir) = &self.credentials {
            args.extend([
                "--config".into(),
                member_config(dir, &format!("observer-{host}")),
            ]);
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let observer = Observer::start(&self.medium, host, python, &self.name, &args);
        self.tails.push(observer.tail());
        self.observers.push(observer);
    }

    /// Starts usv-i in host i where the mission file's scenario starts it,
    /// with the mission file unless [`Setup::mission_file`] is off.
    pub(crate) fn launch(&mut self) {
        self.started = now();
        for (i, p) in starts_in(&scenario(self.mission)).iter().enumerate() {
            if i > 0 {
                sleep(Duration::from_secs_f64(self.launch_every));
            }
            let host = i + 1;
            let log = self.logs.path().join(format!("{}.log", p.id));
            let mut cmd = self.medium.command(host, BIN);
            cmd.args(["agent", "--peer", "--id", &p.id])
                .args(["--start", &format!("{},{},{}", p.x, p.y, p.psi)])
                .args(["--fleet", &self.name])
                .args(if self.mission_file {
                    vec!["--mission", self.mission]
                } else {
                    vec![]
                })
                .args(["--time-warp", &self.warp.to_string()])
                .args(if self.beacon_hz == BEACON_HZ {
                    vec![]
                } else {
                    vec!["--beacon-hz".to_string(), self.beacon_hz.to_string()]
                })
                .args(&self.vessel_args)
                .args(
                    self.credentials
                        .iter()
                        .flat_map(|dir| ["--zenoh-config".to_string(), member_config(dir, &p.id)]),
                )
                .env("RUST_LOG", "warn,seacover::agent::peer::node=info")
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .stderr(std::fs::File::create(&log).unwrap());
            if let Some((_, offset)) = self.clock_off.as_ref().filter(|(id, _)| *id == p.id) {
                cmd.env("LD_PRELOAD", FAKETIME)
                    .env("FAKETIME", offset)
                    .env("FAKETIME_DONT_FAKE_MONOTONIC", "1");
            }
            let child = KillOnDrop(
                cmd.spawn()
                    .unwrap_or_else(|e| panic!("{}: could not start {cmd:?}: {e}", p.id)),
            );
            self.vessels.push(Vessel {
                id: p.id.clone(),
                child,
                log,
            });
        }
    }

    /// Reads what the observers wrote since the last call; panics if a
    /// vessel has exited.
    pub(crate) fn update(&mut self) {
        self.read();
        for v in &mut self.vessels {
            if let Some(status) = v.child.0.try_wait().unwrap() {
                panic!(
                    "{} exited ({status}) while the test ran; its log:\n{}",
                    v.id,
                    std::fs::read_to_string(&v.log).unwrap_or_default()
                );
            }
        }
    }

    /// Reads what the observers wrote since the last call.
    pub(crate) fn read(&mut self) {
        for tail in &mut self.tails {
            for r in tail.read() {
                match r["kind"].as_str() {
                    Some("beacon") => {
                        let mut r = r;
                        let id = r["beacon"]["id"].as_str().unwrap_or("").to_string();
                        let t = r["beacon"]["t"].as_f64().unwrap_or(f64::NAN);
                        let seq = r["beacon"]["seq"].as_i64().unwrap_or(0);
                        // The beacon's number since the vessel started.
                        let n = match self.latest.get(&id) {
                            Some(l) => unwrap_seq(
                                l["n"].as_i64().unwrap(),
                                l["beacon"]["seq"].as_i64().unwrap_or(0),
                                l["beacon"]["t"].as_f64().unwrap_or(t),
                                seq,
                                t,
                                self.warp * self.beacon_hz,
                            ),
                            None => seq,
                        };
                        r["n"] = json!(n);
                        let newer = self
                            .latest
                            .get(&id)
                            .is_none_or(|l| l["beacon"]["t"].as_f64().unwrap_or(0.0) < t);
                        if newer && t.is_finite() {
                            self.latest.insert(id, r.clone());
                        }
                        self.beacons.push(r);
                    }
                    Some("status") => self.statuses.push(r),
                    _ => self.other.push(r),
                }
            }
        }
    }

    pub(crate) fn ids(&self) -> Vec<String> {
        (1..=self.n).map(|i| format!("usv-{i}")).collect()
    }

    /// The least mission time among the running vessels (all before the
    /// launch), from the number of their newest beacons (0 while one is
    /// unheard).
    pub(crate) fn mission_time(&self) -> f64 {
        let ids = if self.vessels.is_empty() {
            self.ids()
        } else {
            self.vessels.iter().map(|v| v.id.clone()).collect()
        };
        ids.iter()
            .map(|id| {
                self.latest
                    .get(id)
                    .and_then(|r| r["n"].as_f64())
                    .map_or(0.0, |n| n / self.beacon_hz)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Runs until every vessel's mission time is `t`, calling `each` every
    /// 50 ms (wall).
    pub(crate) fn run_until(&mut self, t: f64, mut each: impl FnMut(&mut Fleet)) {
        self.update();
        let wall = (t - self.mission_time()).max(0.0) / self.warp;
        let deadline = Instant::now() + Duration::from_secs_f64(3.0 * wall + 30.0);
        loop {
            self.update();
            each(self);
            if self.mission_time() >= t {
                return;
            }
            assert!(
                Instant::now() < deadline,
                "{}: mission time {:.1} s, not {t} s, after {:.0} s of wall time (the machine too \
                 busy?); newest beacon numbers: {:?}",
                self.name,
                self.mission_time(),
                3.0 * wall + 30.0,
                self.latest
                    .iter()
                    .map(|(id, r)| (id.clone(), r["n"].clone()))
                    .collect::<Vec<_>>()
            );
            sleep(Duration::from_millis(50));
        }
    }

    /// Waits until the observers have heard every vessel.
    pub(crate) fn wait_heard_all(&mut self) -> f64 {
        let from = now();
        // A hundred processes take a while to start and find each other.
        let deadline = Instant::now() + Duration::from_secs_f64(30.0 + 0.3 * self.n as f64);
        loop {
            self.update();
            if self.latest.len() >= self.n {
                break;
            }
            assert!(
                Instant::now() < deadline,
                "{}: the observers heard {} of the {} vessels after {:.0} s: {:?}",
                self.name,
                self.latest.len(),
                self.n,
                now() - from,
                self.latest.keys().collect::<Vec<_>>()
            );
            sleep(Duration::from_millis(100));
        }
        now() - from
    }

    /// The newest status of each vessel asked for since `since` (UTC).
    pub(crate) fn newest_statuses(&self, since: f64) -> BTreeMap<String, Value> {
        let mut newest = BTreeMap::new();
        for s in &self.statuses {
            if s["sent"].as_f64().unwrap_or(0.0) >= since
                && let Some(id) = s["status"]["id"].as_str()
            {
                newest.insert(id.to_string(), s.clone());
            }
        }
        newest
    }

    /// Waits until every vessel's status says it has all the others in its
    /// partition (needs status queries); returns how long that took.
    pub(crate) fn wait_formed(&mut self, secs: f64) -> f64 {
        let from = now();
        let n = self.n;
        let what = format!("every vessel has the {} others in its partition", n - 1);
        wait_for(secs, &what, || {
            self.update();
            let newest = self.newest_statuses(from);
            (newest.len() == n
                && newest
                    .values()
                    .all(|s| s["status"]["neighbours"].as_u64() == Some(n as u64 - 1)))
            .then_some(())
        });
        now() - from
    }

    /// The vessels' newest positions, in id order.
    pub(crate) fn positions(&self) -> Vec<Pos> {
        self.ids()
            .iter()
            .map(|id| {
                let b = &self
                    .latest
                    .get(id)
                    .unwrap_or_else(|| panic!("{id} never heard"))["beacon"];
                Pos {
                    id: id.clone(),
                    x: num(&b["x"], "x"),
                    y: num(&b["y"], "y"),
                    psi: num(&b["psi"], "psi"),
                }
            })
            .collect()
    }

    /// The mission's safety distance, from the observer's mission replies
    /// (every reply must give the same).
    pub(crate) fn safety_distance(&mut self) -> f64 {
        wait_for(20.0, "a mission reply with a safety distance", || {
            self.update();
            self.other
                .iter()
                .any(|r| r["kind"] == "mission_reply" && r["safety"]["safety_distance"].is_f64())
                .then_some(())
        });
        let all: Vec<f64> = self
            .other
            .iter()
            .filter(|r| r["kind"] == "mission_reply")
            .map(|r| num(&r["safety"]["safety_distance"], "safety_distance"))
            .collect();
        assert!(
            all.iter().all(|d| *d == all[0]),
            "the members disagree on the safety distance: {all:?}"
        );
        all[0]
    }

    /// Every beacon heard once, in the order of its sender's clock.
    pub(crate) fn unique_beacons(&self) -> Vec<&Value> {
        let mut seen = HashSet::new();
        let mut unique: Vec<&Value> = self
            .beacons
            .iter()
            .filter(|r| {
                seen.insert((
                    r["beacon"]["id"].as_str().unwrap_or("").to_string(),
                    r["beacon"]["seq"].as_u64(),
                    r["beacon"]["t"].as_f64().map(f64::to_bits),
                ))
            })
            .collect();
        unique.sort_by(|a, b| {
            let t = |r: &Value| r["beacon"]["t"].as_f64().unwrap_or(0.0);
            t(a).total_cmp(&t(b))
        });
        unique
    }

    /// The closest two vessels came: each beacon against every other
    /// vessel's newest beacon at most 1 s (of mission time) older, moved
    /// along that vessel's ground velocity to the same instant.
    pub(crate) fn closest_approach(&self) -> Option<Approach> {
        struct Seen {
            t: f64,
            x: f64,
            y: f64,
            vx: f64,
            vy: f64,
        }
        let mut newest: BTreeMap<String, Seen> = BTreeMap::new();
        let mut best: Option<Approach> = None;
        for r in self.unique_beacons() {
            let b = &r["beacon"];
            let (Some(id), Some(t), Some(x), Some(y), Some(psi), Some(u), Some(v)) = (
                b["id"].as_str(),
                b["t"].as_f64(),
                b["x"].as_f64(),
                b["y"].as_f64(),
                b["psi"].as_f64(),
                b["u"].as_f64(),
                b["v"].as_f64(),
            ) else {
                continue;
            };
            let (s, c) = psi.sin_cos();
            let me = Seen {
                t,
                x,
                y,
                vx: u * c - v * s,
                vy: u * s + v * c,
            };
            for (other, o) in &newest {
                let dt = (t - o.t) * self.warp;
                if other == id || dt > 1.0 {
                    continue;
                }
                let d = (x - (o.x + o.vx * dt)).hypot(y - (o.y + o.vy * dt));
                if best.as_ref().is_none_or(|a| d < a.distance) {
                    best = Some(Approach {
                        distance: d,
                        pair: (other.clone(), id.to_string()),
                        at: (t - self.started) * self.warp,
                    });
                }
            }
            newest.insert(id.to_string(), me);
        }
        best
    }

    /// The wire: every beacon heard against the documented format.
    /// Returns (beacons checked, largest payload, the faults found).
    pub(crate) fn wire(&self) -> (usize, usize, Vec<String>) {
        let mut faults = Vec::new();
        let undecodable = self
            .other
            .iter()
            .filter(|r| r["kind"] == "undecodable")
            .count();
        if undecodable > 0 {
            faults.push(format!(
                "{undecodable} undecodable payloads, e.g. {}",
                self.other
                    .iter()
                    .find(|r| r["kind"] == "undecodable")
                    .unwrap()
            ));
        }
        let keys: BTreeSet<&str> = BEACON_KEYS.into_iter().collect();
        let mut max_size = 0;
        for r in &self.beacons {
            let size = r["size"].as_u64().unwrap_or(u64::MAX) as usize;
            max_size = max_size.max(size);
            if let Err(why) = beacon_fault(r, &keys, size)
                && faults.len() < 10
            {
                faults.push(format!("{why}: {r}"));
            }
        }
        (self.beacons.len(), max_size, faults)
    }

    /// Beacons per wall second each vessel sent (from their numbers and
    /// `t`) over the run: (least, most).
    pub(crate) fn beacon_rates(&self) -> (f64, f64) {
        let mut span: BTreeMap<&str, (f64, u64, f64, u64)> = BTreeMap::new();
        for r in self.unique_beacons() {
            let b = &r["beacon"];
            let (Some(id), Some(t), Some(seq)) =
                (b["id"].as_str(), b["t"].as_f64(), r["n"].as_u64())
            else {
                continue;
            };
            let e = span.entry(id).or_insert((t, seq, t, seq));
            (e.2, e.3) = (t, seq);
        }
        let rates: Vec<f64> = span
            .values()
            .filter(|(t0, _, t1, _)| t1 > t0)
            .map(|(t0, s0, t1, s1)| (s1 - s0) as f64 / (t1 - t0))
            .collect();
        (
            rates.iter().copied().fold(f64::INFINITY, f64::min),
            rates.iter().copied().fold(0.0, f64::max),
        )
    }

    /// The share of the beacons sent with `t` in [from, to) (UTC) that
    /// the observers heard (each vessel's beacon numbers in that window).
    pub(crate) fn delivery(&self, from: f64, to: f64) -> f64 {
        let mut seqs: BTreeMap<&str, BTreeSet<u64>> = BTreeMap::new();
        for r in &self.beacons {
            let b = &r["beacon"];
            if let (Some(id), Some(t), Some(seq)) =
                (b["id"].as_str(), b["t"].as_f64(), r["n"].as_u64())
                && (from..to).contains(&t)
            {
                seqs.entry(id).or_default().insert(seq);
            }
        }
        let (heard, sent) = seqs.values().fold((0, 0), |(h, s), set| {
            let span = set.last().unwrap() - set.first().unwrap() + 1;
            (h + set.len() as u64, s + span)
        });
        if sent == 0 {
            0.0
        } else {
            heard as f64 / sent as f64
        }
    }

    /// Each vessel's bytes on its link: (received, transmitted), host i.
    pub(crate) fn bytes(&self) -> Vec<(u64, u64)> {
        (1..=self.n).map(|i| self.medium.bytes(i)).collect()
    }

    /// SIGTERM to every vessel: each must exit 0 within 15 s. With
    /// SEACOVER_PEER_KEEP=DIR, the observers' records and the vessels' logs
    /// are copied to DIR (named by the fleet) for a closer look.
    pub(crate) fn shutdown(&mut self, checks: &mut Checks) {
        if let Some(dir) = std::env::var_os("SEACOVER_PEER_KEEP") {
            let dir = PathBuf::from(dir);
            std::fs::create_dir_all(&dir).unwrap();
            for (k, o) in self.observers.iter().enumerate() {
                let _ = std::fs::copy(&o.out, dir.join(format!("{}-observer{k}.jsonl", self.name)));
            }
            for v in &self.vessels {
                let _ = std::fs::copy(&v.log, dir.join(format!("{}-{}.log", self.name, v.id)));
            }
            eprintln!("{}: records and logs kept in {}", self.name, dir.display());
        }
        for v in &self.vessels {
            signal(v.child.0.id(), "-TERM");
        }
        let mut bad = Vec::new();
        for v in &mut self.vessels {
            let deadline = Instant::now() + Duration::from_secs(15);
            let status = loop {
                if let Some(s) = v.child.0.try_wait().unwrap() {
                    break Some(s);
                }
                if Instant::now() > deadline {
                    break None;
                }
                sleep(Duration::from_millis(50));
            };
            match status {
                Some(s) if s.success() => {}
                other => bad.push(format!("{}: {other:?}", v.id)),
            }
        }
        checks.check(
            bad.is_empty(),
            format!("every vessel exits 0 on SIGTERM within 15 s (not: {bad:?})"),
        );
        self.read();
        let digest: Vec<String> = self
            .vessels
            .iter()
            .filter_map(|v| {
                let text = std::fs::read_to_string(&v.log).unwrap_or_default();
                // The digest is of warnings and errors, with the INFO lines
                // that end one (a hold, joining, a split plan), so that a
                // failed run says how long each lasted; the rest of the
                // INFO lines (joins, plans) are kept for SEACOVER_PEER_KEEP.
                let ends = ["heard the fleet whole", "plan ended"];
                let lines: Vec<&str> = text
                    .lines()
                    .filter(|l| !l.contains(" INFO ") || ends.iter().any(|e| l.contains(e)))
                    .collect();
                let shown = lines
                    .iter()
                    .take(8)
                    .copied()
                    .collect::<Vec<_>>()
                    .join("\n    ");
                (!lines.is_empty()).then(|| {
                    format!(
                        "{}: {} log lines, the first:\n    {shown}",
                        v.id,
                        lines.len()
                    )
                })
            })
            .collect();
        if !digest.is_empty() {
            eprintln!(
                "{}: vessel logs (warnings, errors and what ended them):\n  {}",
                self.name,
                digest.join("\n  ")
            );
        }
    }
}

/// The number (since its start) of a vessel's beacon `seq` sent at `t`
/// (sender UTC), from another of its beacons, number `n0`, `seq0` at `t0`:
/// `seq` counts modulo [`SEQ_MODULUS`], so the difference is taken modulo
/// that, plus the multiple of it nearest to what the clocks say (`rate`
/// beacons per second of the sender's clock: the beacon rate times the
/// time warp): right across any gap while the vessel keeps its pace.
pub(crate) fn unwrap_seq(n0: i64, seq0: i64, t0: f64, seq: i64, t: f64, rate: f64) -> i64 {
    let expected = (t - t0) * rate;
    let d = (seq - seq0).rem_euclid(SEQ_MODULUS);
    let k = ((expected - d as f64) / SEQ_MODULUS as f64).round() as i64;
    n0 + d + k * SEQ_MODULUS
}

/// Why the beacon record `r` is not a documented beacon, if it is not.
pub(crate) fn beacon_fault(r: &Value, keys: &BTreeSet<&str>, size: usize) -> Result<(), String> {
    if size > MAX_BEACON {
        return Err(format!("{size} bytes > {MAX_BEACON}"));
    }
    let b = r["beacon"].as_object().ok_or("not a map")?;
    let got: BTreeSet<&str> = b.keys().map(String::as_str).collect();
    if &got != keys {
        return Err(format!("keys {got:?}, documented {keys:?}"));
    }
    let key = r["key"].as_str().ok_or("no key")?;
    let id = b["id"].as_str().ok_or("id not text")?;
    if !key.ends_with(&format!("/beacon/{id}")) {
        return Err(format!("id {id} on key {key}"));
    }
    if !b["seq"]
        .as_i64()
        .is_some_and(|s| (0..SEQ_MODULUS).contains(&s))
    {
        return Err(format!("seq not an integer in [0, {SEQ_MODULUS})"));
    }
    let t = b["t"].as_f64().ok_or("t not a number")?;
    let recv = r["recv"].as_f64().ok_or("no recv")?;
    if (recv - t).abs() > 60.0 {
        return Err(format!("t {t} is {:.1} s from its arrival", recv - t));
    }
    for k in ["x", "y", "psi", "u", "v", "r", "k", "beta"] {
        // The observer writes non-finite floats as strings.
        if !b[k].as_f64().is_some_and(f64::is_finite) {
            return Err(format!("{k} not a finite number"));
        }
    }
    if b["rev"].as_u64().is_none() {
        return Err("rev not a non-negative integer".into());
    }
    if !b["controlled"].is_boolean() {
        return Err("controlled not a boolean".into());
    }
    Ok(())
}

/// The vessels a status document calls fresh (heard within stale_after).
pub(crate) fn fresh(status: &Value) -> BTreeSet<String> {
    status["status"]["heard"]
        .as_object()
        .map(|h| {
            h.iter()
                .filter(|(_, age)| age.as_f64().is_some_and(|a| a <= STALE_AFTER))
                .map(|(id, _)| id.clone())
                .collect()
        })
        .unwrap_or_default()
}

pub(crate) fn skip(test: &str) -> Option<PathBuf> {
    if !root_or_skip(test) {
        return None;
    }
    let python = python_or_skip(test)?;
    cleanup_stale();
    Some(python)
}

pub(crate) fn approach_text(a: &Option<Approach>) -> String {
    match a {
        Some(a) => format!(
            "{:.2} m ({} and {}, {:.1} s of mission time in)",
            a.distance, a.pair.0, a.pair.1, a.at
        ),
        None => "none heard".into(),
    }
}

pub(crate) fn check_safety(checks: &mut Checks, fleet: &Fleet, safety: f64) -> f64 {
    let closest = fleet.closest_approach();
    let d = closest.as_ref().map_or(f64::NAN, |a| a.distance);
    checks.check(
        d >= safety,
        format!(
            "no two vessels closer than the safety distance {safety} m: closest {}",
            approach_text(&closest)
        ),
    );
    d
}

pub(crate) fn check_wire(checks: &mut Checks, fleet: &Fleet) -> (usize, usize) {
    let (count, max_size, faults) = fleet.wire();
    checks.check(
        count > 0 && faults.is_empty(),
        format!(
            "{count} beacons, each ≤ {MAX_BEACON} bytes (largest {max_size}) and a CBOR map of \
             exactly the documented keys: faults {faults:?}"
        ),
    );
    (count, max_size)
}
