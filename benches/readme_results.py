#!/usr/bin/env python3
"""Every scientific number in the README, regenerated from seeds of your choosing.

Runs the commands behind each of the README's findings with seeds derived from --seed,
computes their statistics with SciPy (an implementation independent of handover's), and
writes them, in the README's words, to OUT/report.md (and OUT/results.json):

  pilot                The pilot-to-plan paragraph: two dry-run studies of 48 people with the
                       arm measured (σ = 5°; seeds SEED and SEED+1) and one observing the grip
                       only (SEED+2), each analysed with --fit-population: the fitted
                       population against the one the people came from, and partial pooling
                       (each person's q* under the fitted population against their session's
                       own: pooled − alone, mean [95 % t-interval], median, share closer,
                       two-sided Wilcoxon).
  recovery             How often the fitted population's 95 % intervals hold the truth, over
                       many simulated studies (the ignored test population_recovery_by_size,
                       people seeded from SEED+100), with Clopper–Pearson intervals.
  particles            The particle counts' accuracy (arm7 simulations, seeds SEED+200 to
                       SEED+207, 20 trials each): benches/particles_accuracy.py twice.
  measured-particles   20 000 against 2000 particles in measured dry-run sessions (the 48
                       people of seed SEED, paired by session): distance to the true q*.
  next-prior           The pilot's fitted population as the next study's prior (`protocol
                       with --prior-file`): 240 new people from the default population (seed
                       SEED+300), measured, under the written prior, the pilot's and the
                       people's own population; active − passive, and each condition's
                       change from the written prior.

Finished steps are kept in OUT (in folders named by their seeds) and not rerun. The whole run takes about two hours on two cores
(most of it the 20 000-particle dry run and next-prior's 720 sessions). --smoke runs every step at toy sizes (a minute or
two) to check the commands and the parsing, not the science.

    benches/readme-results.sh --seed 12000            # builds, makes a venv, runs this
    python3 benches/readme_results.py --handover target/release/handover --seed 12000 --out target/readme-results
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time

import pandas as pd
from scipy import stats

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SECTIONS = ["pilot", "recovery", "particles", "measured-particles", "next-prior"]


def run(cmd, log, cwd=None, env=None):
    """Runs a command with its output in `log`; exits naming it when it fails."""
    t0 = time.perf_counter()
    with open(log, "w") as out:
        r = subprocess.run(cmd, stdout=out, stderr=subprocess.STDOUT, cwd=cwd, env=env)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed (exit {r.returncode}); its output: {log}")
    print(f"  {time.perf_counter() - t0:6.0f} s  {' '.join(os.path.basename(c) if i == 0 else c for i, c in enumerate(cmd))}",
          file=sys.stderr)


def protocol(path, observation, particles=None):
    """The default protocol observing `observation` (measured: σ = 5° per joint)."""
    with open(os.path.join(ROOT, "protocols", "bike-handover.json")) as f:
        p = json.load(f)
    p["learning"]["observation"] = observation
    if observation == "measured":
        p["learning"]["measurement"] = {"sigma_deg": [5] * 7}
    if particles:
        p["learning"]["particles"] = particles
    with open(path, "w") as f:
        json.dump(p, f, indent=1)
    return path


def paired(differences):
    """Mean [95 % t-interval], median, share below zero and the two-sided Wilcoxon p."""
    d = pd.Series(differences, dtype=float)
    n = len(d)
    m = d.mean()
    h = stats.t.ppf(0.975, n - 1) * d.std(ddof=1) / math.sqrt(n) if n > 1 else float("nan")
    p = stats.wilcoxon(d).pvalue if (d != 0).any() else 1.0
    return {"n": n, "mean": m, "low": m - h, "high": m + h, "median": d.median(), "share_below": (d < 0).mean(),
            "p": p}


def fmt_p(p):
    return "p < 0.001" if p < 0.001 else f"p = {p:.3f}"


def fmt_paired(r, unit="°"):
    return (f"{r['mean']:+.1f}{unit} [{r['low']:+.1f}, {r['high']:+.1f}] (median {r['median']:+.1f}{unit}, "
            f"{100 * r['share_below']:.0f} % below 0, Wilcoxon {fmt_p(r['p'])}, n = {r['n']})")


def clopper_pearson(k, n):
    if n == 0:
        return float("nan"), float("nan")
    ci = stats.binomtest(k, n).proportion_ci(0.95, method="exact")
    return ci.low, ci.high


def distances_at_last(out_dir):
    """Each session's and condition's distance (°) of the posterior mean to the true q* at the
    last iteration, from analyze's belief_summary.csv, keyed by the session's seed."""
    b = pd.read_csv(os.path.join(out_dir, "pilot", "belief_summary.csv"))
    s = pd.read_csv(os.path.join(out_dir, "pilot", "sessions.csv"), dtype={"seed": str})
    b = b[b.iteration == b.iteration.max()].merge(s[["session_id", "seed"]], on="session_id")
    return {(r.seed, r.condition): r.distance_to_truth_deg for r in b.itertuples()}


def default_population(low, high):
    """The protocol's default population of a joint whose prior range is [low, high] (mean,
    sd): the mean at the middle of the range, the spread a sixth of it
    (src/protocol/population.rs; no command prints it)."""
    return (low + high) / 2, (high - low) / 6


def pilot_study(args, seed, observation):
    d = os.path.join(args.out, f"pilot-{observation}-{seed}")
    os.makedirs(d, exist_ok=True)
    out = os.path.join(d, "out")
    if not os.path.exists(os.path.join(out, "pilot", "pooled.csv")):
        p = protocol(os.path.join(d, "protocol.json"), observation, args.particles)
        logs = os.path.join(d, "logs")
        if not os.path.isdir(logs):
            run([args.handover, "dry-run", "--protocol", p, "--participants", str(args.participants), "--seed", str(seed),
                 "--pace", "0", "--logs", logs + ".partial"], os.path.join(d, "dry-run.txt"))
            os.rename(logs + ".partial", logs)
        run([args.handover, "analyze", logs, "--fit-population", "--alpha-particles", str(args.alpha_particles),
             "--out", out], os.path.join(d, "analyze.txt"))
    pop = pd.read_csv(os.path.join(out, "pilot", "population.csv"))
    pop = pop[pop.part == "q_star"]
    # The people came from the protocol's default population.
    true_mean, true_sd = default_population(pop.support_min, pop.support_max)
    means_with = pop.mean_low.notna()
    sds_with = pop.sd_low.notna()
    means_held = means_with & (pop.mean_low <= true_mean) & (true_mean <= pop.mean_high)
    sds_held = sds_with & (pop.sd_low <= true_sd) & (true_sd <= pop.sd_high)
    pooled = pd.read_csv(os.path.join(out, "pilot", "pooled.csv"))
    q = pooled[pooled.part == "q_star"]
    dist = q.assign(s=(q.session_mean - q.truth) ** 2, p=(q.pooled_mean - q.truth) ** 2).groupby("session_id")[["s", "p"]].sum()
    pooling = paired(list(dist.p.pow(0.5) - dist.s.pow(0.5)))
    cover = {k: float(((q.truth - q[k + "_mean"]).abs() <= stats.norm.ppf(0.95) * q[k + "_sd"]).mean())
             for k in ("session", "pooled")}
    return {"seed": seed, "observation": observation, "participants": args.participants,
            "joints": len(pop), "means_with_interval": int(means_with.sum()), "means_held": int(means_held.sum()),
            "sds_with_interval": int(sds_with.sum()), "sds_held": int(sds_held.sum()),
            "sds_at_floor": int((pop.sd_at_floor.astype(str).str.lower() == "true").sum()),
            "fitted_sd_deg": [float(x) for x in pop.sd], "true_sd_deg": [float(x) for x in true_sd],
            "median_fitted_sd_deg": float(pop.sd.median()), "median_true_sd_deg": float(true_sd.median()),
            "pooled_minus_alone_deg": pooling, "coverage90": cover, "out": out}


def pilot(args):
    studies = [pilot_study(args, args.seed, "measured"), pilot_study(args, args.seed + 1, "measured"),
               pilot_study(args, args.seed + 2, "region")]
    measured = [s for s in studies if s["observation"] == "measured"]
    lines = [f"Dry-run studies of {args.participants} people drawn from the default population, analysed with "
             f"`--fit-population` (seeds {args.seed} and {args.seed + 1} measured, σ = 5°; {args.seed + 2} regions):", ""]
    j = sum(s["joints"] for s in measured)
    lines.append(f"- measured: the fit held **{sum(s['means_held'] for s in measured)} of the {j} true means** "
                 f"and **{sum(s['sds_held'] for s in measured)} of the {j} spreads** in its 95 % intervals "
                 f"({sum(s['means_with_interval'] for s in measured)} means and "
                 f"{sum(s['sds_with_interval'] for s in measured)} spreads got one)")
    for s in studies:
        r = s["pooled_minus_alone_deg"]
        lines.append(f"- {s['observation']}, seed {s['seed']}: pooled − alone {fmt_paired(r)}; 90 % coverage alone {100 * s['coverage90']['session']:.1f} %, "
                     f"pooled {100 * s['coverage90']['pooled']:.1f} %; fitted spreads "
                     f"{', '.join(f'{x:.1f}' for x in s['fitted_sd_deg'])}° (true "
                     f"{', '.join(f'{x:.1f}' for x in s['true_sd_deg'])}°), {s['sds_at_floor']} of {s['joints']} "
                     "at the floor")
    return {"studies": studies}, lines


def recovery(args):
    d = os.path.join(args.out, f"recovery-{args.seed + 100}-{args.recovery_studies}")
    os.makedirs(d, exist_ok=True)
    csv_path = os.path.join(d, "recovery.csv")
    if not os.path.exists(csv_path):
        env = dict(os.environ, HANDOVER_RECOVERY_SEED=str(args.seed + 100),
                   HANDOVER_RECOVERY_STUDIES=str(args.recovery_studies))
        log = os.path.join(d, "cargo-test.txt")
        profile = [] if args.smoke else ["--release"]
        run(["cargo", "test", "-q", *profile, "--lib", "population_recovery_by_size", "--", "--ignored", "--nocapture",
             "--test-threads", "1"], log, cwd=ROOT, env=env)
        with open(log) as f:
            rows = [l for l in f if l.startswith("observation,") or l.startswith(("measured,", "region,"))]
        with open(csv_path + ".partial", "w") as f:
            f.writelines(rows)
        os.rename(csv_path + ".partial", csv_path)
    t = pd.read_csv(csv_path)
    keys = ["observation", "alpha", "sd_deg", "participants"]
    lines = [f"Population recovery, {args.recovery_studies} studies per row (people seeded {args.seed + 100}–"
             f"{args.seed + 99 + args.recovery_studies}; 26 random handovers each):", "",
             "| observation | α | true spread | participants | mean error of the means | median fitted spread | "
             "means with an interval | … holding the truth | spreads with an interval | … holding the truth |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    rows = []
    for k, g in t.groupby(keys, sort=False):
        lines.append(f"| {k[0]} | {k[1]:g} | {k[2]:g}° | {k[3]} | {g.mean_abs_error_deg.mean():.1f}° | "
                     f"{g.median_fitted_sd_deg.median():.1f}° | {g.means_with_interval.sum()} of {7 * len(g)} | "
                     f"{g.means_covered.sum()} | {g.sds_with_interval.sum()} of {7 * len(g)} | {g.sds_covered.sum()} |")
        rows.append(dict(zip(keys, k), studies=len(g), means_with_interval=int(g.means_with_interval.sum()),
                         means_covered=int(g.means_covered.sum()), sds_with_interval=int(g.sds_with_interval.sum()),
                         sds_covered=int(g.sds_covered.sum())))
    out = {"rows": rows}
    for what in ("means", "sds"):
        k, n = int(t[f"{what}_covered"].sum()), int(t[f"{what}_with_interval"].sum())
        lo, hi = clopper_pearson(k, n)
        out[what] = {"held": k, "with_interval": n, "share": k / n if n else float("nan"), "low": lo, "high": hi}
        lines.append("")
        lines.append(f"{'Means' if what == 'means' else 'Spreads'}: **{k} of {n}** 95 % intervals held the truth "
                     f"({100 * k / n if n else float('nan'):.0f} % [{100 * lo:.0f}, {100 * hi:.0f}], Clopper–Pearson)")
    return out, lines


def particles(args):
    d = os.path.join(args.out, f"particles-{args.seed + 200}{'-smoke' if args.smoke else ''}")
    os.makedirs(d, exist_ok=True)
    counts = "100,200,400,800" if args.smoke else "1000,2000,5000,20000"
    seeds, trials = (2, 2) if args.smoke else (8, 20)
    out, lines = {}, []
    for name, extra in (("configuration-alpha40", []), ("region-alpha5", ["--observation", "region", "--alpha", "5"])):
        j = os.path.join(d, name + ".json")
        if not os.path.exists(j):
            run([sys.executable, os.path.join(HERE, "particles_accuracy.py"), "--handover", args.handover, "--particles",
                 counts, "--learn", "q-star", "--seed", str(args.seed + 200), "--seeds", str(seeds), "--trials",
                 str(trials), "--out", os.path.join(d, name), "--json", j + ".partial", *extra], os.path.join(d, name + ".txt"))
            os.rename(j + ".partial", j)
        with open(j) as f:
            r = json.load(f)
        out[name] = r
        c = [int(x) for x in counts.split(",")]
        lines.append(f"arm7, q*, observing the {r['observation']}, α = {r['alpha'] or 40}, seeds {r['seed']}–"
                     f"{r['seed'] + r['seeds'] - 1} × {r['trials']} trials, distance to the true q* at the last "
                     "iteration (rad; negative: the larger count closer):")
        for n, ref in ((c[1], c[0]), (c[2], c[1]), (c[3], c[2])):
            x = next(e for e in r["results"] if e["measure"] == "distance_to_truth" and e["particles"] == n
                     and e.get("versus") == ref)
            lines.append(f"- {ref} → {n}: {x['difference']:+.3f} [{x['low']:+.3f}, {x['high']:+.3f}] (mean over seeds, "
                         f"95 % t-interval), sign test over {x['trials']} trials p = {x['sign_test_p']:.2g}")
        lines.append("")
    return out, lines


def measured_particles(args):
    many = 400 if args.smoke else 20000
    few = pilot_study(args, args.seed, "measured")
    d = os.path.join(args.out, f"measured-{many}-{args.seed}")
    os.makedirs(d, exist_ok=True)
    out = os.path.join(d, "out")
    if not os.path.exists(os.path.join(out, "pilot", "belief_summary.csv")):
        p = protocol(os.path.join(d, "protocol.json"), "measured", many)
        logs = os.path.join(d, "logs")
        if not os.path.isdir(logs):
            run([args.handover, "dry-run", "--protocol", p, "--participants", str(args.participants), "--seed",
                 str(args.seed), "--pace", "0", "--logs", logs + ".partial"], os.path.join(d, "dry-run.txt"))
            os.rename(logs + ".partial", logs)
        run([args.handover, "analyze", logs, "--out", out], os.path.join(d, "analyze.txt"))
    a, b = distances_at_last(few["out"]), distances_at_last(out)
    if set(a) != set(b):
        sys.exit(f"the {many}-particle sessions are not the same people as the {args.particles or 2000}-particle ones")
    result = {"particles": [args.particles or 2000, many], "seed": args.seed}
    lines = [f"Measured dry-run sessions (σ = 5°, {args.participants} people, seed {args.seed}), distance of the "
             f"posterior mean to the true q* at the end of training, {args.particles or 2000} against {many} particles "
             "(the same people):", ""]
    for condition in ("active", "passive"):
        keys = sorted(k for k in a if k[1] == condition)
        r = paired([b[k] - a[k] for k in keys])
        result[condition] = {"few": float(pd.Series([a[k] for k in keys]).mean()),
                             "many": float(pd.Series([b[k] for k in keys]).mean()), "many_minus_few": r}
        lines.append(f"- {condition}: {result[condition]['few']:.1f}° → {result[condition]['many']:.1f}°; "
                     f"{many} − {args.particles or 2000}: {fmt_paired(r)}")
    for label, dist in (("few", a), ("many", b)):
        seeds = sorted({k[0] for k in dist})
        r = paired([dist[(s, "active")] - dist[(s, "passive")] for s in seeds])
        result[f"active_minus_passive_{label}"] = r
        lines.append(f"- active − passive at {result['particles'][0 if label == 'few' else 1]}: {fmt_paired(r)}")
    return result, lines


def next_prior(args):
    pilot = pilot_study(args, args.seed, "measured")
    seed, n = args.seed + 300, args.participants if args.smoke else 5 * args.participants
    d = os.path.join(args.out, f"next-prior-{args.seed}-{seed}-{n}")
    os.makedirs(d, exist_ok=True)
    written = protocol(os.path.join(d, "written.json"), "measured", args.particles)
    fitted = os.path.join(d, "pilot-prior", "protocol.json")
    if not os.path.exists(fitted):
        run([args.handover, "protocol", "with", written, "--prior-file",
             os.path.join(pilot["out"], "pilot", "prior.json"), "--out", os.path.dirname(fitted)],
            os.path.join(d, "protocol-with.txt"))
    # The population the people come from, as the prior: each joint a normal truncated to
    # the prior's range.
    true_prior = os.path.join(d, "population-prior.json")
    with open(written) as f:
        p = json.load(f)
    for c in p["learning"]["prior"]["q_star_deg"]:
        mean, sd = default_population(c["min"], c["max"])
        c.update(kind="gaussian", mean=mean, sd=sd)
    with open(true_prior, "w") as f:
        json.dump(p, f, indent=1)
    dist = {}
    arms = (("written", written), ("pilot", fitted), ("population", true_prior))
    for name, p in arms:
        out = os.path.join(d, name, "out")
        if not os.path.exists(os.path.join(out, "pilot", "belief_summary.csv")):
            logs = os.path.join(d, name, "logs")
            if not os.path.isdir(logs):
                run([args.handover, "dry-run", "--protocol", p, "--participants", str(n), "--seed", str(seed), "--pace",
                     "0", "--logs", logs + ".partial"], os.path.join(d, f"dry-run-{name}.txt"))
                os.rename(logs + ".partial", logs)
            # The α evidence is not used here: few draws keep the replay short.
            run([args.handover, "analyze", logs, "--alpha-particles", "50", "--out", out],
                os.path.join(d, f"analyze-{name}.txt"))
        dist[name] = distances_at_last(out)
    if any(set(dist["written"]) != set(dist[name]) for name, _ in arms):
        sys.exit("the priors' sessions are not the same people")
    people = sorted({k[0] for k in dist["written"]})
    with open(os.path.join(pilot["out"], "pilot", "prior.json")) as f:
        kinds = [c["kind"] for c in json.load(f)["q_star_deg"]]
    result = {"pilot_seed": args.seed, "seed": seed, "participants": n, "gaussian_joints": kinds.count("gaussian")}
    lines = [f"The measured pilot of seed {args.seed} ({args.participants} people) fitted, its population made the "
             f"prior of {kinds.count('gaussian')} of {len(kinds)} joints (a joint whose fit has no interval keeps the "
             f"written prior); {n} new people from the default population (seed {seed}), measured (σ = 5°), distance of the "
             "posterior mean to the true q* at the end of training:", ""]
    for name, label in (("written", "the written (uniform) prior"), ("pilot", "the pilot's prior"),
                        ("population", "the people's own population as the prior")):
        r = paired([dist[name][(s, "active")] - dist[name][(s, "passive")] for s in people])
        means = {c: float(pd.Series([dist[name][(s, c)] for s in people]).mean()) for c in ("active", "passive")}
        result[name] = {"active_minus_passive": r, **means}
        lines.append(f"- {label}: active {means['active']:.1f}°, passive {means['passive']:.1f}°; "
                     f"active − passive {fmt_paired(r)}")
    for name, label in (("pilot", "the pilot's prior"), ("population", "the population as the prior")):
        for c in ("active", "passive"):
            r = paired([dist[name][(s, c)] - dist["written"][(s, c)] for s in people])
            result[f"{name}_minus_written_{c}"] = r
            lines.append(f"- {c}, {label} − the written one: {fmt_paired(r)}")
    return result, lines


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--handover", default=os.path.join(ROOT, "target", "release", "handover"))
    ap.add_argument("--seed", type=int, required=True, help="the first seed; the steps use SEED to SEED+300")
    ap.add_argument("--out", help="where every step's outputs and the report go (default: target/readme-results, "
                    "or target/readme-results-smoke with --smoke)")
    ap.add_argument("--only", default=",".join(SECTIONS), help=f"comma-separated steps, of {', '.join(SECTIONS)}")
    ap.add_argument("--recovery-studies", type=int, default=4, help="simulated studies per recovery row")
    ap.add_argument("--smoke", action="store_true", help="toy sizes: checks the commands and parsing, not the science")
    args = ap.parse_args()
    only = args.only.split(",")
    for s in only:
        if s not in SECTIONS:
            ap.error(f"--only: unknown step {s!r}; expected some of {', '.join(SECTIONS)}")
    args.participants, args.alpha_particles, args.particles = (6, 200, 200) if args.smoke else (48, 2000, None)
    if args.smoke:
        args.recovery_studies = 0
    args.out = args.out or os.path.join(ROOT, "target", "readme-results-smoke" if args.smoke else "readme-results")
    os.makedirs(args.out, exist_ok=True)
    steps = {"pilot": pilot, "recovery": recovery, "particles": particles, "measured-particles": measured_particles,
             "next-prior": next_prior}
    results, report = {"seed": args.seed, "smoke": args.smoke}, [f"# The README's numbers, from seed {args.seed}", ""]
    for name in SECTIONS:
        if name not in only:
            continue
        print(f"{name}:", file=sys.stderr)
        r, lines = steps[name](args)
        results[name] = r
        report += [f"## {name}", ""] + lines + [""]
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(results, f, indent=1, default=float)
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write("\n".join(report))
    print("\n".join(report))


if __name__ == "__main__":
    main()
