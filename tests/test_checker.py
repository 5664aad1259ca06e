"""The adapter conformance suite and the engines/check-adapter commands."""

import json

import pytest

from rockbench.benchmark.cli.main import main
from rockbench.engines.checker import check_adapter
from rockbench.engines.contact import ContactEngine


pytestmark = pytest.mark.usefixtures("fake_engines")


def test_a_conforming_adapter_passes():
    rep = check_adapter("analytic")
    assert rep.passed, rep.text()
    assert len(rep.checks) >= 10


def test_a_wrong_adapter_fails_with_a_clear_report(fake_engines):
    rep = check_adapter(fake_engines.WrongAdapter())
    assert not rep.passed
    failed = {c.name for c in rep.failed}
    assert {"units", "determinism", "no-uplift-below-threshold"} <= failed
    text = rep.text()
    assert "FAIL  units" in text and "degrees instead of radians" in text and "checks passed;" in text


def test_check_adapter_cli_exit_codes(capsys):
    assert main(["check-adapter", "analytic", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["passed"] and out["n_failed"] == 0
    assert main(["check-adapter", "wrong"]) == 1
    assert "FAIL" in capsys.readouterr().out
    assert main(["check-adapter", "no-such-engine"]) == 2
    assert "unknown engine" in capsys.readouterr().err


def test_check_adapter_unavailable_engine_exit_3(capsys):
    from rockbench.engines import registry
    registry.register("ghost", "no_such_module_xyz:Adapter")
    try:
        assert main(["check-adapter", "ghost"]) == 3
    finally:
        registry.unregister("ghost")
    assert capsys.readouterr().err.count("\n") == 1


def test_engines_command(capsys):
    assert main(["engines", "--json"]) == 0
    rows = {r["engine"]: r for r in json.loads(capsys.readouterr().out)}
    assert rows["analytic"]["available"] and rows["analytic"]["version"]
    for r in rows.values():
        assert set(r) >= {"engine", "available", "version", "reason"}
        assert r["available"] or r["reason"]
    assert main(["engines"]) == 0
    assert "analytic" in capsys.readouterr().out


def test_engines_command_says_in_one_short_line_what_is_missing_and_the_install_command(capsys):
    from rockbench.engines import registry

    registry.register("ghost", "no_such_module_xyz:Adapter")
    try:
        assert main(["engines"]) == 0
    finally:
        registry.unregister("ghost")
    line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("ghost"))
    assert line.split()[1] == "no" and line.endswith("cannot import no_such_module_xyz")
    assert "not available" not in line and len(line.rsplit("  ", 1)[-1]) < 60   # the note alone


def test_a_missing_builtin_engine_names_its_install_command():
    from rockbench.engines.support import install_command

    assert install_command("dart") == "pip install 'rockbench[dart]'"
    assert install_command("genesis").startswith("pip install torch --index-url")
    assert install_command("genesis").endswith("&& pip install 'rockbench[genesis]'")
    assert install_command("reference") == ""


def test_number_setting_checks_and_converts_for_every_adapter():
    import math

    import pytest

    from rockbench.engines.contract import EngineAdapter
    from rockbench.reference_solver.errors import ConfigError

    class Probe(EngineAdapter):
        name = "probe"
        SETTINGS = {"k": None, "d": 0, "t": 1, "e": 0.0}

        def validate(self, s):
            self.number_setting(s, "k", "N/m")
            self.number_setting(s, "d", "N s/m", allow_zero=True, allow_none=False)
            self.number_setting(s, "t", "s", allow_none=False)
            # a plastic material's restitution ships as 0: allow_zero, and a bound
            self.number_setting(s, "e", allow_zero=True, maximum=1.0)

    p = Probe(t="2.5")
    assert p.settings == {"k": None, "d": 0.0, "t": 2.5, "e": 0.0}
    for bad, match in [({"k": 0}, r"'k' must be a finite number > 0 \[N/m\], got 0"),
                       ({"d": -1}, r"'d' must be a finite number >= 0 \[N s/m\], got -1"),
                       ({"d": None}, r"'d' must be a finite number >= 0 \[N s/m\], got None"),
                       ({"t": math.inf}, r"probe setting 't' must be a finite number > 0 \[s\]"),
                       ({"t": "x"}, r"'t' must be a finite number > 0 \[s\], got 'x'"),
                       ({"t": True}, r"'t' must be a finite number > 0 \[s\], got True"),
                       ({"e": 1.5}, r"'e' must be a finite number >= 0 and <= 1, got 1.5")]:
        with pytest.raises(ConfigError, match=match):
            Probe(**bad)


def test_whole_setting_checks_and_converts_for_every_adapter():
    """The same arguments as number_setting (a unit third, shown in the message): a unit given is no
    TypeError, and every bad value one ConfigError line."""
    import math

    import pytest

    from rockbench.engines.contract import EngineAdapter
    from rockbench.reference_solver.errors import ConfigError

    class Probe(EngineAdapter):
        name = "probe"
        SETTINGS = {"n": None, "m": 3}

        def validate(self, s):
            self.whole_setting(s, "n")
            self.whole_setting(s, "m", "steps", minimum=1, allow_none=False)

    p = Probe(n=4.0)
    assert p.settings == {"n": 4, "m": 3} and isinstance(p.settings["n"], int)
    for bad in ({"n": -1}, {"n": 2.5}, {"n": True}, {"n": "4"}, {"n": math.nan}, {"n": math.inf},
                {"m": 0}, {"m": None}):
        key, value = next(iter(bad.items()))
        bound = 0 if key == "n" else 1
        with pytest.raises(ConfigError, match=rf"probe setting '{key}' must be a whole number >= {bound}"):
            Probe(**bad)

    class Positional(EngineAdapter):   # contract 1's _whole_setting(s, key, minimum): the bound third
        name = "positional"
        SETTINGS = {"n": 3}

        def validate(self, s):
            self.whole_setting(s, "n", 1)

    with pytest.raises(TypeError, match=r"whole_setting's third argument is the unit, .*\(minimum=, maximum=\)"):
        Positional()


def test_each_check_is_a_public_function_that_runs_alone(fake_engines):
    from rockbench.engines import checker

    ok = fake_engines.AnalyticAdapter()
    wrong = fake_engines.WrongAdapter()
    assert list(checker.CHECKS) == [c.name for c in check_adapter(ok).checks]
    for name, check in checker.CHECKS.items():
        assert check.__name__ == "check_" + name.replace("-", "_") and getattr(checker, check.__name__) is check
        if name in ("drive", "planar"):   # the modes of a contact engine: skipped, saying why
            with pytest.raises(checker.CheckSkipped, match=f"no '{name}' setting"):
                check(ok)
            continue
        assert isinstance(check(ok), str)   # a passing check returns what it saw
    with pytest.raises(checker.CheckFailed, match="degrees instead of radians"):
        checker.check_units(wrong)
    res = checker.run_check("determinism", checker.check_determinism, wrong)
    assert not res.passed and "differ" in res.detail


def test_registry_refuses_a_class_that_is_not_an_adapter():
    from rockbench.engines import registry
    from rockbench.reference_solver.errors import ConfigError

    registry.register("not-an-adapter", dict)
    registry.register("no-such-class", "rockbench.engines.contract:NoSuchAdapter")
    try:
        with pytest.raises(ConfigError, match="not a subclass of rockbench.engines.contract.EngineAdapter"):
            registry.adapter_class("not-an-adapter")
        with pytest.raises(ConfigError, match="has no 'NoSuchAdapter'"):
            registry.adapter_class("no-such-class")
        assert registry.registered()["not-an-adapter"] == "builtins:dict"
    finally:
        registry.unregister("not-an-adapter")
        registry.unregister("no-such-class")


def test_batching_is_declared(fake_engines):
    from rockbench.engines.contract import EngineAdapter

    assert fake_engines.BatchAnalyticAdapter.batching == "native" and fake_engines.AnalyticAdapter.batching == "none"
    with pytest.raises(TypeError, match="batching must be"):
        class Bad(EngineAdapter):
            batching = "sometimes"


def test_a_supported_version_range_that_pip_cannot_read_fails_where_it_is_declared():
    from rockbench.engines.contract import EngineAdapter

    with pytest.raises(TypeError, match=r"Ranged.SUPPORTED_VERSIONS\['myengine'\] = '=>2' is not a version specifier"):
        class Ranged(EngineAdapter):
            SUPPORTED_VERSIONS = {"myengine": "=>2"}


class HalfDone(ContactEngine):
    """A contact engine that builds its scene and implements nothing else."""

    CONTRACT_VERSION = 2
    name = "half-done"
    SHIPPED = {"stiffness_n_m": None}

    def build(self, block, s, dt_s):
        return {}


def test_a_missing_hook_is_named_with_what_to_do_one_line_each(capsys):
    from rockbench.engines import registry
    from rockbench.engines.hooks import MissingHook

    cls = HalfDone
    rep = check_adapter(cls())
    assert not rep.passed and [c.name for c in rep.checks] == ["contract", "hooks"] and len(rep.not_run) == 14
    lines = rep.checks[1].detail.split("\n")
    assert [ln.split("(")[0].split(":")[1].strip() for ln in lines] == [
        f"implement {h}" for h in ("start", "advance", "read", "KNOBS")]
    assert "--set settings=shipped" in lines[-1] and "declare KNOBS" in lines[-1]
    # as shipped, nothing is calibrated: no knobs needed
    shipped = check_adapter(cls(settings="shipped")).checks[1].detail
    assert "KNOBS" not in shipped and shipped.count("\n") == 2
    # the declaration raises the same line, not an empty NotImplementedError
    with pytest.raises(MissingHook, match=r"HalfDone: implement advance\(scene, n_from, n_to\)"):
        cls().advance(None, 0, 1)
    registry.register("half-done", cls)
    try:
        assert main(["check-adapter", "half-done"]) == 1
    finally:
        registry.unregister("half-done")
    out = capsys.readouterr().out
    assert "FAIL  hooks" in out and out.count("HalfDone: implement") == 4 and "14 checks not run" in out


def test_every_builtin_adapter_implements_every_hook_it_needs():
    from rockbench.engines.registry import BUILTIN, adapter_class

    for name in BUILTIN:
        cls = adapter_class(name)
        modes = ("calibrated", "shipped") if "settings" in cls.SETTINGS else (None,)
        for mode in modes:
            ad = cls() if mode is None else cls(settings=mode)
            assert ad.missing_hooks() == [], (name, mode)


def test_an_entry_point_named_otherwise_than_its_class_is_refused_in_one_line(tmp_path, monkeypatch, capsys):
    """One name per engine: the entry point's name must be the adapter class's ``name`` (a tiny
    installed distribution whose entry point names the reference's class ``alias``)."""
    from rockbench.engines import registry
    from rockbench.reference_solver.errors import ConfigError

    dist = tmp_path / "alias_plugin-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: alias-plugin\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text("[rockbench.engines]\nalias = rockbench.engines.adapters.reference:ReferenceAdapter\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert "alias" in registry.names()
    line = ("engine 'alias': its adapter rockbench.engines.adapters.reference:ReferenceAdapter has name = 'reference'; "
            "an engine has one name: set the class's name = 'alias', or register it as 'reference'.")
    with pytest.raises(ConfigError) as e:
        registry.adapter_class("alias")
    assert str(e.value) == line
    a = registry.availability("alias")
    assert not a["available"] and a["reason"] == line and a["missing"] == ""
    assert main(["check-adapter", "alias"]) == 2
    assert capsys.readouterr().err == f"rockbench: error: {line}\n"
    assert main(["engines"]) == 0
    row = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("alias "))
    assert row.split()[1] == "no" and row.endswith(line)


def test_the_modes_an_adapter_runs_are_declared_refused_before_anything_runs_and_skipped_by_the_checks():
    pytest.importorskip("dartpy")
    from rockbench.engines import checker
    from rockbench.engines.adapters.dart import DartAdapter
    from rockbench.reference_solver.errors import ConfigError

    class InertialDart(DartAdapter):   # DART, declared to run the inertial drive only
        SUPPORTED_MODES = {"drive": ("inertial",)}

    with pytest.raises(ConfigError, match=r"^dart does not run drive = table \(its SUPPORTED_MODES\): use drive = "
                       r"inertial, or an engine that runs it"):
        InertialDart(drive="table")
    assert InertialDart(planar=False).settings["planar"] is False   # a key left out: every value
    with pytest.raises(checker.CheckSkipped, match=r"supports drive = inertial only \(SUPPORTED_MODES\): drive = "
                       "table not checked"):
        checker.check_drive(InertialDart(settings="shipped"))
    # every built-in contact engine runs both drives: the check runs the table drive and compares
    assert checker.check_drive(DartAdapter(settings="shipped")).startswith("drive = table: rocking, max |θ|")
    with pytest.raises(TypeError, match=r"SUPPORTED_MODES\['drive'\] = \('table',\)"):
        class TableOnly(DartAdapter):   # its default drive, inertial, left out
            SUPPORTED_MODES = {"drive": ("table",)}
    with pytest.raises(TypeError, match=r"SUPPORTED_MODES\['contact'\]"):
        class Other(DartAdapter):       # only drive and planar are modes
            SUPPORTED_MODES = {"contact": ("corners",)}


def test_check_adapter_at_a_given_step(capsys):
    """``--dt`` runs every check at that step: twice as many samples at half the step (the reference solver
    samples every step)."""
    detail = {}
    for dt_s in (2e-3, 1e-3):
        rep = check_adapter("reference", dt_s=dt_s)
        assert rep.passed, rep.text()
        detail[dt_s] = next(c.detail for c in rep.checks if c.name == "trajectory-shape")
    n_coarse, n_fine = (int(detail[dt].split()[0]) for dt in (2e-3, 1e-3))
    assert 1.8 * n_coarse < n_fine < 2.2 * n_coarse, detail
    assert main(["check-adapter", "reference", "--dt", "0.002"]) == 0
    assert "checks passed" in capsys.readouterr().out
    assert main(["check-adapter", "analytic", "--dt", "-1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--dt" in err and "\n" not in err
