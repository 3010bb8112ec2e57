#!/usr/bin/env python3
"""Checks the layout rules of docs/api.md against the code, from the includes
and Universal Ctags' function extents:

- no source file directly under backend/ (one sub-folder per concern);
- every include between folders points down (tools -> frontend -> backend
  -> factors, and inside backend the order of the layout table);
- no circle between modules (a module: foo.h with foo.cpp);
- no installed header includes backend/linear or names CHOLMOD;
- no function over 80 lines in backend/, frontend/ and factors/, none over
  100 in tools/ (lambdas count toward the function around them).

Usage: scripts/check-layout.py [REPO]   (exit 1 and one line per breach)
"""
import os
import re
import shutil
import subprocess
import sys
from collections import defaultdict

# Folder -> (area name as included, rank). An include may go to an area of
# lower rank, or to its own; robust and calibration stand side by side.
AREAS = {
    "factors": ("factors", 0),
    "backend/linear": ("linear", 1),
    "backend/graph": ("graph", 2),
    "backend/solvers": ("solvers", 3),
    "backend/robust": ("robust", 4),
    "backend/calibration": ("calibration", 4),
    "frontend": ("frontend", 5),
    "tools": ("tools", 6),
}
BY_NAME = {name: (folder, rank) for folder, (name, rank) in AREAS.items()}
LIMITS = {"tools": 100}
DEFAULT_LIMIT = 80
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"](?:cairn/([a-z_]+)/|(tools)/)([\w./]+)[>"]')


def sources(repo):
    for folder in AREAS:
        path = os.path.join(repo, folder)
        for name in sorted(os.listdir(path)) if os.path.isdir(path) else []:
            if name.endswith((".h", ".cpp")):
                yield folder, name


def check_flat_backend(repo, breaches):
    for name in sorted(os.listdir(os.path.join(repo, "backend"))):
        if name.endswith((".h", ".cpp")):
            breaches.append(f"backend/{name}: a source file directly under backend/")


def module_graph(repo, breaches):
    edges = defaultdict(set)
    for folder, name in sources(repo):
        area, rank = AREAS[folder]
        module = f"{folder}/{os.path.splitext(name)[0]}"
        with open(os.path.join(repo, folder, name), encoding="utf-8") as f:
            for lineno, line in enumerate(f, 1):
                m = INCLUDE.match(line)
                if not m:
                    continue
                target_area = m.group(1) or m.group(2)
                if target_area not in BY_NAME:
                    breaches.append(f"{folder}/{name}:{lineno}: unknown area '{target_area}'")
                    continue
                target_folder, target_rank = BY_NAME[target_area]
                if target_area != area and target_rank >= rank:
                    breaches.append(f"{folder}/{name}:{lineno}: {area} includes {target_area} "
                                    "(an arrow up or sideways)")
                if (name.endswith(".h") and target_area == "linear" and area not in
                        ("linear", "tools")):
                    breaches.append(f"{folder}/{name}:{lineno}: a public header includes "
                                    "backend/linear")
                target = f"{target_folder}/{os.path.splitext(m.group(3))[0]}"
                if target != module:
                    edges[module].add(target)
    return edges


def find_cycles(edges):
    """Tarjan's strongly connected components; returns those of size > 1."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    sys.setrecursionlimit(10000)
    for v in list(edges):
        if v not in index:
            visit(v)
    return out


def check_public_headers(repo, breaches):
    for folder, name in sources(repo):
        if not name.endswith(".h") or folder in ("backend/linear", "tools"):
            continue
        with open(os.path.join(repo, folder, name), encoding="utf-8") as f:
            for lineno, line in enumerate(f, 1):
                if "cholmod" in line.lower():
                    breaches.append(f"{folder}/{name}:{lineno}: an installed header names CHOLMOD")


def check_function_lengths(repo, breaches):
    folders = [f for f in AREAS if os.path.isdir(os.path.join(repo, f))]
    try:
        # Debian names Universal Ctags ctags-universal (ctags is an alternative).
        ctags = shutil.which("ctags-universal") or "ctags"
        tags = subprocess.run([ctags, "--fields=+ne", "--kinds-C++=f", "-o", "-", "-R"] + folders,
                              cwd=repo, capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError) as e:
        breaches.append(f"ctags (Universal Ctags) could not run: {e}")
        return
    for row in tags.splitlines():
        fields = row.split("\t")
        extra = dict(f.split(":", 1) for f in fields[3:] if ":" in f)
        if "line" not in extra or "end" not in extra:
            continue
        length = int(extra["end"]) - int(extra["line"]) + 1
        path = fields[1]
        limit = LIMITS.get(path.split("/")[0], DEFAULT_LIMIT)
        if length > limit:
            breaches.append(f"{path}:{extra['line']}: {fields[0]} is {length} lines "
                            f"(at most {limit})")


def main():
    repo = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..")
    breaches = []
    check_flat_backend(repo, breaches)
    edges = module_graph(repo, breaches)
    for cycle in find_cycles(edges):
        breaches.append("a circle between modules: " + " <-> ".join(cycle))
    check_public_headers(repo, breaches)
    check_function_lengths(repo, breaches)
    for b in breaches:
        print(b)
    modules = len(set(edges) | {t for ts in edges.values() for t in ts})
    print(f"layout: {len(breaches)} breaches ({modules} modules, "
          f"{sum(len(t) for t in edges.values())} includes between them)")
    return 1 if breaches else 0


if __name__ == "__main__":
    sys.exit(main())
