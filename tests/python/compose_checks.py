"""The Docker demo's checks (scripts/compose-smoke): HTTP, JSON and timing,
standard library only; docker is run from here.

    python3 tests/python/compose_checks.py COMMAND [ARGS...]

The environment gives the coordinator's URL (SMOKE_BASE_URL), the peer
member's (SMOKE_PEER_URL, for the `peer-` commands), the token
(SEACOVER_TOKEN), the time warp (SEACOVER_TIME_WARP) and a JSON file the
commands keep state in between calls (SMOKE_STATE).
"""
import json, os, subprocess, sys, time, urllib.error, urllib.request

BASE = os.environ["SMOKE_BASE_URL"]
TOKEN = os.environ["SEACOVER_TOKEN"]
WARP = float(os.environ["SEACOVER_TIME_WARP"])
LIVENESS = 3.0   # mission seconds (ServeConfig's default)
TICK = 0.1       # mission seconds (10 Hz)
STATE = os.environ["SMOKE_STATE"]   # a JSON file shared between checks


def fail(msg):
    print(f"compose-smoke: FAILED: {msg}", file=sys.stderr)
    sys.exit(1)


def ok(msg):
    print(f"compose-smoke: ok: {msg}", file=sys.stderr)


def request(method, path, body=None, token=None):
    req = urllib.request.Request(BASE + path, method=method)
    data = None
    if body is not None:
        data = json.dumps(body).encode()
        req.add_header("content-type", "application/json")
    if token:
        req.add_header("authorization", f"Bearer {token}")
    try:
        with urllib.request.urlopen(req, data, timeout=5) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def get(path):
    status, body = request("GET", path)
    if status != 200:
        raise OSError(f"GET {path}: {status}")
    return json.loads(body)


def ring_area(ring):
    return 0.5 * abs(sum(x0 * y1 - x1 * y0
                         for (x0, y0), (x1, y1) in zip(ring, ring[1:] + ring[:1])))


def region_area():
    region = get("/api/v1/mission")["region"]
    return ring_area(region["polygon"]) - sum(ring_area(h) for h in region.get("holes", []))


def fleet():
    """Live and connected vessel ids, and the coverage document."""
    vessels = get("/api/v1/vessels")
    live = {v["id"] for v in vessels if v["live"] and v["connected"]}
    return live, vessels, get("/api/v1/coverage")


def tiled(cov, area):
    """The cells tile the region: their areas add up to its area."""
    return abs(sum(c["area"] for c in cov["cells"]) - area) <= 1e-6 * area


def wait_fleet(ids, timeout, what):
    """Waits until exactly `ids` are connected, live and own the cells, and
    the cells tile the region; returns the seconds waited."""
    start = time.monotonic()
    area = None
    last = "no answer"
    while time.monotonic() - start < timeout:
        try:
            area = area or region_area()
            live, _, cov = fleet()
            cells = {c["id"] for c in cov["cells"]}
            if live == ids and cells == ids and tiled(cov, area):
                return time.monotonic() - start, cov, area
            last = (f"{len(live)} live and connected, {len(cells)} cells, "
                    f"unexpected {sorted(live - ids)}, missing {sorted(ids - live)}")
        except OSError as e:
            last = str(e)
        time.sleep(0.2)
    fail(f"{what}: not {len(ids)} live vessels within {timeout} s ({last})")


def docker(*args):
    return subprocess.run(["docker", *args], check=True, capture_output=True,
                          text=True).stdout.strip()


def load_state():
    with open(STATE) as f:
        return json.load(f)


def save_state(state):
    with open(STATE, "w") as f:
        json.dump(state, f)


def cmd_fleet(what, timeout, ids):
    ids = set(ids.split(","))
    waited, cov, area = wait_fleet(ids, float(timeout), what)
    total = sum(c["area"] for c in cov["cells"])
    ok(f"{what}: {len(ids)} vessels connected and live after {waited:.1f} s, "
       f"one per container; their {len(cov['cells'])} cells cover "
       f"{total:.1f} of {area:.1f} m²")


def cmd_dashboard():
    status, page = request("GET", "/")
    if status != 200 or b"<html" not in page.lower():
        fail(f"GET / answered {status} without a page")
    status, body = request("GET", "/healthz")
    if status != 200 or body.strip() != b"ok":
        fail(f"GET /healthz answered {status} {body[:100]!r}")
    ok(f"dashboard page served at / ({len(page)} bytes); /healthz ok")


def cmd_rising(seconds):
    seconds = float(seconds)
    samples = []
    start = time.monotonic()
    while True:
        cov = get("/api/v1/coverage")
        samples.append((cov["tick"], cov["H"]))
        if time.monotonic() - start >= seconds:
            break
        time.sleep(1.0)
    (t0, h0), (t1, h1) = samples[0], samples[-1]
    rises = sum(b[1] > a[1] for a, b in zip(samples, samples[1:]))
    shown = " ".join(f"{h:.0f}" for _, h in samples)
    if not (t1 > t0 and h1 > 1.05 * h0 and rises >= 0.7 * (len(samples) - 1)):
        fail(f"H(P) not rising over {seconds:.0f} s: {shown}")
    ok(f"H(P) rising: {h0:.0f} -> {h1:.0f} (+{100 * (h1 / h0 - 1):.0f} %) over "
       f"{seconds:.0f} s, {rises} of {len(samples) - 1} steps up: {shown}")


def cmd_risk_object():
    obj = {"x": 40.0, "y": 60.0, "alpha": 7.5, "sigma": 6.0}
    status, _ = request("POST", "/api/v1/risk-objects", obj)
    if status != 401:
        fail(f"a write without the token answered {status}, not 401")
    status, body = request("POST", "/api/v1/risk-objects", obj, token="not-" + TOKEN)
    if status != 401:
        fail(f"a write with a wrong token answered {status}, not 401")
    status, body = request("POST", "/api/v1/risk-objects", obj, token=TOKEN)
    if status != 201:
        fail(f"POST /api/v1/risk-objects answered {status}: {body[:200]!r}")
    created = json.loads(body)
    if not created.get("id") or any(created[k] != v for k, v in obj.items()):
        fail(f"the created object is {created}, sent {obj}")
    if created not in get("/api/v1/risk-objects"):
        fail(f"{created} is not listed")
    state = load_state()
    state["object"] = created
    save_state(state)
    ok(f"writes need the token (401 without it or with a wrong one); "
       f"risk object {created['id']} created (201)")


def check_object(what):
    obj = load_state()["object"]
    objects = get("/api/v1/risk-objects")
    if obj not in objects:
        fail(f"{what}: risk object {obj} is gone; the mission has {objects}")
    return obj["id"]


def cmd_takeover(container, vessel, others):
    others = others.split(",")
    limit = (LIVENESS + TICK) / WARP + 0.5
    area = region_area()
    # From the moment docker kill returns: the vessel is dead by then, and
    # the engine's own latency (0.1-0.2 s here) is not the coordinator's.
    start = time.monotonic()
    docker("kill", container)
    killed = time.monotonic() - start
    start = time.monotonic()
    while True:
        cov = get("/api/v1/coverage")
        elapsed = time.monotonic() - start
        if vessel not in {c["id"] for c in cov["cells"]}:
            break
        if elapsed > limit + 5:
            fail(f"{vessel} still has a cell {elapsed:.1f} s after docker kill")
        time.sleep(0.05)
    live, vessels, cov = fleet()
    gone = next(v for v in vessels if v["id"] == vessel)
    cells = {c["id"] for c in cov["cells"]}
    if elapsed > limit:
        fail(f"{vessel} left the partition {elapsed:.2f} s after docker kill, "
             f"over the limit of {limit:.2f} s")
    if cells != set(others) or live != set(others) or not tiled(cov, area):
        fail(f"after {vessel} left: cells {sorted(cells)}, live {sorted(live)}, "
             f"area {sum(c['area'] for c in cov['cells']):.1f} of {area:.1f}")
    if gone["live"] or gone["connected"] or gone["polygon"] is not None:
        fail(f"{vessel} after the kill: {gone}")
    running = docker("inspect", "-f", "{{.State.Running}}", container)
    if running != "false":
        fail(f"the killed container is running again (restart policy?)")
    ok(f"docker kill {container[:12]} (took {killed:.2f} s): {vessel} left the "
       f"partition {elapsed:.2f} s after it returned (limit: liveness {LIVENESS / WARP:.1f} s + one "
       f"tick + 0.5 s = {limit:.2f} s); the other {len(others)} cells cover "
       f"{sum(c['area'] for c in cov['cells']):.1f} of {area:.1f} m²")


def cmd_restart(what, timeout, ids, *command):
    """Runs `command` (which restarts or replaces the coordinator), then
    waits for `ids` to be back and checks the risk object."""
    ids = set(ids.split(","))
    start = time.monotonic()
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode:
        fail(f"{' '.join(command)}: {done.stderr.strip()}")
    took = time.monotonic() - start
    wait_fleet(ids, float(timeout), f"after the coordinator's {what}")
    object_id = check_object(f"after the coordinator's {what}")
    ok(f"coordinator {what} ({took:.1f} s): {len(ids)} vessels reconnected and "
       f"live {time.monotonic() - start:.1f} s after it began; risk object "
       f"{object_id} still there")


def cmd_rejoin(container, timeout, ids):
    ids = set(ids.split(","))
    start = time.monotonic()
    docker("start", container)
    wait_fleet(ids, float(timeout), "rejoin")
    ok(f"docker start {container[:12]}: {len(ids)} vessels live again "
       f"{time.monotonic() - start:.1f} s later")


# ------------------------------------------------------------ peer profile
# The coordinator as a member (serve --peer), through its own port; every
# peer-* command asks it.

PEER_PORT = 7447   # the Zenoh endpoint every peer vessel listens on


def peer_fleet(ids):
    """The peer vessels shown live and connected, the documents, and what
    is missing: 8 cells tiling the region, each vessel reporting all the
    others as its neighbours."""
    live, vessels, cov = fleet()
    cells = {c["id"] for c in cov["cells"]}
    deaf = {v["id"]: v.get("neighbours") for v in vessels
            if v["id"] in ids and v.get("neighbours") != len(ids) - 1}
    return live, cells, deaf, cov


def wait_peer_fleet(ids, timeout, what, neighbours=True):
    start = time.monotonic()
    area = None
    last = "no answer"
    while time.monotonic() - start < timeout:
        try:
            area = area or region_area()
            live, cells, deaf, cov = peer_fleet(ids)
            if live == ids and cells == ids and tiled(cov, area) and not (neighbours and deaf):
                return time.monotonic() - start, cov, area
            last = (f"{len(live)} live and connected, {len(cells)} cells, "
                    f"unexpected {sorted(live - ids)}, missing {sorted(ids - live)}, "
                    f"neighbour counts not {len(ids) - 1}: {deaf}")
        except OSError as e:
            last = str(e)
        time.sleep(0.2)
    fail(f"{what}: not {len(ids)} live peer vessels within {timeout} s ({last})")


def cmd_peer_fleet(timeout, ids):
    ids = set(ids.split(","))
    waited, cov, area = wait_peer_fleet(ids, float(timeout), "peer fleet")
    ok(f"peer fleet: {len(ids)} vessels live on the coordinator (serve --peer) "
       f"{waited:.1f} s after up, one per container, each hearing the "
       f"{len(ids) - 1} others; their {len(cov['cells'])} cells cover "
       f"{sum(c['area'] for c in cov['cells']):.1f} of {area:.1f} m²")


def cmd_peer_rising(seconds):
    seconds = float(seconds)
    samples = []
    start = time.monotonic()
    while True:
        samples.append(get("/api/v1/coverage")["H"])
        if time.monotonic() - start >= seconds:
            break
        time.sleep(1.0)
    rises = sum(b > a for a, b in zip(samples, samples[1:]))
    shown = " ".join(f"{h:.0f}" for h in samples)
    if not (samples[-1] > samples[0] and rises >= 0.7 * (len(samples) - 1)):
        fail(f"peer fleet: H(P) not rising over {seconds:.0f} s: {shown}")
    ok(f"peer fleet: H(P) rising: {shown}")


def tcp_peers(container, port):
    """The addresses a container has established TCP connections with, to
    or from `port` (from /proc/net/tcp and tcp6: the image has no ss)."""
    import ipaddress

    def addr(hexa):
        raw = bytes.fromhex(hexa)
        # Little-endian 32-bit words.
        raw = b"".join(raw[i:i + 4][::-1] for i in range(0, len(raw), 4))
        ip = ipaddress.ip_address(raw)
        return str(ip.ipv4_mapped or ip) if ip.version == 6 else str(ip)

    peers = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        out = subprocess.run(["docker", "exec", container, "cat", table],
                             capture_output=True, text=True).stdout
        for line in out.splitlines()[1:]:
            f = line.split()
            if len(f) < 4 or f[3] != "01":   # ESTABLISHED
                continue
            (local, lport), (remote, rport) = f[1].split(":"), f[2].split(":")
            if port in (int(lport, 16), int(rport, 16)):
                peers.add(addr(remote))
    return peers


def cmd_peer_outage(coordinator, outage, limit, ids, *containers):
    """Kills the coordinator, checks that the vessels stay linked to each
    other without it, starts it again and compares H(P)."""
    ids, outage, limit = set(ids.split(",")), float(outage), float(limit)
    ips = {c: docker("inspect", "-f",
                     "{{range .NetworkSettings.Networks}}{{.IPAddress}}{{end}}", c)
           for c in containers}
    before = get("/api/v1/coverage")["H"]
    docker("kill", coordinator)
    killed = time.monotonic()
    try:
        get("/api/v1/coverage")
        fail("the coordinator's API still answers after docker kill")
    except OSError:
        pass
    if docker("inspect", "-f", "{{.State.Running}}", coordinator) != "false":
        fail("the killed coordinator is running again (restart policy?)")
    # Late in the outage, when the coordinator's own links are long gone:
    # each vessel still has a link of its own with each of the others.
    time.sleep(max(0.0, outage - 5))
    unlinked = {}
    for c, ip in ips.items():
        missing = set(ips.values()) - {ip} - tcp_peers(c, PEER_PORT)
        if missing:
            unlinked[c[:12]] = sorted(missing)
    if unlinked:
        fail(f"{time.monotonic() - killed:.0f} s after the coordinator's kill, vessels "
             f"without a Zenoh link to others: {unlinked}")
    linked = time.monotonic() - killed
    time.sleep(max(0.0, outage - (time.monotonic() - killed)))
    docker("start", coordinator)
    away = time.monotonic() - killed
    start = time.monotonic()
    waited, cov, area = wait_peer_fleet(ids, limit, "after the coordinator's restart",
                                        neighbours=False)
    after = cov["H"]
    if after <= before:
        fail(f"H(P) {after:.1f} after the coordinator's restart, not above the "
             f"{before:.1f} just before its kill: the fleet stopped covering")
    wait_peer_fleet(ids, 5, "after the coordinator's restart, neighbour counts")
    ok(f"docker kill of the coordinator: {linked:.0f} s later each of the {len(ips)} "
       f"vessels still had a direct Zenoh link with each of the others")
    ok(f"docker start of it {away:.1f} s after the kill: {len(ids)} live vessels "
       f"shown again {waited:.1f} s later (limit {limit:.0f} s); H(P) {before:.0f} "
       f"before the kill -> {after:.0f} after (+{100 * (after / before - 1):.1f} %): "
       f"the fleet kept covering")


cmd, *args = sys.argv[1:]
if cmd.startswith("peer-"):
    BASE = os.environ["SMOKE_PEER_URL"]
globals()["cmd_" + cmd.replace("-", "_")](*args)
