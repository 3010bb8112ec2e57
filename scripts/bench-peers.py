#!/usr/bin/env python3
"""cairn's cold command line against g2o and GTSAM, side by side, on the shared g2o files.

For each file and run, in one loop (so that a busy machine weighs on all alike):
  - `cairn optimize FILE --solver gn --init file` as a user runs it: its report's time_s (the
    solve, set-up included) and the wall time of the whole process (reading, writing included);
  - the peers through `PEERS/run.sh FILE` (g2o's Gauss-Newton on CHOLMOD, GTSAM 4.3's
    Levenberg-Marquardt and Gauss-Newton): their own solver times, which leave out their set-up.
A peer counts as converged on a file when g2o's chi-squared of its result (`cairn info` on the
file it wrote) is close to cairn's: g2o's own printed chi2 (in memory; the file it writes has 6
digits, which on parking-garage alone add 1e-3) within 1e-3 relative (it minimises the same
objective; further off it stopped early or in another minimum), GTSAM's within
--converged (default 1.25) times it (GTSAM minimises a Logmap rotation error, so its 3D optimum
scores 12-18% above g2o's, while a stalled run is orders of magnitude off). Prints a markdown table: the fastest of --runs runs (and the slowest, as the
spread), and the ratio of cairn's fastest time_s to the fastest converged peer's.

Benchmarks and documentation only: never run from the tests or CI. Run nothing else meanwhile.

  scripts/bench-peers.py [--runs 3] [--files 2d/intel,3d/sphere2500] [--output table.md]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

FILES = ["2d/intel", "2d/MIT", "2d/city10000", "3d/tinyGrid3D", "3d/smallGrid3D",
         "3d/sphere2500", "3d/parking-garage", "3d/sphere_bignoise_vertex3"]
PEERS = ["g2o-gn", "gtsam-lm", "gtsam-gn"]


def run_cairn(tool, path, tmp):
    report = os.path.join(tmp, "r.json")
    start = time.perf_counter()
    subprocess.run([tool, "optimize", path, "-o", os.path.join(tmp, "out.g2o"), "--solver", "gn",
                    "--init", "file", "--quiet", "--report", report], check=True)
    wall = time.perf_counter() - start
    with open(report) as f:
        r = json.load(f)
    return {"time": r["time_s"], "wall": wall, "iterations": r["iterations"],
            "chi2": r["final_chi2"]}


def g2o_chi2(tool, path):
    out = subprocess.run([tool, "info", path, "--json"], check=True, capture_output=True,
                         text=True).stdout
    return json.loads(out)["chi2"]


def run_peers(peers, path, tool, tmp):
    env = dict(os.environ, PEERS_OUT=os.path.join(tmp, "peers"))
    out = subprocess.run([os.path.join(peers, "run.sh"), path], capture_output=True, text=True,
                         env=env).stdout
    results = {}
    for line in out.splitlines():
        fields = line.split()
        if len(fields) < 3 or fields[1] not in PEERS:
            continue
        values = dict(zip(fields[2::2], fields[3::2]))
        try:
            r = {"time": float(values["time_s"]), "iterations": int(values["iterations"])}
            # g2o prints its own chi2 to 6 digits; GTSAM's error is its own objective.
            r["chi2"] = g2o_chi2(tool, values["out"])
            if "chi2" in values:
                r["own_chi2"] = float(values["chi2"])
        except (KeyError, ValueError, subprocess.CalledProcessError):
            continue
        results[fields[1]] = r
    return results


def spread(values, digits=3):
    lo, hi = min(values), max(values)
    return f"{lo:.{digits}f}" if f"{lo:.{digits}f}" == f"{hi:.{digits}f}" else \
        f"{lo:.{digits}f}-{hi:.{digits}f}"


def table(files, cairn, peers, threshold):
    lines = ["| file | cairn GN: it, chi2, time_s (wall) | g2o GN: it, chi2, s | GTSAM LM: it, "
             "chi2, s | GTSAM GN: it, chi2, s | fastest converged peer, s | ratio |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for f in files:
        c = cairn[f]
        best_c = min(r["time"] for r in c)
        row = [f, f"{c[0]['iterations']}, {c[0]['chi2']:.10g}, {spread([r['time'] for r in c])} "
                  f"({spread([r['wall'] for r in c])})"]
        fastest = None
        for name in PEERS:
            runs = [p[name] for p in peers[f] if name in p]
            if not runs:
                row.append("no result")
                continue
            limit = (1 + 1e-3) if name.startswith("g2o") else threshold
            ok = runs[0].get("own_chi2", runs[0]["chi2"]) <= limit * c[0]["chi2"]
            t = min(r["time"] for r in runs)
            row.append(f"{runs[0]['iterations']}, {runs[0]['chi2']:.7g}, "
                       f"{spread([r['time'] for r in runs])}" + ("" if ok else " (not converged)"))
            if ok and (fastest is None or t < fastest[1]):
                fastest = (name, t)
        if fastest:
            row += [f"{fastest[0]} {fastest[1]:.3f}", f"{best_c / fastest[1]:.2f}"]
        else:
            row += ["none", "-"]
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines)


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--files", default=",".join(FILES))
    ap.add_argument("--cairn", default=os.path.join(root, "build", "cairn"))
    ap.add_argument("--peers", default=os.path.join(root, "..", "shared", "peers"))
    ap.add_argument("--datasets", default=os.path.join(root, "..", "shared", "datasets"))
    ap.add_argument("--converged", type=float, default=1.25)
    ap.add_argument("--output", help="also write the table to this file")
    ap.add_argument("--raw", help="also write every run's figures to this JSON file")
    ap.add_argument("--from-raw", help="only print the table of an earlier --raw file")
    a = ap.parse_args()
    if a.from_raw:
        with open(a.from_raw) as f:
            raw = json.load(f)
        print(table(raw["files"], raw["cairn"], raw["peers"], a.converged))
        return
    if not os.path.exists(os.path.join(a.peers, "run.sh")):
        sys.exit(f"bench-peers: no peers at {a.peers} (run.sh); nothing to compare with")
    files = [f for f in a.files.split(",") if f]
    cairn = {f: [] for f in files}
    peers = {f: [] for f in files}
    with tempfile.TemporaryDirectory() as tmp:
        for run in range(a.runs):
            for f in files:
                path = os.path.join(a.datasets, "g2o", f + ".g2o")
                cairn[f].append(run_cairn(a.cairn, path, tmp))
                peers[f].append(run_peers(a.peers, path, a.cairn, tmp))
                print(f"run {run + 1}/{a.runs} {f}: cairn {cairn[f][-1]['time']:.3f} s, " +
                      ", ".join(f"{k} {v['time']:.3f} s" for k, v in peers[f][-1].items()),
                      file=sys.stderr)
    if a.raw:
        with open(a.raw, "w") as f:
            json.dump({"files": files, "cairn": cairn, "peers": peers}, f)
    text = table(files, cairn, peers, a.converged)
    print(text)
    if a.output:
        with open(a.output, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
