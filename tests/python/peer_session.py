"""The Zenoh session flags the tests' Python tools share (observer.py,
inject.py): the endpoints, a configuration file and multicast scouting,
and the session configuration they make. Peer mode always, as seacover's
members."""

import json
import os

# Every tool here must keep hearing the peers it can reach when others vanish
# (the observer is the tests' instrument; a stand-in vessel's silence fails a
# test as surely). Zenoh (1.10.2) sets SO_LINGER 10 s on its TCP
# links and closes a link whose lease expired on one of its runtimes' few
# workers (RX: 2, TX and Net: 1 by default): with unsent data queued for a
# peer behind a partition, close(2) blocks that worker for up to 10 s, and
# two such links (any partition) block every RX worker, so the whole session
# stops receiving for 10 s (measured: strace shows two threads in close() for
# > 8 s, and no sample delivered meanwhile; with more RX workers only, TX
# and Net still stall some links for seconds). More workers than links that
# can close at once avoid that; ZENOH_RUNTIME, if set, wins.
os.environ.setdefault(
    "ZENOH_RUNTIME",
    "(rx: (worker_threads: 16), tx: (worker_threads: 16), net: (worker_threads: 16))",
)

import zenoh  # noqa: E402 (after the runtime's environment)


def add_session_args(p):
    """Adds --connect, --listen, --config and --no-multicast to parser `p`."""
    p.add_argument("--connect", action="append", default=[], metavar="EP",
                   help="Zenoh endpoint to connect to, e.g. tcp/10.0.0.1:7447 (repeatable)")
    p.add_argument("--listen", action="append", default=[], metavar="EP",
                   help="Zenoh endpoint to listen on (repeatable)")
    p.add_argument("--config", help="a Zenoh JSON5 configuration file (e.g. credentials)")
    p.add_argument("--no-multicast", action="store_true",
                   help="turn multicast scouting off (it is on by default)")


def make_config(args):
    """The session's configuration: the file if given, then peer mode,
    the endpoints and the multicast scouting switch on top of it."""
    config = zenoh.Config.from_file(args.config) if args.config else zenoh.Config()
    config.insert_json5("mode", json.dumps("peer"))
    if args.connect:
        config.insert_json5("connect/endpoints", json.dumps(args.connect))
    if args.listen:
        config.insert_json5("listen/endpoints", json.dumps(args.listen))
    config.insert_json5("scouting/multicast/enabled", json.dumps(not args.no_multicast))
    # As seacover's members (src/agent/peer/session.rs, GOSSIP): found by
    # multicast scouting alone, no gossip, which would have the tool try to
    # link with every member it hears of, out of radio range too.
    if json.loads(config.get_json("connect/endpoints")) in ([], None):
        config.insert_json5("scouting/gossip/enabled", "false")
    return config
