"""The Zenoh session flags the tests' Python tools share (observer.py,
inject.py): the endpoints, a configuration file and multicast scouting,
and the session configuration they make. Peer mode always, as seacover's
members."""

import json

import zenoh


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
    return config
