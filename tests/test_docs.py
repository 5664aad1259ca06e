"""Every code example of the README and docs/ runs as a test.

- Python blocks run, in order, in one namespace per file, in a fresh folder.
- CSV blocks load as shaking-table outcomes; JSON blocks parse (a block with ``...`` is a schematic
  of a document's layout, and is checked to be one).
- Shell blocks (``bash``, ``console``, ``sh``) and the ``run:`` lines of YAML blocks: every
  ``rockbench`` command is parsed by the real command line (unknown commands or options fail), its
  engine must be registered, and the cheap ones run for real: ``blocks``, ``engines``, reference
  ``simulate`` and ``map``, ``check-adapter reference``, ``run`` (as ``run --plan``: the suite and
  its options are checked without computing it). Engine maps, calibrations and scoring of maps
  the examples did not compute are parsed only (minutes each; the engine tests cover them).
- ``python tests/measurements/X.py`` lines: the script exists and its ``--help`` works.
- Pip and git lines are setup, not examples, and are skipped. A block with no language tag fails:
  every example says what it is.
"""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
FILES = [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md"))
FENCE = re.compile(r"^```([\w-]*)[^\n]*\n(.*?)^```", re.S | re.M)
SHELL = {"bash", "console", "sh", "shell"}
#: subcommands run for real (when their engine is the reference)
CHEAP = {"blocks", "engines", "simulate", "map", "check-adapter", "run"}


def blocks(path: Path):
    return [(m.group(1).lower(), m.group(2)) for m in FENCE.finditer(path.read_text())]


def _ids(paths):
    return [p.relative_to(ROOT).as_posix() for p in paths]


def shell_commands(text: str) -> list[str]:
    """Command lines of a shell block: prompts stripped, continuations joined, comments dropped."""
    out, cur = [], ""
    for line in text.splitlines():
        line = line.rstrip()
        if line.startswith("$ "):
            line = line[2:]
        if line.endswith("\\"):
            cur += line[:-1] + " "
            continue
        line = cur + line
        cur = ""
        if line.strip() and not line.lstrip().startswith("#"):
            out.append(line.strip())
    return out


def _argv(cmd: str) -> list[str]:
    argv = shlex.split(cmd, comments=True)
    # a pipe or redirection ends the command
    for k, a in enumerate(argv):
        if a in ("|", ">", ">>", "&&"):
            return argv[:k]
    return argv


def _rockbench(argv: list[str], tmp: Path, capsys) -> None:
    from rockbench.benchmark.cli.main import build_parser, main
    from rockbench.engines.registry import names

    args = build_parser().parse_args(argv)       # unknown commands and options raise SystemExit
    engine = getattr(args, "engine", None) or "reference"
    assert engine in names(), f"unknown engine {engine!r} in {' '.join(argv)}"
    if args.command not in CHEAP or engine != "reference":
        return
    if args.command == "check-adapter" and argv[-1] != "reference":
        return
    if args.command == "run":
        argv = argv + ["--plan"]
    if args.command == "map" and "--serial" not in argv:
        argv = argv + ["--serial"]
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 0, f"`rockbench {' '.join(argv)}` exited {code}: {err[-800:]}"


def _run_shell(cmds: list[str], tmp: Path, capsys) -> int:
    n = 0
    for cmd in cmds:
        argv = _argv(cmd)
        if not argv:
            continue
        exe = Path(argv[0]).name
        if exe == "rockbench":
            _rockbench(argv[1:], tmp, capsys)
            n += 1
        elif exe.startswith("python") and len(argv) > 1 and argv[1].startswith("tests/measurements/"):
            script = ROOT / argv[1]
            assert script.is_file(), f"{argv[1]} does not exist"
            r = subprocess.run([sys.executable, str(script), "--help"], capture_output=True, text=True, timeout=300,
                               cwd=tmp)
            assert r.returncode == 0, f"{argv[1]} --help: {r.stderr[-800:]}"
            n += 1
        elif exe.startswith("python") and "-m" in argv and "pytest" in argv:
            n += 1                                   # the test command: this is it running
        elif exe in ("pip", "git", "sudo", "apt-get", "cd", "export", "ls", "mkdir", "cp") or exe.startswith("python3"):
            continue                                 # setup
        elif ".venv/bin/" in argv[0] or argv[0].startswith(".venv"):
            continue                                 # setup through the project's venv
        else:
            raise AssertionError(f"an example runs {argv[0]!r}, which this test does not know how to check")
    return n


@pytest.mark.parametrize("path", FILES, ids=_ids(FILES))
def test_every_code_example_runs(write_map, band, path, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    _fake_run_folder(tmp_path, write_map, band)
    ns: dict = {"__name__": "__docs__"}
    checked = 0
    for lang, text in blocks(path):
        if lang == "python":
            exec(compile(text, f"{path.name}:python", "exec"), ns)
        elif lang == "csv":
            from rockbench.benchmark.blocks.experiments import parse_outcomes
            assert parse_outcomes(text, name=path.name)
        elif lang == "json":
            if "..." in text:
                assert re.search(r'"\.\.\."|\.\.\.[\]}]|, \.\.\.', text), "a schematic marks its gaps with ..."
            else:
                json.loads(text)
        elif lang in SHELL:
            checked += _run_shell(shell_commands(text), tmp_path, capsys)
        elif lang == "yaml":
            cmds = [m.group(1) for m in re.finditer(r"-\s*run:\s*(.+)", text)]
            checked += _run_shell(cmds, tmp_path, capsys)
        elif lang == "toml":
            import tomllib
            tomllib.loads(text)
        elif lang in ("", "text"):
            assert lang == "text", f"{path.name}: a code block without a language tag; say what it is"
        else:
            raise AssertionError(f"{path.name}: no check for ```{lang} blocks")
        checked += 1
    assert checked or not blocks(path)


def _fake_run_folder(tmp: Path, write_map, band) -> None:
    """``rockbench-results/quick`` as `rockbench run --quick` would leave it (small hand-made maps,
    scored), for the examples that read a finished run."""
    sys.path.insert(0, str(Path(__file__).parent))

    from rockbench.benchmark.store.files import write_json
    from rockbench.benchmark.scoring.score_runs import score_dirs
    root = tmp / "rockbench-results" / "quick"
    write_map(root / "maps" / "reference" / "B3M-sine-housner", band(9, 11, 4), block="B3M")
    write_map(root / "maps" / "mujoco-settings=calibrated" / "B3M-sine-housner", band(9, 11, 5), engine="mujoco",
              block="B3M", settings={"settings": "calibrated"})
    write_json(root / "score.json", score_dirs([root / "maps"]).to_json())


def test_the_notebook_example_is_ten_lines():
    text = (ROOT / "docs" / "notebook.md").read_text()
    first = blocks(ROOT / "docs" / "notebook.md")[0]
    assert first[0] == "python" and "## Ten lines" in text
    lines = [ln for ln in first[1].splitlines() if ln.strip()]
    assert len(lines) <= 10 and any("stability_map" in ln for ln in lines)


def test_no_document_points_at_files_a_user_does_not_have():
    for path in FILES:
        text = path.read_text()
        assert "../shared/" not in text and "shared/CLI.md" not in text and "shared/STYLE.md" not in text, path.name
        for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", text):
            if "://" in target:
                continue
            assert (path.parent / target).exists(), f"{path.name} links to {target}, which does not exist"


def test_every_cited_section_of_physics_md_exists():
    """Code, tests and docs cite the physics by section ("docs/physics.md §7"): each § they name exists."""
    sections = set(re.findall(r"^## (\d+)\. ", (ROOT / "docs" / "physics.md").read_text(), re.M))
    cited = {}
    for folder in ("reference_solver", "engines", "benchmark", "tests", "docs"):
        for path in (ROOT / folder).rglob("*"):
            if path.suffix in (".py", ".md", ".toml") and path.is_file():
                for n in re.findall(r"physics\.md[^§\n]{0,3}§(\d+)", path.read_text(errors="replace")):
                    cited.setdefault(n, path.relative_to(ROOT).as_posix())
    assert cited, "no citation of docs/physics.md found"
    missing = {n: where for n, where in cited.items() if n not in sections}
    assert not missing, f"docs/physics.md has no section(s) {missing} cited there"


#: a commit hash as git abbreviates it: 7 to 40 lowercase hex digits with at least one digit and one letter
COMMIT_LIKE = re.compile(r"\b(?=[0-9a-f]*[0-9])(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}\b")
#: an ISO date, 2026-11-29
ISO_DATE = re.compile(r"\b(?:19|20)\d\d-[01]\d-[0-3]\d\b")


def prose_lines(text: str):
    """``(line number, line)`` of a page's prose: every line outside fenced code blocks and outside its
    records tables.

    A *records table* is a Markdown table (consecutive lines starting with ``|``) whose header row (its
    first line) has a column headed ``record`` or ``records`` (case-insensitive, any text after it, e.g.
    ``record (tests/measurements/results/)``). Its rows name the stored records a page rests on, and they
    alone may carry the commit and the date a record was made at."""
    lines = text.splitlines()
    fence = in_records = False
    for n, line in enumerate(lines, 1):
        if line.startswith("```"):
            fence = not fence
            continue
        if fence:
            continue
        if line.startswith("|"):
            if n == 1 or not lines[n - 2].startswith("|"):           # a table's header row
                heads = [c.strip().strip("`*").lower() for c in line.strip().strip("|").split("|")]
                in_records = any(re.match(r"records?\b", h) for h in heads)
            if in_records:
                continue
        yield n, line


def test_prose_lines_skip_records_tables_and_code_only():
    text = ("prose 2026-11-29\n\n| engine | record |\n|---|---|\n| mujoco | `x` at c1353c0, 2026-11-23 |\n\n"
            "| engine | when |\n|---|---|\n| mujoco | c1353c0 |\n```text\nabc1234 2026-01-01\n```\n")
    found = [n for n, line in prose_lines(text) if COMMIT_LIKE.search(line) or ISO_DATE.search(line)]
    assert found == [1, 9]


@pytest.mark.parametrize("path", sorted((ROOT / "docs").glob("*.md")), ids=_ids(sorted((ROOT / "docs").glob("*.md"))))
def test_docs_prose_names_no_commit_and_no_date(path):
    """Docs state today's rules: a commit or a date belongs in CHANGELOG.md or in a records table."""
    bad = [f"{path.name}:{n}: {m.group(0)}" for n, line in prose_lines(path.read_text())
           for m in (*COMMIT_LIKE.finditer(line), *ISO_DATE.finditer(line))]
    assert not bad, ("a commit hash or a date in docs prose (move the story to CHANGELOG.md, or the record "
                     "to the page's records table): " + "; ".join(bad))


def test_check_counts_in_docs_are_the_checkers():
    """A count of `check-adapter`'s checks drifts as checks are added: the docs give none, except the
    example report's last line, which is tested against the checker."""
    from rockbench.engines.checker import CHECKS
    for path in sorted((ROOT / "docs").glob("*.md")):
        text = path.read_text()
        assert not re.search(r"check-adapter[^.\n]{0,40}pass(es|ed)? (all )?\d+ |pass(es)? all \d+ checks", text), \
            f"{path.name}: a count of check-adapter's checks (say 'passes every check')"
        for passed, total, skipped in re.findall(r"(\d+) of (\d+) checks passed(?:; (\d+) skipped)?", text):
            assert passed == total and int(total) + int(skipped or 0) == len(CHECKS), \
                f"{path.name}: '{passed} of {total} checks passed', but check-adapter runs {len(CHECKS)}"


def _engines_md_section(title: str) -> str:
    text = (ROOT / "docs" / "engines.md").read_text()
    start = text.index(title)
    return text[start:text.index("\n## ", start + 1)]


def _shown_value(cell: str):
    """A default as the shared settings' table shows it: `calibrated`, `true`, none, 10."""
    cell = cell.strip().strip("`")
    return {"true": True, "false": False, "none": None}.get(cell, cell if not re.fullmatch(r"[\d.]+", cell)
                                                               else float(cell))


def test_the_shared_settings_table_gives_the_codes_defaults():
    """docs/engines.md lists each shared setting's default: the code's (`SHARED_SETTINGS`, the loop's
    segment, the base's `contact`)."""
    from rockbench.engines.contact import SHARED_SETTINGS
    from rockbench.engines.loop import DEFAULT_SEGMENT_S
    section = _engines_md_section("## The contact engines' base")
    shown = {}
    for keys, values in re.findall(r"^\| (`[a-z_]+`(?:, `[a-z_]+`)*) \| ([^|]+) \|", section, re.M):
        for key, value in zip(re.findall(r"`([a-z_]+)`", keys), values.split(",")):
            shown[key] = _shown_value(value)
    assert {k: shown[k] for k in SHARED_SETTINGS} == dict(SHARED_SETTINGS)
    assert shown["segment_s"] == DEFAULT_SEGMENT_S and shown["contact"] == "auto"


def test_no_adapter_has_a_setting_a_suite_takes_for_its_own():
    """docs/engines.md: a suite variant's `restitution`, `engines` and `blocks` are the suite's, so an
    adapter's setting of that name could never be set from a suite; a contact's restitution is
    `contact_restitution`."""
    from rockbench.benchmark.suites.plan import variant_settings
    from rockbench.engines.registry import BUILTIN, adapter_class
    suite_keys = {"restitution", "engines", "blocks"}
    assert variant_settings({k: 1 for k in suite_keys}) == {}
    assert all(f"`{k}`" in _engines_md_section("## The contact engines' base") for k in suite_keys)
    for name in BUILTIN:
        assert not suite_keys & set(adapter_class(name).SETTINGS), name


def test_the_block_table_names_every_field_of_block():
    import dataclasses
    from rockbench.reference_solver.model import Block
    section = _engines_md_section("## The contract in one page")
    for f in dataclasses.fields(Block):
        assert f"`{f.name}`" in section, f"docs/engines.md's Block table omits {f.name}"


def test_the_porting_table_names_modules_that_exist_now_and_did_then():
    """Contract 2's column names modules this rockbench has; contract 1's, modules it does not."""
    section = _engines_md_section("## Porting an adapter to contract 2")
    old_new = [line.split(" | ")[:2] for line in section.splitlines() if line.startswith("| ") and " | " in line]
    module = re.compile(r"\brockbench(?:\.\w+)+")
    old = {m for o, _ in old_new for m in module.findall(o)}
    new = {m for _, n in old_new for m in module.findall(n)}
    assert "rockbench.engines.knobs" in old and "rockbench.engines.calibration.knobs" in new
    for name in new:
        assert _importable(name), f"{name}: contract 2's column names what this rockbench does not have"
    for name in old:
        assert not _importable(name), f"{name}: contract 1's column names what this rockbench still has"


def _importable(dotted: str) -> bool:
    """Whether ``dotted`` is a module, or an attribute of one, here."""
    import importlib
    parts = dotted.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ImportError:
            continue
        for attr in parts[k:]:
            if not hasattr(obj, attr):
                return False
            obj = getattr(obj, attr)
        return True
    return False


def test_the_conformance_table_lists_every_check_the_checker_runs():
    from rockbench.engines.checker import CHECKS
    text = (ROOT / "docs" / "engines.md").read_text()
    start = text.index("### The conformance checks")
    section = text[start:text.index("\n## ", start)]
    listed = [name for row in re.findall(r"^\| (`[a-z-]+`(?:, `[a-z-]+`)*) \|", section, re.M)
              for name in re.findall(r"`([a-z-]+)`", row)]
    assert listed == list(CHECKS), "docs/engines.md's table of checks is not the checker's CHECKS, in order"
