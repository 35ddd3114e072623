#!/usr/bin/env python3
"""Recompute analyze's per-session tables from the session logs alone, and compare.

  python3 tables_from_log.py LOGS OUT [--withdrawn ID ...]

An independent reader: it shares no code with handover. It reads every log under LOGS with
the `mcap` package (a finished file through its summary, a cut one record by record, as
check_mcap.py does), takes each session's most complete log, and rebuilds from the logged
events and the embedded protocol alone (docs/log-format.md, docs/outputs.md):

  sessions.csv, trials.csv, notes.csv, robot.csv, questionnaire.csv, beliefs.csv,
  belief_summary.csv, and test_log_likelihood.csv's `log_likelihood_mean`

for the real sessions (OUT/) and the pilots (OUT/pilot/). It then reads the tables analyze
wrote in OUT with the `csv` module and compares every cell: texts exactly, numbers to 1e-12
relative, booleans and missing values by their spelling. The other tables (fig10_tests,
objects_by_body, alpha, the posterior-predictive column) are statistics over sessions, not
recomputed here. The closing line counts sessions, events, rows and cells compared:

  reader: S sessions (L logs, E events): R rows, C cells compared, 0 differ
  N passed, N failed

Exit status 1 on any difference (each is printed), 2 on bad input.

Needs: pip install mcap
"""
import argparse
import csv
import datetime
import json
import math
import os
import sys
from pathlib import Path

try:
    from mcap.reader import make_reader
    from mcap.stream_reader import StreamReader
    from mcap.records import Attachment, Channel, Message, Schema
except ImportError as e:  # pragma: no cover
    print(f"tables_from_log: missing Python package ({e}); run: pip install mcap", file=sys.stderr)
    sys.exit(2)

JOINTS = [
    "shoulder_flexion",
    "shoulder_abduction",
    "shoulder_internal_rotation",
    "elbow_flexion",
    "forearm_pronation",
    "wrist_flexion",
    "wrist_radial_deviation",
]
EVENT_TOPICS = {
    "/trial/query", "/trial/response", "/trial/void", "/trial/undo", "/notes", "/session/pause",
    "/session/resume", "/session/transition", "/questionnaire/likert", "/questionnaire/choice",
    "/session/end", "/robot/command", "/robot/status",
}


class Log:
    """One log file: its messages by event, its protocol, whether it is finished."""

    def __init__(self, path):
        self.path = path
        self.finished = True
        try:
            self.messages, self.protocol = self._read_finished()
        except Exception:
            self.finished = False
            self.messages, self.protocol = self._read_stream()
        starts = [d for t, _, _, d in self.messages if t == "/session/start"]
        if not starts:
            raise ValueError(f"{path}: no /session/start")
        self.start = starts[0]
        if self.protocol is None:
            raise ValueError(f"{path}: no protocol.json attachment")
        # A cut log ends at its last whole event: an event's messages are written together,
        # so the last event of a stream read may have lost derived messages, never its own.
        self.events = sorted({seq for t, seq, _, _ in self.messages if t in EVENT_TOPICS})

    def _read_finished(self):
        with open(self.path, "rb") as f:
            reader = make_reader(f, validate_crcs=True)
            if reader.get_summary() is None:
                raise ValueError("not finished")
            out = [
                (c.topic, m.sequence, m.log_time, json.loads(m.data))
                for _, c, m in reader.iter_messages(log_time_order=False)
            ]
            protocol = None
            for a in reader.iter_attachments():
                if a.name == "protocol.json":
                    protocol = json.loads(a.data)
        return out, protocol

    def _read_stream(self):
        channels, out, protocol = {}, [], None
        with open(self.path, "rb") as f:
            try:
                for rec in StreamReader(f, skip_magic=False).records:
                    if isinstance(rec, Channel):
                        channels[rec.id] = rec
                    elif isinstance(rec, Message):
                        out.append((channels[rec.channel_id].topic, rec.sequence, rec.log_time, json.loads(rec.data)))
                    elif isinstance(rec, Attachment) and rec.name == "protocol.json":
                        protocol = json.loads(rec.data)
            except Exception:
                pass  # a cut tail: what came before it stands
        return out, protocol


def ms(ns):
    """RFC 3339 UTC with milliseconds (truncated), as docs/outputs.md's `time`."""
    t = datetime.datetime.fromtimestamp(ns // 1_000_000_000, tz=datetime.timezone.utc)
    return t.strftime("%Y-%m-%dT%H:%M:%S") + f".{(ns % 1_000_000_000) // 1_000_000:03d}Z"


def rows_of(log):
    """Every table's rows of one session, from its events."""
    s, p = log.start, log.protocol
    objects = {o["id"]: o for o in p["objects"]}
    # A query's pose name (a void before presenting logs none of its own).
    labels = {q["id"]: q["label"] for q in p["training_menu"] + p["test_set"]}
    order = s["condition_order"]
    session_id, participant = s["session_id"], s["participant"]
    by_event = {}
    for topic, seq, t, data in log.messages:
        by_event.setdefault(seq, []).append((topic, t, data))
    events = log.events
    trials, notes, robot, likert, choice, ended = [], [], [], {}, None, None
    beliefs = {c: [] for c in order}
    test_ll = {}
    open_trial, open_robot = None, None
    # The start's beliefs (iteration 0).
    for topic, t, data in by_event.get(0, []):
        if topic.startswith("/belief/"):
            beliefs[data["condition"]] = [data]
    for seq in events:
        for topic, t, d in by_event[seq]:
            if topic == "/trial/query":
                trials.append(trial_row(d, objects, labels, seq, t))
                open_trial = len(trials) - 1
            elif topic == "/trial/response":
                row = trials[open_trial]
                row.update(
                    status="taken", region=d["region"], region_label=d["region_label"],
                    config_index=d["config_index"], responded_at=ms(t),
                    learned_from=d.get("learned_from"),
                )
                for j, q in zip(JOINTS, d["configuration"]):
                    row[f"q_{j}_rad"] = q
                m = d.get("measured")
                if m is not None:
                    for j, q in zip(JOINTS, m["q_rad"]):
                        row[f"measured_{j}_rad"] = q
                    row.update(
                        measurement_offset_s=m["offset_s"], measurement_implied_region=m["implied_region"],
                        measurement_agrees=m["agrees"],
                    )
            elif topic == "/trial/undo":
                trials[open_trial]["status"] = "undone"
                again = dict(trials[open_trial])
                again.update(
                    status="unanswered", region=None, region_label=None, config_index=None, responded_at=None,
                    learned_from=None, measurement_offset_s=None, measurement_implied_region=None,
                    measurement_agrees=None,
                )
                for j in JOINTS:
                    again[f"q_{j}_rad"] = None
                    again[f"measured_{j}_rad"] = None
                trials.append(again)
                open_trial = len(trials) - 1
            elif topic == "/trial/void":
                if open_trial is None:
                    # Voided before its query was presented: a row of its own.
                    trials.append(trial_row(d, objects, labels, seq, None))
                    open_trial = len(trials) - 1
                trials[open_trial].update(status="voided", void_reason=d["reason"], void_detail=d["detail"])
                open_trial = None
            elif topic == "/robot/command":
                open_trial = None  # the robot moved on: the last presentation is closed
                robot.append({
                    "event_index": seq, "phase": d["phase"], "condition": d.get("condition"),
                    "program": d.get("program"), "trial": d["trial"], "query": d["query"],
                    "attempt": d["attempt"], "command": d.get("command"), "link": d["link"],
                    "frame": d["pose"]["frame"], "commanded_at": ms(t), "moving_at": None, "outcome": None,
                    "outcome_at": None, "seconds_to_outcome": None, "detail": "", "reports": 0,
                    "stale_reports": 0, "_t": t,
                })
                open_robot = len(robot) - 1
            elif topic == "/robot/status":
                r = robot[open_robot] if open_robot is not None else None
                if r is not None and d.get("stale", False):
                    r["stale_reports"] += 1  # an answer to another command, or to none that can be told
                    continue
                if r is None or "attempt" not in d or r["query"] != d["query"] or r["attempt"] != d["attempt"]:
                    continue
                if r["outcome"] is not None:
                    continue
                r["reports"] += 1
                if d["state"] == "moving" and r["moving_at"] is None:
                    r["moving_at"] = ms(t)
                if d["state"] in ("at_pose", "failed", "timeout"):
                    r.update(outcome=d["state"], outcome_at=ms(t), seconds_to_outcome=(t - r["_t"]) / 1e9,
                             detail=d["detail"])
            elif topic == "/notes":
                notes.append({"event_index": seq, "time": ms(t), "text": d["message"]})
            elif topic == "/questionnaire/likert":
                likert[(ord(d["program"]) - ord("A"), d["item"])] = d["value"]
            elif topic == "/questionnaire/choice":
                choice = ord(d["program"]) - ord("A")
            elif topic == "/session/end":
                ended = d["status"]
            elif topic.startswith("/belief/"):
                stack = beliefs[d["condition"]]
                # After a response the next iteration; after an undo or a retraction the
                # standing one again.
                del stack[d["iteration"]:]
                stack.append(d)
            elif topic.startswith("/test/log_likelihood"):
                test_ll[d["condition"]] = d["log_likelihood"]
    items = [i["id"] for i in p["questionnaire"]["items"]]
    arm = p.get("arm", {})
    cond = lambda k: order[k] if k is not None and k < len(order) else None
    seed = s.get("seed_decimal", s["seed"])
    sessions = [{
        "pilot": s["pilot"], "slot": s["slot"], "condition_order": "-".join(order),
        "program_a": cond(0), "program_b": cond(1), "completed": ended == "completed",
        "truncated": not log.finished, "events": len(events),
        "forced_choice_program": None if choice is None else chr(ord("A") + choice),
        "forced_choice_condition": cond(choice), "started_at": s["started_at"], "seed": str(seed),
        "body_height_m": arm.get("body_height_m"), "hand": arm.get("side", "right"), "log": log.path,
    }]
    questionnaire = [
        {"condition_order": "-".join(order), "condition": cond(k) or "", "program": chr(ord("A") + k),
         "item": item, "value": likert[(k, item)]}
        for k in range(len(order)) for item in items if (k, item) in likert
    ]
    belief_rows, summary_rows, ll_rows = [], [], []
    truth = s.get("simulated_truth")
    for k, c in enumerate(order):
        letter = chr(ord("A") + k)
        for b in beliefs[c]:
            for estimate, lam in [
                ("mean", b["mean"]), ("map", b["map"]), ("ci90_low", b["ci90"]["low"]),
                ("ci90_high", b["ci90"]["high"]), ("grid_mode", b["grid_mode"]),
            ]:
                for j, v in zip(JOINTS, lam["q_star"]):
                    belief_rows.append({"condition": c, "program": letter, "iteration": b["iteration"],
                                        "parameter": "q_star", "joint": j, "estimate": estimate,
                                        "value": math.degrees(v), "unit": "deg"})
                for j, v in zip(JOINTS, lam["w"]):
                    belief_rows.append({"condition": c, "program": letter, "iteration": b["iteration"],
                                        "parameter": "w", "joint": j, "estimate": estimate, "value": v,
                                        "unit": None})
            distance = None
            if truth is not None:
                distance = math.sqrt(sum(math.degrees(a - t) ** 2 for a, t in zip(b["mean"]["q_star"], truth["q_star"])))
            summary_rows.append({"condition": c, "program": letter, "iteration": b["iteration"],
                                 "entropy_nats": b["entropy"], "ess": b["ess"], "distance_to_truth_deg": distance})
        for i, v in enumerate(test_ll.get(c, [])):
            ll_rows.append({"condition": c, "program": letter, "iteration": i, "log_likelihood_mean": v})
    for r in robot:
        del r["_t"]
    ids = {"session_id": session_id, "participant": participant}
    tag = lambda rows: [dict(ids, **r) for r in rows]
    return {
        "sessions.csv": tag(sessions), "trials.csv": tag(trials), "notes.csv": tag(notes),
        "robot.csv": tag(robot), "questionnaire.csv": tag(questionnaire), "beliefs.csv": tag(belief_rows),
        "belief_summary.csv": tag(summary_rows), "test_log_likelihood.csv": tag(ll_rows),
    }, bool(test_ll)


def trial_row(d, objects, labels, seq, t):
    row = {
        "event_index": seq, "phase": d["phase"], "condition": d.get("condition"), "program": d.get("program"),
        "trial": d["trial"], "query": d["query"], "query_label": labels[d["query"]], "object": d["object"],
        "object_label": objects[d["object"]]["label"], "status": "unanswered", "region": None,
        "region_label": None, "config_index": None, "presented_at": None if t is None else ms(t),
        "responded_at": None, "void_reason": None, "void_detail": "", "learned_from": None,
        "measurement_offset_s": None, "measurement_implied_region": None, "measurement_agrees": None,
    }
    for j in JOINTS:
        row[f"q_{j}_rad"] = None
        row[f"measured_{j}_rad"] = None
    return row


# The posterior-predictive test log-likelihood integrates over the belief's particles, which
# the log does not hold.
NOT_IN_THE_LOG = {"log_likelihood_predictive"}


class Compare:
    def __init__(self):
        self.rows = self.cells = 0
        self.differences = []
        self.max_relative = 0.0

    def cell(self, where, expected, found):
        self.cells += 1
        ok = True
        if expected is None:
            ok = found == ""
        elif isinstance(expected, bool):
            ok = found.lower() == str(expected).lower()
        elif isinstance(expected, int):
            ok = found == str(expected)
        elif isinstance(expected, float):
            try:
                x = float(found)
            except ValueError:
                ok = False
            else:
                rel = abs(x - expected) / max(1.0, abs(expected))
                self.max_relative = max(self.max_relative, rel)
                ok = rel <= 1e-12
        else:
            ok = found == expected
        if not ok:
            self.differences.append(f"{where}: the log gives {expected!r}, analyze wrote {found!r}")

    def table(self, path, expected, key_columns=None, only=None):
        """Compares `expected` (dicts in order) with the CSV at `path`, in the columns the dicts
        have; `only` keeps analyze's rows of those sessions."""
        if not expected and not path.exists():
            return
        if not path.exists():
            self.differences.append(f"{path}: missing, the logs give {len(expected)} rows")
            return
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            found = list(reader)
            header = reader.fieldnames or []
        # Every column analyze writes is recomputed here, but the one a log cannot give.
        unchecked = set(header) - set(expected[0] if expected else header) - NOT_IN_THE_LOG
        if unchecked:
            self.differences.append(f"{path}: columns {sorted(unchecked)} are not recomputed by this reader")
        if only is not None:
            found = [r for r in found if r["session_id"] in only]
        if len(found) != len(expected):
            self.differences.append(f"{path}: {len(found)} rows, the logs give {len(expected)}")
        for n, (e, f) in enumerate(zip(expected, found)):
            self.rows += 1
            for col, v in e.items():
                if col not in f:
                    self.differences.append(f"{path}: no column {col}")
                    return
                if col == "log":
                    same = os.path.realpath(f[col]) == os.path.realpath(v)
                    self.cells += 1
                    if not same:
                        self.differences.append(f"{path} row {n + 2} log: {f[col]!r}, the log is {v!r}")
                    continue
                self.cell(f"{path} row {n + 2} ({e.get('session_id')}) {col}", v, f[col])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("logs")
    ap.add_argument("out")
    ap.add_argument("--withdrawn", nargs="*", default=[], help="participants left out of the analysis")
    a = ap.parse_args()
    files = []
    for root, dirs, names in os.walk(a.logs, followlinks=False):
        files += [os.path.join(root, n) for n in names if n.endswith(".mcap") and os.path.isfile(os.path.join(root, n))
                  and not os.path.islink(os.path.join(root, n))]
    files.sort(key=lambda p: Path(p).parts)
    logs = []
    for p in files:
        try:
            logs.append(Log(p))
        except Exception as e:
            print(f"tables_from_log: {p}: unreadable ({e}); analyze skips it too", file=sys.stderr)
    # The most complete log of each session: more events, then finished; the first read wins.
    best = {}
    for log in logs:
        key = (log.start["session_id"], log.start["protocol_sha256"])
        old = best.get(key)
        if old is None or (len(log.events), log.finished) > (len(old.events), old.finished):
            best[key] = log
    chosen = [best[k] for k in sorted(best)]
    chosen = [l for l in chosen if l.start["pilot"] or l.start["participant"] not in a.withdrawn]
    chosen.sort(key=lambda l: (l.start["pilot"], l.start["started_at"]))
    cmp = Compare()
    events = 0
    # What the corpus covered, over every log read.
    seen = {}
    def count(what, n=1):
        seen[what] = seen.get(what, 0) + n
    for log in logs:
        st = log.start
        count(f"format {st.get('log_format', 1)}")
        count("finished" if log.finished else "cut (killed or quit before the end)")
        if "resumed_from" in st:
            count("resumed")
        count(f"hand {log.protocol.get('arm', {}).get('side', 'right')}")
        count(f"observation {log.protocol['learning'].get('observation', 'region')}")
        presented = False
        for topic, seq, _, d in sorted(log.messages, key=lambda m: m[1]):
            if topic not in EVENT_TOPICS:
                continue
            count(topic)
            if topic == "/trial/query":
                presented = True
            elif topic == "/trial/void":
                count("void retracting a grasp" if d["retracted"] else
                      ("void after presenting" if presented else "void before presenting"))
                presented = False
            elif topic == "/robot/command":
                presented = False
            elif topic == "/robot/status":
                count(f"robot {d['state']}" + (" (stale)" if d.get("stale") else "" if "attempt" in d else " (late)"))
    for pilot in (False, True):
        group = [l for l in chosen if l.start["pilot"] == pilot]
        if not group:
            continue
        out = Path(a.out) / ("pilot" if pilot else "")
        tables, with_ll = {}, set()
        for log in group:
            events += len(log.events)
            rows, has_ll = rows_of(log)
            if has_ll:
                with_ll.add(log.start["session_id"])
            for name, r in rows.items():
                tables.setdefault(name, []).extend(r)
        for name, rows in tables.items():
            if name == "robot.csv" and not rows:
                if (out / name).exists():
                    cmp.differences.append(f"{out / name}: written, but no session had a robot")
                continue
            # Test log-likelihoods are logged with the end of a completed session: the
            # sessions that logged them are compared.
            cmp.table(out / name, rows, only=with_ll if name == "test_log_likelihood.csv" else None)
    print("covered: " + ", ".join(f"{k} {v}" for k, v in sorted(seen.items())))
    for d in cmp.differences[:50]:
        print(f"DIFFERENT {d}")
    if len(cmp.differences) > 50:
        print(f"... and {len(cmp.differences) - 50} more")
    print(
        f"reader: {len(chosen)} sessions ({len(logs)} logs, {events} events): {cmp.rows} rows, {cmp.cells} cells compared, "
        f"{len(cmp.differences)} differ (largest relative difference of a number {cmp.max_relative:.1e})"
    )
    ok = not cmp.differences
    print(f"{int(ok)} passed, {int(not ok)} failed")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
