#!/usr/bin/env python3
"""Does speed buy accuracy? The same simulated arm7 study at several particle counts.

Runs `handover research simulate arm7 --particles N` for each N with the same seeds and trials (a
trial's truth, menu and test set depend only on the seed and the trial, so the runs are
paired trial by trial), then prints, at the last iteration, each count's mean distance to
the truth and test log-likelihood with a 95 % t-interval over the seeds' means, and the
paired difference from the first count (mean over seeds with its 95 % interval, and the
two-sided sign test over all trials); `--json FILE` also writes them for
benches/readme_results.py. Standard library only.

    python3 benches/particles_accuracy.py --handover target/release/handover \\
        --particles 1000,5000,20000 --learn both --seeds 10 --trials 20 --out target/particles
"""

import argparse
import csv
import json
import math
import os
import statistics
import subprocess
import sys
import time

# Two-sided 95 % t quantiles by degrees of freedom (1–30); the normal's beyond.
T95 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
       2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
       2.052, 2.048, 2.045, 2.042]


def interval(xs):
    m = statistics.fmean(xs)
    if len(xs) < 2:
        return m, float("nan"), float("nan")
    t = T95[len(xs) - 2] if len(xs) - 1 <= len(T95) else 1.96
    h = t * statistics.stdev(xs) / math.sqrt(len(xs))
    return m, m - h, m + h


def sign_test(diffs):
    """Two-sided exact sign test of a zero median (ties dropped)."""
    pos = sum(d > 0 for d in diffs)
    neg = sum(d < 0 for d in diffs)
    n = pos + neg
    if n == 0:
        return 1.0
    k = min(pos, neg)
    p = sum(math.comb(n, i) for i in range(k + 1)) / 2 ** n
    return min(1.0, 2 * p)


def last_iteration(path):
    rows = {}
    with open(path, newline="") as f:
        data = list(csv.DictReader(f))
    last = max(int(r["iteration"]) for r in data)
    for r in data:
        if int(r["iteration"]) == last:
            rows[(r["algorithm"], int(r["seed"]), int(r["trial"]))] = r
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--handover", default="target/release/handover")
    ap.add_argument("--particles", default="1000,5000,20000")
    ap.add_argument("--learn", default="both")
    ap.add_argument("--algorithms", default="active")
    ap.add_argument("--seed", type=int, default=0, help="the first seed (seeds SEED, SEED+1, …)")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--observation", default="configuration", help="configuration or region (the grip taken)")
    ap.add_argument("--alpha", help="the simulated person's and the model's α (default: simulate's)")
    ap.add_argument("--out", default="target/particles")
    ap.add_argument("--json", help="also write every count's and difference's numbers here")
    args = ap.parse_args()
    counts = [int(c) for c in args.particles.split(",")]

    runs = {}
    for n in counts:
        out = os.path.join(args.out, f"particles-{n}")
        metrics = os.path.join(out, "metrics.csv")
        cmd = [args.handover, "research", "simulate", "arm7", "--learn", args.learn, "--particles", str(n),
               "--algorithms", args.algorithms, "--seed", str(args.seed), "--seeds", str(args.seeds), "--trials", str(args.trials),
               "--observation", args.observation, "--out", out] + (["--alpha", args.alpha] if args.alpha else [])
        # A finished run is kept only for the same settings (command.json, written after it).
        done = os.path.join(out, "command.json")
        kept = os.path.exists(metrics) and os.path.exists(done) and json.load(open(done)) == cmd[1:]
        if not kept:
            t0 = time.perf_counter()
            r = subprocess.run(cmd, stdout=subprocess.DEVNULL)
            if r.returncode != 0:
                sys.exit(f"{' '.join(cmd)} failed (exit {r.returncode})")
            with open(done, "w") as f:
                json.dump(cmd[1:], f)
            print(f"{n} particles: {time.perf_counter() - t0:.0f} s", file=sys.stderr)
        runs[n] = last_iteration(metrics)

    base = counts[0]
    results = []
    print(f"arm7, learning {args.learn}, observing the {args.observation}, α = {args.alpha or 'simulate default'}, "
          f"seeds {args.seed}–{args.seed + args.seeds - 1} × {args.trials} trials, last iteration; "
          f"mean [95 % interval over seeds]; Δ: paired difference from a smaller count "
          f"(mean over seeds [95 % interval], sign test over all trials)")
    for algorithm in args.algorithms.split(","):
        for measure, better in (("distance_to_truth", "lower"), ("test_log_likelihood", "higher")):
            print(f"\n{algorithm}: {measure} ({better} is better)")
            for n in counts:
                keys = sorted(k for k in runs[n] if k[0] == algorithm)
                by_seed = {}
                for k in keys:
                    by_seed.setdefault(k[1], []).append(float(runs[n][k][measure]))
                m, lo, hi = interval([statistics.fmean(v) for v in by_seed.values()])
                results.append({"algorithm": algorithm, "measure": measure, "particles": n, "mean": m, "low": lo,
                                "high": hi})
                line = f"  {n:>6} particles  {m:10.4f} [{lo:.4f}, {hi:.4f}]"
                i = counts.index(n)
                for ref in ([base] if i == 1 else [base, counts[i - 1]]) if i > 0 else []:
                    diffs = [float(runs[n][k][measure]) - float(runs[ref][k][measure]) for k in keys]
                    seed_diffs = {}
                    for k, d in zip(keys, diffs):
                        seed_diffs.setdefault(k[1], []).append(d)
                    dm, dlo, dhi = interval([statistics.fmean(v) for v in seed_diffs.values()])
                    p = sign_test(diffs)
                    results.append({"algorithm": algorithm, "measure": measure, "particles": n, "versus": ref,
                                    "difference": dm, "low": dlo, "high": dhi, "sign_test_p": p, "trials": len(diffs)})
                    line += f"   Δ vs {ref}: {dm:+.4f} [{dlo:+.4f}, {dhi:+.4f}], sign test p = {p:.2g}"
                print(line)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"seed": args.seed, "seeds": args.seeds, "trials": args.trials, "observation": args.observation,
                       "alpha": args.alpha, "learn": args.learn, "results": results}, f, indent=1)


if __name__ == "__main__":
    main()
