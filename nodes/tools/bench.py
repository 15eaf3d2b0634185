"""``densepack-bench SUITE``: one interface for every benchmark (figures: docs/benchmarks.md).

``densepack-bench SUITE [--quick] [--seeds K] [--json PATH] [suite options]`` runs the
suite, prints a table and writes ``{"suite", "machine", "git_rev", "created", "args",
"rows"}``. A suite is a module with ``add_arguments(parser)`` (its own options),
``run(opts) -> list[dict]`` (one row per instance set, figures named as in docs/benchmarks.md)
and optionally ``COLUMNS`` (the columns the table shows, in order).
"""

from __future__ import annotations

import argparse
import datetime as dt
import importlib
import json
import math
import os
import platform
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

SUITES = {
    "sim": "nodes.bench.sim",
    "arm": "nodes.bench.arm",
    "perception": "nodes.bench.perception",
    "planner": "nodes.bench.planner",
    "cell": "nodes.bench.cell",
    "soak": "nodes.bench.soak",
    "unlabeled": "nodes.bench.unlabeled",
    "reference": "nodes.bench.reference",
    "placement": "nodes.bench.placement",
    "transport": "nodes.bench.transport",
}


def machine_info() -> dict[str, Any]:
    model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "hostname": platform.node(),
        "cpu": model or platform.processor(),
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "platform": platform.platform(),
    }


def git_rev() -> str:
    repo = Path(__file__).resolve().parents[2]
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=repo,
                             capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=repo, capture_output=True, text=True, timeout=10).stdout
    except (OSError, subprocess.TimeoutExpired):
        return "unknown"
    return f"{rev}{'-dirty' if dirty.strip() else ''}" if rev else "unknown"


def _cell(value: Any) -> str:
    if isinstance(value, float):
        if math.isnan(value):
            return "-"
        return f"{value:.4g}"
    return str(value)


def format_table(rows: Sequence[dict[str, Any]], columns: Sequence[str] | None = None) -> str:
    if not rows:
        return "(no rows)"
    if columns is None:
        columns = list(dict.fromkeys(k for row in rows for k in row
                                     if not isinstance(row[k], list | dict)))
    cells = [[_cell(row.get(c, "")) for c in columns] for row in rows]
    widths = [max(len(c), *(len(r[i]) for r in cells)) for i, c in enumerate(columns)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(columns, widths, strict=True))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(v.ljust(w) for v, w in zip(r, widths, strict=True)) for r in cells]
    return "\n".join(lines)


def _json_safe(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    return value


def main(args: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if args is None else args)
    top = argparse.ArgumentParser(prog="densepack-bench", add_help=False)
    top.add_argument("suite", nargs="?", choices=sorted(SUITES))
    known, _ = top.parse_known_args(argv)
    if known.suite is None:
        print(f"usage: densepack-bench {{{','.join(sorted(SUITES))}}} [--quick] [--seeds K] "
              "[--json PATH] [suite options]", file=sys.stderr if not argv else sys.stdout)
        return 0 if argv and argv[0] in ("-h", "--help") else 2
    try:
        suite = importlib.import_module(SUITES[known.suite])
    except ModuleNotFoundError as err:
        print(f"densepack-bench: suite '{known.suite}' is not implemented yet ({err.name})",
              file=sys.stderr)
        return 2
    parser = argparse.ArgumentParser(prog=f"densepack-bench {known.suite}",
                                     description=(suite.__doc__ or "").strip().splitlines()[0])
    parser.add_argument("suite", choices=[known.suite])
    parser.add_argument("--quick", action="store_true", help="small subset (a few minutes)")
    parser.add_argument("--seeds", type=int, default=None, help="seeds per instance set")
    parser.add_argument("--json", type=Path, default=None,
                        help="output JSON (default bench_results/SUITE.json)")
    suite.add_arguments(parser)
    opts = parser.parse_args(argv)
    rows = suite.run(opts)
    print(format_table(rows, getattr(suite, "COLUMNS", None)))
    out = opts.json or Path("bench_results") / f"{known.suite}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    record = {
        "suite": known.suite,
        "machine": machine_info(),
        "git_rev": git_rev(),
        "created": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "args": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(opts).items()},
        "rows": _json_safe(list(rows)),
    }
    out.write_text(json.dumps(record, indent=2) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
