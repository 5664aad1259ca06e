"""Benchmark records: one JSON file per measurement in ``tests/measurements/results/``, and the one reader.

A record says what was measured, how, on which code and which machine, and holds the figures::

    {
      "format": 1,
      "name": "reference-map-process",          # the file's stem: what it measures, never a date
      "measures": "one sentence or a paragraph: what the figures are",
      "command": "python tests/measurements/bench_map_process.py --sizes 200,1000",
      "commit": "5e1f0c2…",                     # 7 to 40 hex digits
      "commit_basis": "measured",               # or "added", see below
      "machine": {"cores": 2, "cpu": "AMD EPYC", "memory_gib": 24, "gpu": null},
      "versions": {"python": "3.11.7", "numba": "0.62.1"},
      "date_utc": "2026-11-23T01:19:41Z",       # a date or a time, UTC
      "figures": {...},                         # the measurement itself, any JSON object
      "load_average": "1.6-1.9",                # optional: what else ran on the machine
      "notes": "..."                            # optional
    }

``commit_basis`` says where the commit comes from: ``measured`` when the script (or the person)
that measured recorded the commit it ran on; ``added`` when the measurement predates this format and
the commit is the one that added its raw output (or, where only the docs held them, its figures) to
the repository: its code is the measured code unless the code changed between the measurement and
that commit. The scripts in ``tests/measurements/`` write
records through :func:`write_record`, which fills in the commit, machine, versions and date.

    python tests/measurements/records.py list                # one line per record
    python tests/measurements/records.py show NAME [--full]  # a record, its figures included
    python tests/measurements/records.py check               # exit 1 if a file is not a valid record
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import platform
import re
import shutil
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

RESULTS_DIR = Path(__file__).resolve().parent / "results"
FORMAT = 1
REQUIRED = ("format", "name", "measures", "command", "commit", "commit_basis", "machine", "versions",
            "date_utc", "figures")
OPTIONAL = ("load_average", "notes", "dirty")
MACHINE_KEYS = ("cores", "cpu", "memory_gib", "gpu")
COMMIT_BASES = ("measured", "added")
_NAME = re.compile(r"^[a-z0-9][a-z0-9.-]*$")
_DATE_IN_NAME = re.compile(r"\d{4}-\d{2}-\d{2}")
_COMMIT = re.compile(r"^[0-9a-f]{7,40}$")
_DATE = re.compile(r"^\d{4}-\d{2}-\d{2}")
#: ``show`` prints figures longer than this (characters of JSON) only with ``--full``
SHOW_CHARS = 6000


# --- writing -------------------------------------------------------------------------------------

def machine_info() -> dict:
    """Cores this process may use, CPU model, memory [GiB] and GPU name (None without one)."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:
        cores = os.cpu_count() or 1
    cpu, memory_gib = platform.processor() or platform.machine(), None
    try:
        text = Path("/proc/cpuinfo").read_text()
        cpu = re.search(r"^model name\s*:\s*(.+)$", text, re.M).group(1).strip()
    except (OSError, AttributeError):
        pass
    try:
        kib = int(re.search(r"^MemTotal:\s*(\d+)", Path("/proc/meminfo").read_text(), re.M).group(1))
        memory_gib = round(kib / 2**20, 1)
    except (OSError, AttributeError):
        pass
    gpu = None
    if shutil.which("nvidia-smi"):
        r = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"],
                           capture_output=True, text=True)
        gpu = r.stdout.strip().splitlines()[0] if r.returncode == 0 and r.stdout.strip() else None
    return {"cores": cores, "cpu": cpu, "memory_gib": memory_gib, "gpu": gpu}


def package_versions(packages=()) -> dict:
    """Python's version and those of ``rockbench`` and ``packages`` that are installed."""
    out = {"python": platform.python_version()}
    for name in ("rockbench", *packages):
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            pass
    return out


def git_commit() -> tuple[str, bool]:
    """The checkout's commit and whether tracked files differ from it."""
    root = Path(__file__).resolve().parent.parent
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True)
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                           capture_output=True, text=True)
    return head.stdout.strip(), bool(dirty.stdout.strip())


def write_record(name: str, measures: str, command: str, figures: dict, packages=(), notes: str | None = None,
                 directory: Path = RESULTS_DIR) -> Path:
    """Write ``figures`` as the record ``NAME.json`` (replacing one of that name) and return its path.

    The commit, machine, versions (Python, rockbench and ``packages``), date and load average are
    filled in here. The write is atomic: an interrupted script leaves the old record whole.
    """
    commit, dirty = git_commit()
    rec = {"format": FORMAT, "name": name, "measures": measures, "command": command,
           "commit": commit, "commit_basis": "measured", "dirty": dirty, "machine": machine_info(),
           "versions": package_versions(packages),
           "date_utc": datetime.now(timezone.utc).isoformat(timespec="seconds").replace("+00:00", "Z"),
           "figures": figures}
    if hasattr(os, "getloadavg"):
        rec["load_average"] = " ".join(f"{x:.2f}" for x in os.getloadavg())
    if notes:
        rec["notes"] = notes
    bad = problems(rec, name)
    if bad:
        raise ValueError(f"record {name!r} is not valid: {'; '.join(bad)}")
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"{name}.json"
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(rec, indent=1, default=float, ensure_ascii=False) + "\n")
    tmp.replace(path)
    return path


# --- reading and checking ------------------------------------------------------------------------

def problems(rec, stem: str) -> list[str]:
    """What makes ``rec`` (read from ``STEM.json``) not a valid record; empty when it is one."""
    if not isinstance(rec, dict):
        return ["not a JSON object"]
    out = [f"missing {k!r}" for k in REQUIRED if k not in rec]
    out += [f"unknown field {k!r}" for k in rec if k not in REQUIRED + OPTIONAL]
    if rec.get("format", FORMAT) != FORMAT:
        out.append(f"format {rec['format']!r}, expected {FORMAT}")
    name = rec.get("name")
    if name is not None and (name != stem or not _NAME.match(name) or _DATE_IN_NAME.search(name)):
        out.append(f"name {name!r} must equal the file's stem {stem!r}: lower case, no date")
    for k in ("measures", "command"):
        if k in rec and not (isinstance(rec[k], str) and rec[k].strip()):
            out.append(f"{k!r} must be a non-empty string")
    if "commit" in rec and not (isinstance(rec["commit"], str) and _COMMIT.match(rec["commit"])):
        out.append(f"commit {rec['commit']!r} is not 7-40 hex digits")
    if "commit_basis" in rec and rec["commit_basis"] not in COMMIT_BASES:
        out.append(f"commit_basis {rec['commit_basis']!r} not one of {COMMIT_BASES}")
    m = rec.get("machine")
    if m is not None:
        if not isinstance(m, dict) or any(k not in m for k in MACHINE_KEYS):
            out.append(f"machine must have {', '.join(MACHINE_KEYS)}")
        elif not (isinstance(m["cores"], int) and m["cores"] > 0 and isinstance(m["cpu"], str)
                  and (m["memory_gib"] is None or isinstance(m["memory_gib"], (int, float)) and m["memory_gib"] > 0)
                  and (m["gpu"] is None or isinstance(m["gpu"], str))):
            out.append("machine: cores > 0 (int), cpu (text), memory_gib > 0 or null (not recorded), gpu (text or null)")
    v = rec.get("versions")
    if v is not None and not (isinstance(v, dict) and "python" in v and all(isinstance(x, str) for x in v.values())):
        out.append("versions must map package names to version strings, python included")
    if "date_utc" in rec and not (isinstance(rec["date_utc"], str) and _DATE.match(rec["date_utc"])):
        out.append(f"date_utc {rec['date_utc']!r} does not start with YYYY-MM-DD")
    if "figures" in rec and not (isinstance(rec["figures"], dict) and rec["figures"]):
        out.append("figures must be a non-empty JSON object")
    return out


def check(directory: Path = RESULTS_DIR) -> list[str]:
    """Every problem of the folder: files that are not records, and records with bad fields."""
    out = []
    for path in sorted(directory.iterdir()):
        if path.suffix != ".json":
            out.append(f"{path.name}: not a record (only NAME.json files belong here)")
            continue
        try:
            rec = json.loads(path.read_text())
        except (OSError, ValueError) as e:
            out.append(f"{path.name}: unreadable: {e}")
            continue
        out += [f"{path.name}: {p}" for p in problems(rec, path.stem)]
    return out


def load(name: str, directory: Path = RESULTS_DIR) -> dict:
    path = directory / f"{Path(name).stem}.json"
    if not path.is_file():
        raise FileNotFoundError(f"no record {name!r} in {directory}; `records.py list` shows them")
    return json.loads(path.read_text())


def machine_words(m: dict) -> str:
    memory = "memory not recorded" if m["memory_gib"] is None else f"{m['memory_gib']:g} GiB"
    words = f"{m['cores']} cores, {m['cpu']}, {memory}"
    return words + (f", {m['gpu']}" if m.get("gpu") else ", no GPU")


def show(rec: dict, full: bool = False) -> str:
    lines = [f"{rec['name']}: {rec['measures']}", "",
             f"command:  {rec['command']}",
             f"commit:   {rec['commit']} ({rec['commit_basis']}{', dirty' if rec.get('dirty') else ''})",
             f"machine:  {machine_words(rec['machine'])}",
             f"versions: {', '.join(f'{k} {v}' for k, v in rec['versions'].items())}",
             f"date:     {rec['date_utc']}"]
    if rec.get("load_average"):
        lines.append(f"load:     {rec['load_average']}")
    if rec.get("notes"):
        lines += ["", rec["notes"]]
    lines.append("")
    for key, value in rec["figures"].items():
        text = value if isinstance(value, str) else json.dumps(value, indent=1, ensure_ascii=False)
        if len(text) > SHOW_CHARS and not full:
            text = f"({len(text)} characters; --full prints them)"
        lines += [f"## {key}", text.rstrip(), ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="List, show and check the benchmark records in tests/measurements/results/.")
    sub = ap.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="one line per record: name, date, commit, machine")
    s = sub.add_parser("show", help="a record with its figures")
    s.add_argument("name")
    s.add_argument("--full", action="store_true", help="print long figures whole")
    sub.add_parser("check", help="exit 1 if a file in the folder is not a valid record")
    args = ap.parse_args(argv)
    if args.command == "check":
        bad = check()
        print("\n".join(bad) if bad else f"{len(list(RESULTS_DIR.glob('*.json')))} records, all valid")
        return 1 if bad else 0
    if args.command == "show":
        try:
            print(show(load(args.name), args.full))
        except FileNotFoundError as e:
            print(e, file=sys.stderr)
            return 2
        return 0
    for path in sorted(RESULTS_DIR.glob("*.json")):
        rec = json.loads(path.read_text())
        m = rec["machine"]
        print(f"{rec['name']:40} {rec['date_utc'][:10]}  {rec['commit'][:9]}  {m['cores']:>2} cores"
              f"{'  ' + m['gpu'] if m.get('gpu') else ''}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
