"""What a receiver on the fleet's radio reads: every frame crossing the
interfaces of a network namespace (the medium's, run inside it: each frame
between two hosts is seen entering and leaving the bridge) for some seconds,
captured with a raw packet socket (no libpcap), and how often each given
string appears in the frames' bytes, in the clear.

Prints "ready" once the socket is open, then captures until its standard
input closes (or --seconds pass), then prints one JSON line: {"frames",
"bytes", "found": {needle: frames}}."""

import argparse
import json
import socket
import sys
import threading
import time

ETH_P_ALL = 0x0003


def main():
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--iface", help="one interface only (all unless given)")
    p.add_argument("--seconds", type=float, default=600.0, help="at most")
    p.add_argument("--needle", action="append", default=[],
                   help="a string to look for in the frames (repeatable)")
    args = p.parse_args()
    s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
    if args.iface:
        s.bind((args.iface, 0))
    s.settimeout(0.2)
    needles = {n: n.encode() for n in args.needle}
    found = {n: 0 for n in needles}
    frames = size = 0
    done = threading.Event()

    def until_eof():
        sys.stdin.read()
        done.set()

    threading.Thread(target=until_eof, daemon=True).start()
    print("ready", flush=True)
    end = time.monotonic() + args.seconds
    while time.monotonic() < end and not done.is_set():
        try:
            frame = s.recv(65536)
        except socket.timeout:
            continue
        frames += 1
        size += len(frame)
        for n, b in needles.items():
            if b in frame:
                found[n] += 1
    print(json.dumps({"frames": frames, "bytes": size, "found": found}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
