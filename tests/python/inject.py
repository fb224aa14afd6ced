#!/usr/bin/env python3
"""Publishes raw payloads into a seacover peer fleet, for the peer tests
(bad input, and stand-in vessels for the harness's own test).

Written against Eclipse Zenoh's Python API and ``cbor2`` (pinned in
scripts/test), independently of seacover's code. Two modes:

- payloads: ``--key-suffix beacon/usv-1`` with ``--hex PAYLOAD`` (raw
  bytes) or ``--cbor-json '{...}'`` (the JSON object encoded as a CBOR map:
  JSON numbers with a fraction or exponent stay floats, integers stay
  integers), put on ``seacover/<fleet>/<suffix>`` ``--count N`` times
  (0: until SIGTERM/SIGINT) at ``--hz F``. With ``--stamp`` (CBOR maps only)
  each message gets ``seq`` = message number mod 65536 and ``t`` = the
  sender's UTC time in seconds, as a live beacon would; ``--jump DX`` then
  adds DX metres to ``x`` of every other message (a position no hull can
  reach between two beacons).
- ``--mission-json FILE``: the file's bytes are put on
  ``seacover/<fleet>/mission`` (``--count`` times, at ``--hz``).

``--alive ID`` also declares the liveliness token ``seacover/<fleet>/alive/ID``
for as long as the process runs. ``--wait-subscriber S`` waits up to S
seconds for a matching subscriber before the first put (a put before any
peer is discovered goes nowhere); with ``--wait-peers N`` also for direct
links to N peers (a matching subscriber is any one of them: the others'
puts would be lost until they are linked too). ``ready`` is printed on stdout (flushed)
once the session is open; the process exits 0 after the last put, or on
SIGTERM/SIGINT, closing the session.
"""

import argparse
import json
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
    p.add_argument("--fleet", required=True)
    p.add_argument("--key-suffix", help="key under seacover/<fleet>/, e.g. beacon/usv-1")
    payload = p.add_mutually_exclusive_group(required=True)
    payload.add_argument("--hex", help="the payload's bytes in hexadecimal")
    payload.add_argument("--cbor-json", help="a JSON object, put as a CBOR map")
    payload.add_argument("--mission-json", metavar="FILE",
                         help="put this file on seacover/<fleet>/mission")
    p.add_argument("--count", type=int, default=1, help="messages to put (0: until signalled)")
    p.add_argument("--hz", type=float, default=10.0, help="messages per second")
    p.add_argument("--stamp", action="store_true",
                   help="set seq and t in each CBOR map as a live beacon would")
    p.add_argument("--jump", type=float, default=0.0, metavar="DX",
                   help="with --stamp, add DX metres to x of every odd-numbered message")
    p.add_argument("--canonical", action="store_true",
                   help="encode CBOR maps canonically (shortest floats, sorted keys)")
    p.add_argument("--alive", metavar="ID", help="declare the token seacover/<fleet>/alive/ID")
    p.add_argument("--wait-subscriber", type=float, default=0.0, metavar="S",
                   help="wait up to S seconds for a matching subscriber before the first put")
    p.add_argument("--wait-peers", type=int, default=0, metavar="N",
                   help="within --wait-subscriber, also wait for direct links to N peers")
    add_session_args(p)
    args = p.parse_args(argv)
    if args.mission_json is None and not args.key_suffix:
        p.error("--key-suffix is required with --hex and --cbor-json")
    if args.stamp and args.cbor_json is None:
        p.error("--stamp needs --cbor-json")
    if args.jump and not args.stamp:
        p.error("--jump needs --stamp")
    if args.hz <= 0:
        p.error("--hz must be positive")
    return args


def payloads(args):
    """The key suffix and a function from message number to payload bytes."""
    if args.mission_json is not None:
        with open(args.mission_json, "rb") as f:
            data = f.read()
        return "mission", lambda _n: data
    if args.hex is not None:
        data = bytes.fromhex(args.hex)
        return args.key_suffix, lambda _n: data
    doc = json.loads(args.cbor_json)
    if not isinstance(doc, dict):
        sys.exit("inject.py: --cbor-json must be a JSON object")
    # canonical=True: each float in the shortest form that holds it
    # exactly (RFC 8949 §4.2), as a compact sender would put it; the map's
    # keys come sorted, which a decoder must accept.
    if not args.stamp:
        data = cbor2.dumps(doc, canonical=args.canonical)
        return args.key_suffix, lambda _n: data

    def stamped(n):
        x = doc.get("x", 0.0) + (args.jump if n % 2 else 0.0)
        return cbor2.dumps({**doc, "x": x, "seq": n % 256, "t": time.time()},
                           canonical=args.canonical)
    return args.key_suffix, stamped


def main(argv):
    args = parse_args(argv)
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())

    suffix, payload = payloads(args)
    session = zenoh.open(make_config(args))
    token = None
    if args.alive:
        token = session.liveliness().declare_token(f"seacover/{args.fleet}/alive/{args.alive}")
    publisher = session.declare_publisher(f"seacover/{args.fleet}/{suffix}")
    print("ready", flush=True)
    try:
        waited = time.monotonic() + args.wait_subscriber
        def linked():
            return (publisher.matching_status
                    and len(session.info.peers_zid()) >= args.wait_peers)
        while not stop.is_set() and not linked() and time.monotonic() < waited:
            stop.wait(0.05)
        period = 1.0 / args.hz
        next_put = time.monotonic()
        n = 0
        while not stop.is_set() and (args.count == 0 or n < args.count):
            publisher.put(payload(n))
            n += 1
            next_put += period
            stop.wait(max(0.0, next_put - time.monotonic()))
    finally:
        publisher.undeclare()
        if token is not None:
            token.undeclare()
        session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
