//! A simulated radio medium for the peer-fleet tests: every simulated vessel
//! process runs in a Linux network namespace of its own ("host"), linked by a
//! veth pair to one Linux bridge that lives in one more namespace (the
//! "medium"), where partitions, packet loss, range limits and bandwidth
//! limits are applied.
//!
//! Layout of a [`Medium`] with `n` hosts, names `scnet-<pid>-<k>-…` (the
//! test process's id and a per-process counter, so parallel tests and
//! parallel test processes never collide; [`cleanup_stale`] removes what a
//! crashed run left):
//!
//! - `scnet-<pid>-<k>-m`: bridge `br0` (up, multicast snooping off, so
//!   multicast is always flooded), and `v0 … v<n-1>`, the medium's ends of
//!   the veth pairs, enslaved to `br0`. `net.bridge.bridge-nf-call-iptables`
//!   is set to 1 here, so that bridged frames traverse this namespace's
//!   iptables FORWARD chain, where `-m physdev --physdev-out vB` tells the
//!   hosts apart (for flooded multicast too: the hook runs once per output
//!   port). FORWARD jumps to three chains of ours: `SC_PART`
//!   ([`Medium::partition`]), `SC_CUT` ([`Medium::cut_pairs`]), `SC_LOSS`
//!   ([`Medium::loss`]).
//! - Partitions and cuts change while the vessels move, so they never go
//!   through a netfilter commit: under load (eight vessels at a time warp
//!   on two busy cores) one `iptables-restore` took up to 28 s here,
//!   waiting in the kernel, and a range-limited radio that lags the boats
//!   by seconds lets two of them close in silence. Their chains are fixed
//!   when the medium is made: one rule per port `vB`, dropping what leaves
//!   it from a source in the `xt_recent` list `sc_part_vB` or `sc_cut_vB`.
//!   A change adds or removes addresses in those lists by writing to
//!   `/proc/<pid>/net/xt_recent/…` of a `sleep` the medium keeps in its
//!   namespace: a write under the same load took at most 7 ms. `SC_LOSS`
//!   is rebuilt whole, one `iptables-restore --noflush` batch each time.
//! - `scnet-<pid>-<k>-h<i>`: `lo` up, `eth0` (the host's end of its veth)
//!   with 10.77.<k mod 250>.<i+1>/24, and a route for 224.0.0.0/4 on `eth0`:
//!   without any route for multicast, a plain socket's send to Zenoh's
//!   scouting group 224.0.0.224:7446 fails with ENETUNREACH (Zenoh itself
//!   picks the interface, but other tools do not).
//!
//! Invariants:
//! - Nothing is changed in the host's (the machine's) own namespace: no
//!   interface, route, iptables rule, qdisc or sysctl. Everything lives in
//!   the namespaces made here, and [`Drop`] deletes them all (deleting a
//!   host's namespace destroys its veth pair; deleting the medium's destroys
//!   the bridge, its rules and qdiscs). The bridge-netfilter sysctls are per
//!   namespace (since Linux 5.3; checked on this machine: setting them in a
//!   namespace leaves the host's value alone). One thing is global: if the
//!   `br_netfilter` module is not loaded (the sysctls are missing), it is
//!   loaded with `modprobe`, which cannot be undone per test; on a machine
//!   where it is built in (CONFIG_BRIDGE_NETFILTER=y) nothing is loaded.
//! - Every host knows every other host's MAC address from the start (a
//!   permanent neighbour entry each, fixed addresses `02:5c:<k>:00:00:<i>`):
//!   the kernel keeps one neighbour table for all namespaces, and by default
//!   refuses a new ARP entry past 1024 in all (`gc_thresh3`, settable only in
//!   the machine's own namespace, which is not ours to change). A hundred
//!   hosts, each with its neighbours in range, passed that at the 48th: its
//!   packets were dropped before they left ("neighbor table overflow" in the
//!   kernel's log). Permanent entries are not counted against it.
//! - IPv4 only: IPv6 is disabled in every namespace made here, so no packet
//!   bypasses the IPv4 rules (the rules do not see ARP; ARP replies carry
//!   no data and are left alone).
//! - A condition of one kind replaces the previous one of its kind; kinds
//!   combine (a partition and a loss rate at the same time).
//! - Processes are only started by the caller ([`Medium::command`]), except
//!   the medium's own `sleep`, which it kills on [`Drop`]. A namespace
//!   deleted while a process is still in it lives on until that process
//!   exits.
//! - Every command's exit status is checked: a failure panics naming the
//!   command and its stderr. Everything is synchronous.
//!
//! Callers check [`root_or_skip`] first: without root the tests are skipped
//! with a message, except under CI=true, where that is a failure.

use std::collections::BTreeSet;
use std::io::Write;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// The prefix of every namespace made here.
const PREFIX: &str = "scnet-";

/// The chains of ours hooked from FORWARD in the medium's namespace.
const PARTITION: &str = "SC_PART";
const CUT: &str = "SC_CUT";
const LOSS: &str = "SC_LOSS";

/// A packet that would wait longer than this in a rate-limited link's queue
/// is dropped, as a saturated radio would.
const TBF_LATENCY: &str = "200ms";

/// Makes the namespace names of one process unique.
static NEXT: AtomicUsize = AtomicUsize::new(0);

/// Whether this process can create network namespaces (uid 0 and
/// iproute2's `ip`). Otherwise prints "skipped: <test> needs root to create
/// network namespaces" and returns false, or panics under CI=true.
pub(crate) fn root_or_skip(test: &str) -> bool {
    let root = uid() == Some(0);
    let ip = Command::new("ip")
        .arg("-V")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if root && ip {
        return true;
    }
    let why = if root {
        "needs iproute2's `ip` to create network namespaces"
    } else {
        "needs root to create network namespaces"
    };
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "CI=true: {test} {why}"
    );
    eprintln!("skipped: {test} {why}");
    false
}

/// The real user id, from /proc/self/status.
fn uid() -> Option<u32> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("Uid:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Runs `program args…` (with `stdin` on its standard input) and returns its
/// stdout; panics naming the command and its stderr if it fails.
fn run(program: &str, args: &[&str], stdin: Option<&str>) -> String {
    let shown = || format!("`{program} {}`", args.join(" "));
    let mut child = Command::new(program)
        .args(args)
        .stdin(if stdin.is_some() {
            Stdio::piped()
        } else {
            Stdio::null()
        })
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("{} could not start: {e}", shown()));
    if let Some(input) = stdin {
        let mut pipe = child.stdin.take().unwrap();
        pipe.write_all(input.as_bytes())
            .unwrap_or_else(|e| panic!("{}: writing its stdin: {e}", shown()));
    }
    let out = child
        .wait_with_output()
        .unwrap_or_else(|e| panic!("{}: {e}", shown()));
    assert!(
        out.status.success(),
        "{} failed ({}): {}{}",
        shown(),
        out.status,
        String::from_utf8_lossy(&out.stderr),
        stdin.map_or(String::new(), |s| format!("\nits input was:\n{s}")),
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs `program args…` inside namespace `ns`.
fn run_in(ns: &str, program: &str, args: &[&str], stdin: Option<&str>) -> String {
    let mut all = vec!["netns", "exec", ns, program];
    all.extend_from_slice(args);
    run("ip", &all, stdin)
}

/// Turns IPv6 off in namespace `ns` (before its interfaces exist, so that
/// none gets a link-local address); `-e`: a kernel without IPv6 is fine.
fn ipv4_only(ns: &str) {
    run_in(
        ns,
        "sysctl",
        &[
            "-q",
            "-e",
            "-w",
            "net.ipv6.conf.all.disable_ipv6=1",
            "net.ipv6.conf.default.disable_ipv6=1",
        ],
        None,
    );
}

/// The namespaces made here whose names are `scnet-…`, as `ip netns list`
/// lists them.
fn our_namespaces() -> Vec<String> {
    run("ip", &["netns", "list"], None)
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .filter(|n| n.starts_with(PREFIX))
        .map(str::to_string)
        .collect()
}

/// Deletes the namespaces left by earlier runs that crashed: `scnet-<pid>-…`
/// whose process `pid` is no longer alive. Namespaces of live processes
/// (this one and parallel test runs) are left alone.
pub(crate) fn cleanup_stale() {
    for ns in our_namespaces() {
        let pid: Option<u32> = ns[PREFIX.len()..]
            .split('-')
            .next()
            .and_then(|p| p.parse().ok());
        let Some(pid) = pid else { continue };
        if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
            eprintln!("netns: deleting {ns}, left by process {pid}");
            run("ip", &["netns", "del", &ns], None);
        }
    }
}

/// A radio medium with its hosts: see the module doc. Dropping it deletes
/// every namespace it made.
pub(crate) struct Medium {
    medium: String,
    hosts: Vec<String>,
    /// The third octet of the hosts' addresses.
    subnet: usize,
    /// Whether [`Medium::limit`] has put qdiscs in place.
    limited: AtomicBool,
    /// A process in the medium's namespace, for its `/proc/<pid>/net`.
    holder: Option<Child>,
    /// The pairs (a < b) in the partition's and the cut's lists now.
    parted: Mutex<BTreeSet<(usize, usize)>>,
    cut: Mutex<BTreeSet<(usize, usize)>>,
}

/// Which of the two kinds of pair lists ([`Medium::set_pairs`]).
#[derive(Clone, Copy)]
enum Pairs {
    Partition,
    Cut,
}

impl Pairs {
    fn list(self, port: usize) -> String {
        match self {
            Pairs::Partition => format!("sc_part_v{port}"),
            Pairs::Cut => format!("sc_cut_v{port}"),
        }
    }
}

/// How many addresses an `xt_recent` list holds (the module's default
/// `ip_list_tot`); a fuller list would forget its oldest entry.
const LIST_SIZE: usize = 100;

impl Medium {
    /// A medium with `hosts` hosts (1 to 250), all linked and up.
    pub(crate) fn new(hosts: usize) -> Medium {
        assert!(
            (1..=250).contains(&hosts),
            "Medium::new({hosts}): 1 to 250 hosts"
        );
        let k = NEXT.fetch_add(1, Ordering::Relaxed);
        let prefix = format!("{PREFIX}{}-{k}", std::process::id());
        // Made before any namespace exists, so that a failure half-way
        // through still deletes what was made (Drop skips the missing ones).
        let mut medium = Medium {
            medium: format!("{prefix}-m"),
            hosts: (0..hosts).map(|i| format!("{prefix}-h{i}")).collect(),
            subnet: k % 250,
            limited: AtomicBool::new(false),
            holder: None,
            parted: Mutex::new(BTreeSet::new()),
            cut: Mutex::new(BTreeSet::new()),
        };
        medium.make_medium();
        medium.holder = Some(
            Command::new("ip")
                .args(["netns", "exec", &medium.medium, "sleep", "infinity"])
                .stdin(Stdio::null())
                .spawn()
                .unwrap_or_else(|e| {
                    panic!("`ip netns exec … sleep infinity` could not start: {e}")
                }),
        );
        for i in 0..hosts {
            medium.make_host(i);
        }
        for i in 0..hosts {
            medium.know_neighbours(i);
        }
        medium
    }

    /// Host `i`'s MAC address.
    fn mac(&self, i: usize) -> String {
        format!("02:5c:{:02x}:00:00:{:02x}", self.subnet, i)
    }

    /// A permanent neighbour entry in host `i` for every other host (see
    /// the module doc).
    fn know_neighbours(&self, i: usize) {
        let batch: String = (0..self.hosts.len())
            .filter(|&j| j != i)
            .map(|j| {
                format!(
                    "neigh replace {} lladdr {} dev eth0 nud permanent\n",
                    self.ip(j),
                    self.mac(j)
                )
            })
            .collect();
        run("ip", &["-n", &self.hosts[i], "-batch", "-"], Some(&batch));
    }

    fn make_medium(&self) {
        let m = self.medium.as_str();
        run("ip", &["netns", "add", m], None);
        run("ip", &["-n", m, "link", "set", "lo", "up"], None);
        ipv4_only(m);
        // The bridge-netfilter sysctls exist (in every namespace) once
        // br_netfilter is loaded; loading it is the one global step.
        let sysctl = "/proc/sys/net/bridge/bridge-nf-call-iptables";
        let present = Command::new("ip")
            .args(["netns", "exec", m, "test", "-e", sysctl])
            .status()
            .is_ok_and(|s| s.success());
        if !present {
            run("modprobe", &["br_netfilter"], None);
        }
        run_in(
            m,
            "sysctl",
            &["-q", "-w", "net.bridge.bridge-nf-call-iptables=1"],
            None,
        );
        run(
            "ip",
            &[
                "-n",
                m,
                "link",
                "add",
                "name",
                "br0",
                "type",
                "bridge",
                "mcast_snooping",
                "0",
            ],
            None,
        );
        run("ip", &["-n", m, "link", "set", "br0", "up"], None);
        let mut hooks = format!(
            "*filter\n:{PARTITION} - [0:0]\n:{CUT} - [0:0]\n:{LOSS} - [0:0]\n\
             -A FORWARD -j {PARTITION}\n-A FORWARD -j {CUT}\n-A FORWARD -j {LOSS}\n"
        );
        for port in 0..self.hosts.len() {
            for (chain, kind) in [(PARTITION, Pairs::Partition), (CUT, Pairs::Cut)] {
                hooks.push_str(&format!(
                    "-A {chain} -m physdev --physdev-out v{port} -m recent --name {} --rsource \
                     --rcheck -j DROP\n",
                    kind.list(port)
                ));
            }
        }
        hooks.push_str("COMMIT\n");
        run_in(m, "iptables-restore", &["-w", "--noflush"], Some(&hooks));
    }

    fn make_host(&self, i: usize) {
        let (m, h) = (self.medium.as_str(), self.hosts[i].as_str());
        let port = format!("v{i}");
        let addr = format!("{}/24", self.ip(i));
        run("ip", &["netns", "add", h], None);
        run("ip", &["-n", h, "link", "set", "lo", "up"], None);
        ipv4_only(h);
        run(
            "ip",
            &[
                "-n",
                h,
                "link",
                "add",
                "eth0",
                "address",
                &self.mac(i),
                "type",
                "veth",
                "peer",
                "name",
                &port,
                "netns",
                m,
            ],
            None,
        );
        run(
            "ip",
            &["-n", m, "link", "set", &port, "master", "br0", "up"],
            None,
        );
        run("ip", &["-n", h, "addr", "add", &addr, "dev", "eth0"], None);
        run("ip", &["-n", h, "link", "set", "eth0", "up"], None);
        run(
            "ip",
            &["-n", h, "route", "add", "224.0.0.0/4", "dev", "eth0"],
            None,
        );
    }

    /// The number of hosts.
    pub(crate) fn host_count(&self) -> usize {
        self.hosts.len()
    }

    /// The medium's namespace (the bridge's), for inspection.
    pub(crate) fn medium_ns(&self) -> &str {
        &self.medium
    }

    /// Host `i`'s namespace.
    pub(crate) fn host_ns(&self, i: usize) -> &str {
        &self.hosts[i]
    }

    /// Host `i`'s IPv4 address (without the prefix length).
    pub(crate) fn ip(&self, i: usize) -> String {
        assert!(i < self.hosts.len(), "no host {i}");
        format!("10.77.{}.{}", self.subnet, i + 1)
    }

    /// `program` to be run inside host `i`'s namespace (`ip netns exec`,
    /// which execs it: the child's pid is the program's); the environment
    /// is inherited. The caller adds the arguments and owns the child.
    pub(crate) fn command(&self, i: usize, program: impl AsRef<std::ffi::OsStr>) -> Command {
        let mut c = Command::new("ip");
        c.args(["netns", "exec", self.host_ns(i)]).arg(program);
        c
    }

    /// Replaces the rules of `chain` in the medium's namespace by `rules`
    /// (iptables `-A` arguments after the chain), in one batch.
    fn set_chain(&self, chain: &str, rules: &[String]) {
        let mut input = format!("*filter\n:{chain} - [0:0]\n-F {chain}\n");
        for r in rules {
            input.push_str(&format!("-A {chain} {r}\n"));
        }
        input.push_str("COMMIT\n");
        run_in(
            &self.medium,
            "iptables-restore",
            &["-w", "--noflush"],
            Some(&input),
        );
    }

    /// Hosts in different groups can no longer exchange any packet (both
    /// directions); hosts in no group are not affected. Replaces the
    /// previous partition.
    pub(crate) fn partition(&self, groups: &[Vec<usize>]) {
        let mut pairs = Vec::new();
        for (g, group) in groups.iter().enumerate() {
            for other in &groups[g + 1..] {
                for &a in group {
                    pairs.extend(other.iter().map(|&b| (a, b)));
                }
            }
        }
        self.set_pairs(Pairs::Partition, &pairs);
    }

    /// Removes the partition.
    pub(crate) fn heal(&self) {
        self.set_pairs(Pairs::Partition, &[]);
    }

    /// Drops all packets between each given pair of hosts, replacing the
    /// previous set of cut pairs (`&[]` removes them): a range-limited radio,
    /// updated by the caller as the vessels move. Only what changed is
    /// written, in milliseconds (see the module doc).
    pub(crate) fn cut_pairs(&self, pairs: &[(usize, usize)]) {
        self.set_pairs(Pairs::Cut, pairs);
    }

    /// Makes `pairs` the pairs of kind `kind` that hear nothing of each
    /// other: each host's list holds the addresses it must not receive from.
    fn set_pairs(&self, kind: Pairs, pairs: &[(usize, usize)]) {
        let n = self.hosts.len();
        let wanted: BTreeSet<(usize, usize)> = pairs
            .iter()
            .map(|&(a, b)| {
                assert!(
                    a < n && b < n && a != b,
                    "no pair of distinct hosts ({a}, {b}) among {n}"
                );
                (a.min(b), a.max(b))
            })
            .collect();
        for port in 0..n {
            let held = wanted
                .iter()
                .filter(|(a, b)| *a == port || *b == port)
                .count();
            assert!(
                held <= LIST_SIZE,
                "host {port} cut from {held} hosts: an xt_recent list holds {LIST_SIZE}"
            );
        }
        let mut now = match kind {
            Pairs::Partition => &self.parted,
            Pairs::Cut => &self.cut,
        }
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
        for (sign, changed) in [
            ("+", wanted.difference(&now)),
            ("-", now.difference(&wanted)),
        ] {
            for &(a, b) in changed {
                self.write_list(&kind.list(b), &format!("{sign}{}", self.ip(a)));
                self.write_list(&kind.list(a), &format!("{sign}{}", self.ip(b)));
            }
        }
        *now = wanted;
    }

    /// One command (`+ADDR` or `-ADDR`) to the medium's `xt_recent` list.
    fn write_list(&self, list: &str, command: &str) {
        let pid = self.holder.as_ref().expect("the medium's holder").id();
        let path = format!("/proc/{pid}/net/xt_recent/{list}");
        std::fs::OpenOptions::new()
            .write(true)
            .open(&path)
            .and_then(|mut f| f.write_all(command.as_bytes()))
            .unwrap_or_else(|e| panic!("{path}: writing {command:?}: {e}"));
    }

    /// Every forwarded packet is dropped with probability `p`, independently
    /// (`-m statistic --mode random`); `loss(0.0)` removes the loss.
    pub(crate) fn loss(&self, p: f64) {
        assert!((0.0..=1.0).contains(&p), "loss({p}): a probability");
        let rules = if p > 0.0 {
            vec![format!(
                "-m statistic --mode random --probability {p:.6} -j DROP"
            )]
        } else {
            vec![]
        };
        self.set_chain(LOSS, &rules);
    }

    /// Limits every host's link to `kbit` kbit/s in each direction with a
    /// token bucket (`tc qdisc … tbf`): on the medium's end `v<i>` for the
    /// traffic to host i, on the host's `eth0` for the traffic from it.
    /// Burst: 20 ms at the rate, at least 1600 bytes (a full Ethernet frame
    /// must fit); latency 200 ms (a packet that would queue longer is
    /// dropped). Replaces the previous limit.
    pub(crate) fn limit(&self, kbit: u32) {
        assert!(kbit > 0, "limit(0): use unlimit()");
        let burst = (u64::from(kbit) * 1000 / 8 / 50).max(1600);
        let tbf = |dev: &str| {
            format!(
                "qdisc replace dev {dev} root tbf rate {kbit}kbit burst {burst} latency {TBF_LATENCY}\n"
            )
        };
        let ports: String = (0..self.hosts.len())
            .map(|i| tbf(&format!("v{i}")))
            .collect();
        self.limited.store(true, Ordering::SeqCst);
        run_in(&self.medium, "tc", &["-batch", "-"], Some(&ports));
        for h in &self.hosts {
            run_in(h, "tc", &["-batch", "-"], Some(&tbf("eth0")));
        }
    }

    /// Removes the bandwidth limit (a no-op without one).
    pub(crate) fn unlimit(&self) {
        if !self.limited.swap(false, Ordering::SeqCst) {
            return;
        }
        let ports: String = (0..self.hosts.len())
            .map(|i| format!("qdisc del dev v{i} root\n"))
            .collect();
        run_in(&self.medium, "tc", &["-batch", "-"], Some(&ports));
        for h in &self.hosts {
            run_in(h, "tc", &["qdisc", "del", "dev", "eth0", "root"], None);
        }
    }

    /// Host `i`'s `eth0` byte counters: (received, transmitted).
    pub(crate) fn bytes(&self, i: usize) -> (u64, u64) {
        let dir = "/sys/class/net/eth0/statistics";
        let out = run_in(
            self.host_ns(i),
            "cat",
            &[&format!("{dir}/rx_bytes"), &format!("{dir}/tx_bytes")],
            None,
        );
        let n: Vec<u64> = out
            .split_whitespace()
            .map(|w| w.parse().unwrap_or_else(|e| panic!("{dir}: {w:?}: {e}")))
            .collect();
        assert_eq!(n.len(), 2, "{dir}: {out:?}");
        (n[0], n[1])
    }
}

impl Drop for Medium {
    fn drop(&mut self) {
        if let Some(mut holder) = self.holder.take() {
            let _ = holder.kill();
            let _ = holder.wait();
        }
        // Hosts first (their veth pairs go with them), then the medium.
        for ns in self.hosts.iter().chain([&self.medium]) {
            // Where `ip netns add` mounts them (NETNS_RUN_DIR).
            if !Path::new("/var/run/netns").join(ns).exists() {
                continue;
            }
            match Command::new("ip").args(["netns", "del", ns]).output() {
                Ok(out) if out.status.success() => {}
                Ok(out) => eprintln!(
                    "netns: `ip netns del {ns}` failed ({}): {}",
                    out.status,
                    String::from_utf8_lossy(&out.stderr)
                ),
                Err(e) => eprintln!("netns: `ip netns del {ns}`: {e}"),
            }
        }
    }
}
