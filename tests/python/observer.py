#!/usr/bin/env python3
"""An independent observer of a seacover peer fleet, for the peer tests.

Written against Eclipse Zenoh's Python API (``eclipse-zenoh``, pinned in
scripts/test to the version of the Rust crate) and ``cbor2``, not against
seacover's code: it joins the fleet as a Zenoh peer and writes what it hears,
one JSON object per line, flushed per line, to ``--out FILE``:

- ``seacover/<fleet>/beacon/*`` (a CBOR map, RFC 8949):
  ``{"kind": "beacon", "key", "recv", "size", "beacon": {decoded map}}``, or
  ``{"kind": "undecodable", "key", "size", "recv", "error", "hex"}`` when the payload
  is not CBOR or not a map. Byte strings in the map are written as hex text,
  non-finite floats as the strings "NaN", "inf", "-inf", other keys than
  text as their ``str``.
- ``seacover/<fleet>/sample/*`` (a CBOR array of maps): ``{"kind": "samples", "key",
  "recv", "size", "samples": [decoded maps]}``, or ``undecodable`` as a beacon.
- ``seacover/<fleet>/alive/*`` (liveliness, with history):
  ``{"kind": "alive" | "gone", "key", "recv"}``.
- ``seacover/<fleet>/mission`` (a JSON document with an integer "revision"):
  ``{"kind": "mission", "revision", "safety", "by", "recv", "size"}`` (``by``: who
  made the revision, ``null`` when it does not say; ``safety``:
  the document's ``safety`` object, null without one; ``revision`` is null,
  with an ``error``, when the document is not such JSON); with
  ``--query-mission-every S``, a ``get`` on that key every S seconds writes
  ``{"kind": "mission_reply", "revision", "safety", "by", "from": <reply key>, "replier":
  <Zenoh id of the answering session>, "recv", "size"}`` per reply (every
  queryable is asked, replies are not consolidated) (``{"kind": "mission_reply_error", "error", "recv"}``
  for an error reply).
- with ``--query-status-every S``, a ``get`` on ``seacover/<fleet>/status/*``
  every S seconds (every queryable asked, replies not consolidated, timeout
  ``min(S, 2)`` s) writes ``{"kind": "status", "from": <reply key>, "sent":
  <UTC of the query>, "recv", "size", "status": {the JSON document}}`` per
  reply, or ``{"kind": "status_error", "from", "sent", "recv", "error"}`` for
  a reply that is an error or not a JSON object. With ``--status-belief`` the
  query asks for each vessel's learned belief too (``status/*?belief``).
- with ``--peers-every S``, every S seconds ``{"kind": "peers", "zids":
  [<Zenoh ids of the sessions this one is linked to directly>], "recv"}``:
  a peer heard only through another (Zenoh's failover brokering) is not
  among them.

Each kind of periodic query runs in a thread of its own: one waiting out its
timeout (a peer that went silent) never delays the other.

``recv`` is the observer's UTC clock in seconds. ``ready`` is printed on
stdout (flushed) once the session is open and every subscriber declared.
The observer runs for ``--duration S`` seconds, or until SIGTERM or SIGINT;
either way it closes the file cleanly, then the session (waiting at most
``CLOSE_WAIT`` for it), and exits 0.
"""

import argparse
import json
import math
import os
import signal
import sys
import threading
import time

# First: it sets Zenoh's runtime up before zenoh is imported.
from peer_session import add_session_args, make_config  # noqa: I001

import cbor2
import zenoh


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--fleet", required=True, help="fleet name (key prefix seacover/<fleet>)")
    p.add_argument("--out", required=True, help="JSON-lines file to write")
    add_session_args(p)
    p.add_argument("--duration", type=float, help="exit after this many seconds")
    p.add_argument("--query-mission-every", type=float, metavar="S",
                   help="query seacover/<fleet>/mission every S seconds")
    p.add_argument("--query-status-every", type=float, metavar="S",
                   help="query seacover/<fleet>/status/* every S seconds")
    p.add_argument("--status-belief", action="store_true",
                   help="ask the status queries for each vessel's belief")
    p.add_argument("--peers-every", type=float, metavar="S",
                   help="record the directly linked peers every S seconds")
    return p.parse_args(argv)


def jsonable(value):
    """`value` (decoded CBOR) as something json.dumps writes as strict JSON."""
    if isinstance(value, float):
        if math.isnan(value):
            return "NaN"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return value
    if isinstance(value, (bytes, bytearray)):
        return bytes(value).hex()
    if isinstance(value, dict):
        return {k if isinstance(k, str) else str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, cbor2.CBORTag):
        return {"tag": value.tag, "value": jsonable(value.value)}
    if value is None or isinstance(value, (bool, int, str)):
        return value
    return str(value)


class Out:
    """The output file: one JSON object per line, flushed per line, written
    from Zenoh's callback threads and the main thread alike."""

    def __init__(self, path):
        self.file = open(path, "a", encoding="utf-8")
        self.lock = threading.Lock()

    def write(self, obj):
        line = json.dumps(obj, allow_nan=False, separators=(",", ":"))
        with self.lock:
            if self.file is not None:
                self.file.write(line + "\n")
                self.file.flush()

    def close(self):
        with self.lock:
            if self.file is not None:
                self.file.close()
                self.file = None


def on_cbor(out, kind, shape):
    """Writes each CBOR item of `shape` (dict or list) received as a record of `kind`."""
    def callback(sample):
        recv = time.time()
        data = sample.payload.to_bytes()
        key = str(sample.key_expr)
        try:
            value = cbor2.loads(data)
            if not isinstance(value, shape):
                raise ValueError(f"not a CBOR {shape.__name__} but {type(value).__name__}")
        except Exception as e:  # noqa: BLE001 (any decoding failure is the finding)
            out.write({"kind": "undecodable", "key": key, "size": len(data),
                       "recv": recv, "error": str(e), "hex": data.hex()})
            return
        out.write({"kind": kind, "key": key, "recv": recv, "size": len(data),
                   kind: jsonable(value)})
    return callback


def on_alive(out):
    def callback(sample):
        kind = "alive" if sample.kind == zenoh.SampleKind.PUT else "gone"
        out.write({"kind": kind, "key": str(sample.key_expr), "recv": time.time()})
    return callback


def mission_revision(data):
    """The document's integer "revision", or (None, error)."""
    try:
        doc = json.loads(data)
    except Exception as e:  # noqa: BLE001
        return None, f"not JSON: {e}"
    revision = doc.get("revision") if isinstance(doc, dict) else None
    if isinstance(revision, bool) or not isinstance(revision, int):
        return None, "no integer \"revision\" field"
    return revision, None


def mission_safety(data):
    """The document's "safety" object (None without one)."""
    try:
        doc = json.loads(data)
    except Exception:  # noqa: BLE001 (mission_revision reports it)
        return None
    safety = doc.get("safety") if isinstance(doc, dict) else None
    return jsonable(safety) if isinstance(safety, dict) else None


def mission_field(data, name):
    """The document's string field `name` (who made a revision, when; None without)."""
    try:
        doc = json.loads(data)
    except Exception:  # noqa: BLE001 (mission_revision reports it)
        return None
    value = doc.get(name) if isinstance(doc, dict) else None
    return value if isinstance(value, str) else None


def on_mission(out):
    def callback(sample):
        data = sample.payload.to_bytes()
        revision, error = mission_revision(data)
        obj = {"kind": "mission", "revision": revision, "safety": mission_safety(data),
               "by": mission_field(data, "by"), "recv": time.time(), "size": len(data)}
        if error:
            obj["error"] = error
        out.write(obj)
    return callback


def replier_zid(reply):
    """The answering session's Zenoh id (an unstable API: None without it)."""
    try:
        return str(reply.replier_id.zid)
    except Exception:  # noqa: BLE001
        return None


def query_mission(session, key, out, timeout):
    """One `get` on the mission key; a line per reply."""
    replies = session.get(key, target=zenoh.QueryTarget.ALL,
                          consolidation=zenoh.ConsolidationMode.NONE, timeout=timeout)
    for reply in replies:
        recv = time.time()
        if reply.ok is not None:
            sample = reply.ok
            data = sample.payload.to_bytes()
            revision, error = mission_revision(data)
            obj = {"kind": "mission_reply", "revision": revision,
                   "safety": mission_safety(data), "by": mission_field(data, "by"),
                   "from": str(sample.key_expr), "recv": recv, "size": len(data)}
            if error:
                obj["error"] = error
        else:
            obj = {"kind": "mission_reply_error", "recv": recv,
                   "error": reply.err.payload.to_bytes().decode("utf-8", "replace")}
        replier = replier_zid(reply)
        if replier is not None:
            obj["replier"] = replier
        out.write(obj)


def query_status(session, selector, out, timeout):
    """One `get` on every vessel's status key; a line per reply."""
    sent = time.time()
    replies = session.get(selector, target=zenoh.QueryTarget.ALL,
                          consolidation=zenoh.ConsolidationMode.NONE, timeout=timeout)
    for reply in replies:
        recv = time.time()
        if reply.ok is not None:
            sample = reply.ok
            data = sample.payload.to_bytes()
            key = str(sample.key_expr)
            try:
                doc = json.loads(data)
                if not isinstance(doc, dict):
                    raise ValueError(f"not a JSON object but {type(doc).__name__}")
            except Exception as e:  # noqa: BLE001 (any decoding failure is the finding)
                out.write({"kind": "status_error", "from": key, "sent": sent, "recv": recv,
                           "error": str(e)})
                continue
            out.write({"kind": "status", "from": key, "sent": sent, "recv": recv,
                       "size": len(data), "status": jsonable(doc)})
        else:
            out.write({"kind": "status_error", "from": None, "sent": sent, "recv": recv,
                       "error": reply.err.payload.to_bytes().decode("utf-8", "replace")})


def main(argv):
    args = parse_args(argv)
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())

    out = Out(args.out)
    prefix = f"seacover/{args.fleet}"
    session = zenoh.open(make_config(args))
    subscribers = [
        session.declare_subscriber(f"{prefix}/beacon/*", on_cbor(out, "beacon", dict)),
        session.declare_subscriber(f"{prefix}/sample/*", on_cbor(out, "samples", list)),
        session.liveliness().declare_subscriber(f"{prefix}/alive/*", on_alive(out), history=True),
        session.declare_subscriber(f"{prefix}/mission", on_mission(out)),
    ]
    print("ready", flush=True)

    # Each kind of periodic query in a thread of its own, so that a query
    # waiting out its timeout (a partitioned peer) never delays the other.
    def periodic(period, timeout, query):
        def loop():
            due = time.monotonic()
            while not stop.is_set():
                query(timeout)
                # A period after the previous one was due (never a backlog).
                due = max(due + period, time.monotonic())
                stop.wait(max(0.0, due - time.monotonic()))
        thread = threading.Thread(target=loop, daemon=True)
        thread.start()
        return thread

    threads = []
    if args.query_mission_every:
        timeout = max(0.1, min(args.query_mission_every, 5.0))
        threads.append(periodic(args.query_mission_every, timeout,
                                lambda t: query_mission(session, f"{prefix}/mission", out, t)))
    status = f"{prefix}/status/*" + ("?belief" if args.status_belief else "")
    if args.query_status_every:
        timeout = max(0.1, min(args.query_status_every, 2.0))
        threads.append(periodic(args.query_status_every, timeout,
                                lambda t: query_status(session, status, out, t)))
    if args.peers_every:
        def peers(_timeout):
            zids = sorted(str(z) for z in session.info.peers_zid())
            out.write({"kind": "peers", "zids": zids, "recv": time.time()})
        threads.append(periodic(args.peers_every, 0.0, peers))
    deadline = None if args.duration is None else time.monotonic() + args.duration
    try:
        while not stop.is_set():
            now = time.monotonic()
            if deadline is not None and now >= deadline:
                break
            # Bounded, so that a signal is noticed promptly in any case.
            stop.wait(max(0.0, min(1.0, (deadline or now + 1.0) - now)))
        stop.set()
        for thread in threads:
            thread.join(timeout=10.0)
    finally:
        for s in subscribers:
            s.undeclare()
        out.close()
        # Closing waits on every link: under the load of a hundred vessel
        # processes on two cores it timed out (Zenoh's 10 s), and the
        # observer, the test's tool, then took over the 15 s the tests give
        # it to exit. What was heard is written by now; the fleet is what
        # the tests judge. So the close gets CLOSE_WAIT, then the process
        # exits without it (its links end with it).
        closer = threading.Thread(target=close_session, args=(session,), daemon=True)
        closer.start()
        closer.join(timeout=CLOSE_WAIT)
        if closer.is_alive():
            print(f"observer: the Zenoh session did not close within {CLOSE_WAIT} s; "
                  "exiting without it", file=sys.stderr, flush=True)
            os._exit(0)
    return 0


# Seconds the observer waits for its Zenoh session to close on exit.
CLOSE_WAIT = 5.0


def close_session(session):
    try:
        session.close()
    except zenoh.ZError as e:
        print(f"observer: closing the Zenoh session: {e}", file=sys.stderr, flush=True)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
