#!/usr/bin/env python3
"""Key to screen in the real console, in tmux: how long after a grip's key the next trial's
screen (with its suggested query) is on the terminal.

For every training grasp of a session, the grip key is sent either at once after the key
that presents the query (nothing learned ahead yet: the worker computes the update and the
next suggestion after the key) or after `--reach` seconds (the participant reaching: the
worker has learned ahead for every grip offered). The time is from `tmux send-keys` to the
first `capture-pane` that shows the next trial, polled as fast as tmux answers (a few ms: the
resolution). It includes the event's fsync.

    benches/console_latency.py target/release/handover --particles 20000 --learn both
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time


def tmux(*args):
    return subprocess.run(["tmux", *args], capture_output=True, text=True).stdout


def wait_for(name, text, timeout=120.0):
    t0 = time.monotonic()
    while True:
        screen = tmux("capture-pane", "-t", name, "-p")
        if text in screen:
            return time.monotonic()
        if time.monotonic() - t0 > timeout:
            sys.exit(f"'{text}' never appeared; the screen:\n{screen}")


def session(binary, protocol, work, seed, reach):
    """One session's training grasps: [(phase, trial, seconds from key to next screen)]."""
    # No dot in a tmux target (it separates window and pane).
    name = f"handover-latency-{os.getpid()}-{seed}-{int(reach * 1000)}"
    logs = os.path.join(work, f"logs-{seed}-{reach}")
    cmd = f"{binary} run --protocol {protocol} --logs {logs} --participants-dir {work}/participants-{seed}-{reach} --seed {seed}; sleep 5"
    tmux("new-session", "-d", "-s", name, "-x", "100", "-y", "40", cmd)
    out = []
    try:
        wait_for(name, "Press Enter to start the session.")
        tmux("send-keys", "-t", name, "Enter")
        for k, phase in enumerate(["Training · Program A", "Training · Program B"]):
            if k > 0:
                wait_for(name, "Press Enter once the participant has been told.")
                tmux("send-keys", "-t", name, "Enter")
            for trial in range(1, 6):
                wait_for(name, f"{phase} · trial {trial}/5")
                tmux("send-keys", "-t", name, "Enter")
                wait_for(name, "Presented.")
                time.sleep(reach)
                after = f"{phase} · trial {trial + 1}/5" if trial < 5 else "Press Enter once the participant has been told."
                t0 = time.monotonic()
                tmux("send-keys", "-t", name, "1")
                t1 = wait_for(name, after)
                out.append((phase, trial, t1 - t0))
    finally:
        tmux("kill-session", "-t", name)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("binary")
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--protocol", default=os.path.join(here, "..", "protocols", "bike-handover.json"))
    ap.add_argument("--particles", type=int, default=20000)
    ap.add_argument("--learn", default="both")
    ap.add_argument("--reach", type=float, default=2.0, help="seconds between presenting and the grip's key")
    ap.add_argument("--sessions", type=int, default=2)
    a = ap.parse_args()
    a.binary = os.path.abspath(a.binary)
    work = tempfile.mkdtemp(prefix="handover-latency-")
    try:
        with open(a.protocol) as f:
            v = json.load(f)
        v["learning"]["particles"] = a.particles
        v["learning"]["learn"] = a.learn
        protocol = os.path.join(work, "protocol.json")
        with open(protocol, "w") as f:
            json.dump(v, f)
        rows = {}
        for label, reach in [("key at once (nothing learned ahead)", 0.0), (f"key after {a.reach} s (learned ahead)", a.reach)]:
            times = []
            for seed in range(1, a.sessions + 1):
                times += [t for _, _, t in session(a.binary, protocol, work, seed, reach)]
            rows[label] = times
        print(f"key → next trial on screen, {a.particles} particles learning {a.learn}, "
              f"{a.sessions} sessions × 10 training grasps (ms):")
        for label, times in rows.items():
            ms = sorted(t * 1000 for t in times)
            print(f"  {label:40s} median {statistics.median(ms):7.1f}   min {ms[0]:7.1f}   max {ms[-1]:7.1f}   n {len(ms)}")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
