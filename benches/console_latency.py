#!/usr/bin/env python3
"""Key to screen in the real console, in tmux: how long after a grip's key the next trial's
screen (with its suggested query) is on the terminal.

For every training grasp of a session, the grip key is sent either at once after the key
that presents the query (nothing learned ahead yet: the worker computes the update and the
next suggestion after the key) or after `--reach` seconds (the participant reaching: the
worker has learned ahead for every grip offered).

The screen is read as tmux writes it, not polled: `tmux pipe-pane` copies every byte the
console writes to the pane into a FIFO, a reader process of its own timestamps each chunk
as it arrives (on the system's monotonic clock, so no lock of this script delays it) and a
terminal emulator (pyte) replays the chunks in order. A grasp's time runs from just
before `tmux send-keys` to the arrival of the chunk after which the screen first shows the
next trial with its query. It therefore includes starting the `tmux send-keys` client
(about 2 ms, see the `send-keys` row) and tmux's own relaying, both of which a person at a
terminal does not wait for.

The logs are written under `--work` (default: a fresh folder in /dev/shm, a tmpfs, where
the event's fsync returns at once, so the time leaves it out; give a folder on disk to
include it).

    python3 -m venv target/bench-venv && target/bench-venv/bin/pip install pyte
    target/bench-venv/bin/python benches/console_latency.py target/release/handover \\
        --particles 20000 --learn both
"""

import argparse
import json
import os
import shutil
import statistics
import struct
import subprocess
import sys
import tempfile
import threading
import time


COLS, ROWS = 100, 40


def tmux(socket, *args):
    return subprocess.run(["tmux", "-L", socket, *args], capture_output=True, text=True).stdout


# The reader of the pane's output, a process of its own so that no lock of this one delays
# its clock: each chunk as it arrives, prefixed by its arrival time (CLOCK_MONOTONIC, the
# clock `time.monotonic` reads here) and length.
READER = r"""
import os, struct, sys, time
fd = os.open(sys.argv[1], os.O_RDONLY)
while True:
    data = os.read(fd, 1 << 16)
    t = time.monotonic_ns()
    if not data:
        break
    os.write(1, struct.pack("<qI", t, len(data)) + data)
"""


class Pane:
    """A console in a tmux session of its own, whose output is read as it arrives."""

    def __init__(self, name, cmd, fifo):
        self.name = name
        os.mkfifo(fifo, 0o600)
        # The shell waits before starting the console so that the pipe is open before its
        # first byte: the emulator must see the whole output to hold the whole screen.
        tmux(name, "new-session", "-d", "-s", name, "-x", str(COLS), "-y", str(ROWS), f"sleep 0.5; {cmd}")
        tmux(name, "pipe-pane", "-O", "-t", name, f"cat >> {fifo}")
        self.process = subprocess.Popen([sys.executable, "-c", READER, fifo], stdout=subprocess.PIPE)
        self.chunks = []  # (arrival time, bytes), appended by the thread that collects them
        self.cond = threading.Condition()
        self.done = 0  # chunks replayed into the emulator
        import pyte  # checked in main()

        self.screen = pyte.Screen(COLS, ROWS)
        self.stream = pyte.ByteStream(self.screen)
        self.collector = threading.Thread(target=self._collect, daemon=True)
        self.collector.start()

    def _collect(self):
        out = self.process.stdout
        while True:
            head = out.read(12)
            if len(head) < 12:
                return
            t, n = struct.unpack("<qI", head)
            data = out.read(n)
            with self.cond:
                self.chunks.append((t / 1e9, data))
                self.cond.notify()

    def text(self):
        return "\n".join(self.screen.display)

    def wait_for(self, *texts, timeout=120.0):
        """The arrival time of the chunk after which the screen first holds every text."""
        deadline = time.monotonic() + timeout
        while True:
            with self.cond:
                while self.done == len(self.chunks):
                    left = deadline - time.monotonic()
                    if left <= 0 or not self.cond.wait(left):
                        sys.exit(f"{texts} never appeared; the screen:\n{self.text()}")
                pending = self.chunks[self.done :]
                self.done = len(self.chunks)
            for t, data in pending:
                self.stream.feed(data)
                screen = self.text()
                if all(s in screen for s in texts):
                    return t

    def send(self, key):
        """Sends a key; returns the time just before the `tmux send-keys` client started and
        the time it took."""
        t0 = time.monotonic()
        tmux(self.name, "send-keys", "-t", self.name, key)
        return t0, time.monotonic() - t0

    def close(self):
        tmux(self.name, "kill-server")
        self.process.kill()
        self.process.wait()


def session(binary, protocol, work, seed, reach):
    """One session's training grasps: [(seconds from key to next screen, seconds send-keys took)]."""
    # No dot in a tmux target (it separates window and pane).
    name = f"handover-latency-{os.getpid()}-{seed}-{int(reach * 1000)}"
    tag = f"{seed}-{int(reach * 1000)}"
    cmd = (
        f"{binary} run --protocol {protocol} --logs {work}/logs-{tag} "
        f"--participants-dir {work}/participants-{tag} --seed {seed}; sleep 5"
    )
    pane = Pane(name, cmd, os.path.join(work, f"screen-{tag}.fifo"))
    out = []
    try:
        pane.wait_for("Press Enter to start the session.")
        pane.send("Enter")
        for k, phase in enumerate(["Training · Program A", "Training · Program B"]):
            if k > 0:
                pane.wait_for("Press Enter once the participant has been told.")
                pane.send("Enter")
            for trial in range(1, 6):
                pane.wait_for(f"{phase} · trial {trial}/5", "(query ")
                pane.send("Enter")
                pane.wait_for("Presented.")
                time.sleep(reach)
                if trial < 5:
                    after = (f"{phase} · trial {trial + 1}/5", "(query ")
                else:
                    after = ("Press Enter once the participant has been told.",)
                t0, sending = pane.send("1")
                out.append((pane.wait_for(*after) - t0, sending))
    finally:
        pane.close()
    return out


def describe(ms):
    ms = sorted(ms)
    p90 = ms[min(len(ms) - 1, int(0.9 * len(ms)))]
    over = sum(1 for t in ms if t > 16.0)
    return (
        f"median {statistics.median(ms):6.1f}   p90 {p90:6.1f}   min {ms[0]:6.1f}   max {ms[-1]:6.1f}"
        f"   over 16 ms {over}/{len(ms)}"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("binary")
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--protocol", default=os.path.join(here, "..", "protocols", "bike-handover.json"))
    ap.add_argument("--particles", type=int, default=20000)
    ap.add_argument("--learn", default="both")
    ap.add_argument("--reach", type=float, default=2.0, help="seconds between presenting and the grip's key")
    ap.add_argument("--sessions", type=int, default=2)
    ap.add_argument("--work", help="where the logs go (default: a fresh folder in /dev/shm)")
    ap.add_argument("--each", action="store_true", help="print every grasp's time")
    a = ap.parse_args()
    try:
        import pyte  # noqa: F401
    except ImportError:
        sys.exit("console_latency.py needs pyte (a terminal emulator): pip install pyte")
    a.binary = os.path.abspath(a.binary)
    base = a.work or ("/dev/shm" if os.path.isdir("/dev/shm") else None)
    work = tempfile.mkdtemp(prefix="handover-latency-", dir=base)
    try:
        with open(a.protocol) as f:
            v = json.load(f)
        v["learning"]["particles"] = a.particles
        v["learning"]["learn"] = a.learn
        protocol = os.path.join(work, "protocol.json")
        with open(protocol, "w") as f:
            json.dump(v, f)
        rows = {}
        sending = []
        for label, reach in [
            ("key at once (nothing learned ahead)", 0.0),
            (f"key after {a.reach:g} s (learned ahead)", a.reach),
        ]:
            times = []
            for seed in range(1, a.sessions + 1):
                grasps = session(a.binary, protocol, work, seed, reach)
                times += [t for t, _ in grasps]
                sending += [s for _, s in grasps]
            rows[label] = times
        print(
            f"key → next trial on screen, {a.particles} particles learning {a.learn}, "
            f"{a.sessions} sessions × 10 training grasps, logs in {base or tempfile.gettempdir()} (ms):"
        )
        for label, times in rows.items():
            print(f"  {label:40s} {describe([t * 1000 for t in times])}")
            if a.each:
                print("    " + " ".join(f"{t * 1000:.1f}" for t in times))
        print(f"  {'of which tmux send-keys':40s} {describe([s * 1000 for s in sending])}")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
