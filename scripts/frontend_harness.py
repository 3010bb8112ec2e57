#!/usr/bin/env python3
"""Harder versions of CARMEN corrected logs, and `cairn map` on each.

    scripts/frontend_harness.py make LOG.gz CASE OUT.log [--seed S]
    scripts/frontend_harness.py run CAIRN LOG.gz... [--cases a,b] [--seeds 1,2] [--out DIR] [--jobs N]

A LOG given as sim:SEEDS (sim:3, sim:1-8, sim:1,4,9) stands for the simulated
buildings of those seeds (`cairn simulate --laser-log`, written to the out
directory as simN.log): logs whose reference poses are the ground truth, of
buildings the front-end was never tuned on.

`make` writes one perturbed log; `run` makes every case of every log (and
seed) and prints a Markdown table of `cairn map`'s ATE against the log's own
reference poses, with the default settings, next to the plain log's.

Cases: glitch (three steps whose odometry heading is off by 60-90 degrees and
translation by up to 1 m), drift (1 degree of heading per metre travelled),
noise3 (the odometry's own error, scan to scan, three times larger), half
(every other beam), skip (every other scan dropped), range (3 cm Gaussian
range noise on every return). On request (`--cases`): reset (one step whose
heading is off by 90-180 degrees and translation by up to 2 m, as when the
odometry restarts), and any cases joined by "+" (glitch+half: the glitches on
half the beams).

The reference poses on the laser lines are never touched. In a corrected log
the ODOM chain restarts at each scan's pose: the raw motion between scans k-1
and k is ref[k-1]^-1 * (the last ODOM before scan k). The perturbed log
keeps that: one ODOM line before each scan, at ref[k-1] * (the perturbed
motion).
"""
import argparse
import gzip
import math
import multiprocessing
import os
import random
import re
import subprocess
import sys

CASES = ["glitch", "drift", "noise3", "half", "skip", "range"]
MORE_CASES = ["reset"]  # made on request (--cases), not by default


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def compose(a, b):
    x, y, t = a
    c, s = math.cos(t), math.sin(t)
    return (x + c * b[0] - s * b[1], y + s * b[0] + c * b[1], wrap(t + b[2]))


def inverse(a):
    x, y, t = a
    c, s = math.cos(t), math.sin(t)
    return (-c * x - s * y, s * x - c * y, wrap(-t))


def between(a, b):
    return compose(inverse(a), b)


def read_log(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt", errors="replace") as f:
        return f.read().splitlines()


def laser_fields(tokens):
    """(ranges, index of the reference pose) of a FLASER line."""
    n = int(float(tokens[1]))
    return [float(r) for r in tokens[2:2 + n]], 2 + n


def parse(lines):
    """Scans (line index, reference pose, raw motion since the previous scan)."""
    scans, last_odom = [], None
    for i, line in enumerate(lines):
        t = line.split()
        if not t:
            continue
        if t[0] == "ODOM":
            last_odom = tuple(float(v) for v in t[1:4])
        elif t[0] == "FLASER":
            _, k = laser_fields(t)
            ref = tuple(float(v) for v in t[k:k + 3])
            if scans and last_odom is not None:
                motion = between(scans[-1][1], last_odom)
            else:
                motion = (0.0, 0.0, 0.0)
            scans.append((i, ref, motion))
            last_odom = ref
    return scans


def scaled_error(true_motion, raw_motion, factor):
    """raw = true * e; returns true * e^factor (e small: its parameters scaled)."""
    e = between(true_motion, raw_motion)
    return compose(true_motion, (factor * e[0], factor * e[1], factor * e[2]))


def glitch_steps(scans, motions, rng, count, degrees, max_shift):
    """`count` steps, away from either end, turned by a heading error drawn
    from `degrees` (either sign) and shifted by up to `max_shift` metres."""
    n = len(scans)
    for k in rng.sample(range(max(2, n // 10), max(3, n - n // 10)), count):
        heading = math.radians(rng.uniform(*degrees)) * rng.choice([-1, 1])
        d, a = rng.uniform(0, max_shift), rng.uniform(-math.pi, math.pi)
        motions[k] = compose(motions[k], (d * math.cos(a), d * math.sin(a), heading))


def perturb_motions(case, scans, rng):
    motions = [m for _, _, m in scans]
    for part in case.split("+"):
        if part == "glitch":
            glitch_steps(scans, motions, rng, 3, (60, 90), 1.0)
        elif part == "reset":
            glitch_steps(scans, motions, rng, 1, (90, 180), 2.0)
        elif part == "drift":
            for k, m in enumerate(motions):
                motions[k] = (m[0], m[1], wrap(m[2] + math.radians(1.0) * math.hypot(m[0], m[1])))
        elif part == "noise3":
            for k in range(1, len(scans)):
                true = between(scans[k - 1][1], scans[k][1])
                motions[k] = scaled_error(true, motions[k], 3.0)
    return motions


def fmt(v):
    return "%.6f" % v


def rewrite_laser(tokens, case, rng, max_reading):
    ranges, k = laser_fields(tokens)
    parts = case.split("+")
    if "half" not in parts and "range" not in parts:
        return " ".join(tokens)
    if "half" in parts:
        ranges = ranges[::2]
    if "range" in parts:
        ranges = [r if r >= max_reading - 1e-3 else max(0.0, r + rng.gauss(0, 0.03)) for r in ranges]
    return " ".join(["FLASER", str(len(ranges))] + [fmt(r) for r in ranges] + tokens[k:])


def make(path, case, out_path, seed):
    unknown = [p for p in case.split("+") if p not in CASES + MORE_CASES]
    if unknown:
        sys.exit("unknown case %s (one of %s, or several joined by +)" %
                 (unknown[0], ", ".join(CASES + MORE_CASES)))
    rng = random.Random(seed)
    lines = read_log(path)
    scans = parse(lines)
    motions = perturb_motions(case, scans, rng)
    skip = "skip" in case.split("+")
    keep = [k % 2 == 0 or not skip for k in range(len(scans))]
    max_reading = max((max(laser_fields(lines[i].split())[0]) for i, _, _ in scans), default=0)
    scan_at = {i: k for k, (i, _, _) in enumerate(scans)}
    out, prev_kept, pending = [], None, (0.0, 0.0, 0.0)
    for i, line in enumerate(lines):
        t = line.split()
        if t and t[0] == "ODOM":
            continue
        if i not in scan_at:
            out.append(line)
            continue
        k = scan_at[i]
        pending = compose(pending, motions[k]) if k > 0 else pending
        if not keep[k]:
            continue
        stamp = t[-1]
        if prev_kept is not None:
            odom = compose(scans[prev_kept][1], pending)
            out.append("ODOM %s %s %s 0 0 0 %s harness %s" % (fmt(odom[0]), fmt(odom[1]), fmt(odom[2]),
                                                              stamp, stamp))
        out.append(rewrite_laser(t, case, rng, max_reading))
        prev_kept, pending = k, (0.0, 0.0, 0.0)
    with open(out_path, "w") as f:
        f.write("\n".join(out) + "\n")


def ate_of(cairn, log, prefix):
    run = subprocess.run([cairn, "map", log, "-o", prefix, "--quiet"], capture_output=True, text=True)
    if run.returncode != 0:
        return "failed (%s)" % run.stderr.strip().splitlines()[-1]
    m = re.search(r"result\s*: ATE ([0-9.]+) m", run.stderr)
    fell = re.search(r"(\d+) scans fell back to odometry", run.stderr)
    rec = re.search(r"(\d+) recover", run.stderr)
    vetoed = re.search(r"(\d+) were refuted by the odometry", run.stderr)
    return "%s%s%s%s" % (m.group(1) if m else "?", " (%s rec.)" % rec.group(1) if rec else "",
                         " (%s refuted)" % vetoed.group(1) if vetoed and vetoed.group(1) != "0" else "",
                         " (%s fell back)" % fell.group(1) if fell and fell.group(1) != "0" else "")


def log_name(log):
    return os.path.basename(log).split("-corrected")[0].split(".")[0]


def run_one(job):
    """One cell: (cairn, the log, case or None for the plain log, seed, out dir)."""
    cairn, log, case, seed, out = job
    name = log_name(log)
    if case is None:
        return ate_of(cairn, log, os.path.join(out, name))
    path = os.path.join(out, "%s_%s_%d.log" % (name, case, seed))
    make(log, case, path, seed)
    return ate_of(cairn, path, path[:-4])


def seeds_of(text):
    """1-8 or 1,4,9 (or both mixed) as a list of ints."""
    out = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out.extend(range(int(lo), int(hi or lo) + 1))
    return out


def expand_logs(cairn, logs, out):
    """Real logs as they are; sim:SEEDS simulated into `out`."""
    paths = []
    for log in logs:
        if not log.startswith("sim:"):
            paths.append(log)
            continue
        for seed in seeds_of(log[4:]):
            path = os.path.join(out, "sim%d.log" % seed)
            subprocess.run([cairn, "simulate", "--laser-log", path, "--seed", str(seed)],
                           check=True, capture_output=True)
            paths.append(path)
    return paths


def run(args):
    os.makedirs(args.out, exist_ok=True)
    args.logs = expand_logs(args.cairn, args.logs, args.out)
    cases = args.cases.split(",")
    seeds = seeds_of(args.seeds)
    print("| log | plain | " + " | ".join("%s s%d" % (c, s) if len(seeds) > 1 else c
                                           for c in cases for s in seeds) + " |")
    print("| --- " * (2 + len(cases) * len(seeds)) + "|")
    rows = [[(args.cairn, log, None, 0, args.out)] +
            [(args.cairn, log, c, s, args.out) for c in cases for s in seeds] for log in args.logs]
    # Each cell is one single-threaded `cairn map`: cells run side by side,
    # rows print in order as they complete.
    with multiprocessing.Pool(max(1, args.jobs)) as pool:
        results = [pool.map_async(run_one, row) for row in rows]
        for log, result in zip(args.logs, results):
            print("| " + " | ".join([log_name(log)] + result.get()) + " |", flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="command", required=True)
    m = sub.add_parser("make")
    m.add_argument("log")
    m.add_argument("case")
    m.add_argument("out")
    m.add_argument("--seed", type=int, default=1)
    r = sub.add_parser("run")
    r.add_argument("cairn")
    r.add_argument("logs", nargs="+")
    r.add_argument("--cases", default=",".join(CASES))
    r.add_argument("--seeds", default="1")
    r.add_argument("--out", default="/tmp/cairn-harness")
    r.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                   help="cells run at once (default: one per core)")
    a = p.parse_args()
    if a.command == "make":
        make(a.log, a.case, a.out, a.seed)
    else:
        run(a)


if __name__ == "__main__":
    main()
