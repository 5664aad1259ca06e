"""A plugin declares the engine contract it is written to; one written to another is refused in one line.

Issue 45 reported a third-party PhysX plugin written from docs/engines.md of contract 1: its
``_calibrate_corners`` called the base's ``_search``, and after the contract changed it failed 12 of
15 conformance checks with an ``AttributeError`` and ``rockbench calibrate`` exited 70. Reproduced
here as installed packages (a ``.dist-info`` with an entry point on the path, as pip leaves one):
every way such a plugin can meet this rockbench ends in one line naming what changed and the docs
section that says how to port it, exit 2 (never 70, never a traceback).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

from rockbench.engines import CONTRACT_VERSION
from rockbench.engines.registry import BUILTIN, PORTING, adapter_class, contract_refusal

#: the plugin as its author wrote it last week, against contract 1 (its skeleton, its ``_search``)
LAST_WEEK = '''
from rockbench.engines.skeleton import Motion, SteppedContactAdapter, pivot_pose


class SapienAdapter(SteppedContactAdapter):
    name = "sapien_old"
    module = "json"
    SETTINGS = {**SteppedContactAdapter.SHARED_SETTINGS, "substeps": None}
    CALIBRATED_SETTINGS = ("substeps",)

    def _calibrate_corners(self, block, target, dt, use_cache):
        return self._search(block, target, dt, use_cache)
'''

#: the same plugin moved onto contract 2's base, hooks and all, but not ported (nor declared)
HALF_PORTED = '''
from rockbench.engines.contact import ContactEngine


class SapienAdapter(ContactEngine):
    name = "sapien_half"
    module = "json"
    SHIPPED = {"substeps": 1}

    def _world(self, block, s, dt_s):
        return {}

    def _calibrate_corners(self, block, target, dt, use_cache):
        return self._search(block, target, dt, use_cache)
'''

#: a plugin that declares a contract this rockbench does not know
FROM_THE_FUTURE = '''
from rockbench.engines.contact import ContactEngine


class SapienAdapter(ContactEngine):
    CONTRACT_VERSION = 99
    name = "sapien_new"
    module = "json"
'''


def _install(root, name: str, source: str):
    """A package ``name`` holding ``source``, with an installed distribution's entry point naming it."""
    (root / f"{name}.py").write_text(textwrap.dedent(source))
    dist = root / f"{name}-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text(f"[rockbench.engines]\n{name} = {name}:SapienAdapter\n")


@pytest.fixture(scope="module")
def plugins(tmp_path_factory):
    root = tmp_path_factory.mktemp("plugins")
    for name, source in (("sapien_old", LAST_WEEK), ("sapien_half", HALF_PORTED), ("sapien_new", FROM_THE_FUTURE)):
        _install(root, name, source)
    return root


def _rockbench(root, *args):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(root), os.environ.get("PYTHONPATH")) if p)}
    return subprocess.run([sys.executable, "-m", "rockbench.benchmark", *args], env=env, capture_output=True,
                          text=True, timeout=300)


@pytest.mark.parametrize("engine, said", [
    ("sapien_old", "imports rockbench.engines.skeleton"),
    ("sapien_half", "declares no CONTRACT_VERSION; it defines _calibrate_corners, _world, contract 1's"),
    ("sapien_new", "declares CONTRACT_VERSION = 99, an engine contract this rockbench does not know"),
])
@pytest.mark.parametrize("command", [("check-adapter",), ("calibrate", "--block", "B3M", "--target", "housner")])
def test_a_plugin_written_to_another_contract_is_refused_in_one_line(plugins, engine, said, command):
    args = [command[0], engine, *command[1:]] if command[0] == "check-adapter" else [command[0], "--engine", engine,
                                                                                      *command[1:]]
    out = _rockbench(plugins, *args)
    assert out.returncode == 2, out.stdout + out.stderr
    assert out.stdout == "" and out.stderr.count("\n") == 1, out.stderr
    assert said in out.stderr and PORTING in out.stderr and "Traceback" not in out.stderr
    assert "AttributeError" not in out.stderr


def test_engines_lists_such_a_plugin_as_not_available_with_the_line(plugins):
    out = _rockbench(plugins, "engines")
    assert out.returncode == 0, out.stderr
    rows = {ln.split()[0]: ln for ln in out.stdout.splitlines()[1:]}
    for name in ("sapien_old", "sapien_half", "sapien_new"):
        assert rows[name].split()[1] == "no" and PORTING in rows[name], rows[name]


def test_check_adapter_given_an_instance_of_an_old_contract_fails_its_first_check_only():
    from rockbench.engines.checker import check_adapter
    from rockbench.engines.contact import ContactEngine

    class Old(ContactEngine):   # no CONTRACT_VERSION: contract 1
        name = "old"
        SETTINGS = {"settings": "shipped"}

        def _world(self, block, s, dt_s):
            return {}

    rep = check_adapter(Old())
    assert [c.name for c in rep.checks] == ["contract"] and not rep.passed and len(rep.not_run) == 15
    assert "written to engine contract 1" in rep.checks[0].detail and "_world" in rep.checks[0].detail


def test_every_builtin_adapter_is_written_to_this_contract():
    from rockbench.engines import contract

    assert contract.CONTRACT_VERSION == CONTRACT_VERSION == 2
    assert all(contract_refusal(adapter_class(name)) is None for name in BUILTIN)


def test_the_porting_section_the_refusal_names_exists():
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[1] / "docs" / "engines.md").read_text(encoding="utf-8")
    anchor = PORTING.split("#", 1)[1]
    headings = {"-".join(ln.lstrip("#").strip().lower().replace(",", "").replace(":", "").split())
                for ln in doc.splitlines() if ln.startswith("#")}
    assert anchor in headings, anchor
