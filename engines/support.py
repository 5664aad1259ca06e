"""The engine versions rockbench supports, and whether the installed ones are among them.

The ranges live in one place: ``pyproject.toml``'s optional dependencies (``[mujoco]``, ``[pybullet]``,
``[exudyn]``, ``[warp]``, ``[drake]``), whose lower bounds are the lowest versions the engine tests
pass with (``.ci/floors`` keeps them true). Here they are read back from the installed rockbench's
metadata (``importlib.metadata.requires``), so `rockbench engines`, `check-adapter` and the
"engine cannot simulate" line of `run` and `map` name the range the install was made with. Run
from a source tree without an install, no range is known and nothing is said. An engine of another
package (a plugin) declares its range on its adapter class, ``SUPPORTED_VERSIONS = {distribution:
specifier}``; the functions here take an engine's name or its adapter class, and read a plugin's
range from the class.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, requires, version

#: the Python distributions each built-in engine is, in the order they are named
DISTRIBUTIONS: dict[str, tuple[str, ...]] = {
    "mujoco": ("mujoco",),
    "pybullet": ("pybullet",),
    "exudyn": ("exudyn",),
    "mujoco_warp": ("mujoco-warp", "warp-lang"),
    "drake": ("drake",),
    "dart": ("dartpy",),
    "newton": ("newton", "warp-lang"),
    "genesis": ("genesis-world", "torch"),
    "physx": ("sapien",),
}

#: the extra of pyproject.toml that installs each engine
EXTRAS = {"mujoco": "mujoco", "pybullet": "pybullet", "exudyn": "exudyn", "mujoco_warp": "warp", "drake": "drake",
          "dart": "dart", "newton": "newton", "genesis": "genesis",
          "physx": "physx"}


#: what must be installed before an engine's extra, where pip would otherwise pull the wrong thing
#: (Genesis: torch's CPU wheel, or pip pulls a multi-GB CUDA torch)
PREREQUISITES = {"genesis": "pip install torch --index-url https://download.pytorch.org/whl/cpu"}


def install_command(engine: str) -> str:
    """The shell command that installs a built-in engine, e.g. ``pip install 'rockbench[dart]'``
    (its prerequisite first, joined by ``&&``); "" for an engine rockbench does not ship."""
    extra = EXTRAS.get(engine)
    if extra is None:
        return ""
    cmd = f"pip install 'rockbench[{extra}]'"
    return f"{PREREQUISITES[engine]} && {cmd}" if engine in PREREQUISITES else cmd


def _canonical(name: str) -> str:
    return name.lower().replace("_", "-").replace(".", "-")


def _name(engine) -> str:
    return engine if isinstance(engine, str) else engine.name


def _distributions(engine) -> tuple[str, ...]:
    """The distributions ``engine`` (a name or an adapter class) is: a built-in's, else those its class
    declares in ``SUPPORTED_VERSIONS``."""
    return DISTRIBUTIONS.get(_name(engine)) or tuple(getattr(engine, "SUPPORTED_VERSIONS", {}))


def _declared_for(engine) -> dict[str, str]:
    """``{canonical distribution: specifier}`` declared for ``engine``: a built-in's extra, else its
    class's ``SUPPORTED_VERSIONS`` ({} for a name rockbench does not ship)."""
    extra = EXTRAS.get(_name(engine))
    if extra is not None:
        return _declared(extra)
    return {_canonical(d): str(spec) for d, spec in getattr(engine, "SUPPORTED_VERSIONS", {}).items()}


def _declared(extra: str) -> dict[str, str]:
    """``{distribution: specifier}`` that rockbench's extra ``extra`` declares ({} without an install)."""
    from packaging.requirements import InvalidRequirement, Requirement   # on first use (start-up time: ~40 ms)

    try:
        reqs = requires("rockbench") or []
    except PackageNotFoundError:
        return {}
    out = {}
    for text in reqs:
        try:
            req = Requirement(text)
        except InvalidRequirement:
            continue
        if req.marker is not None and req.marker.evaluate({"extra": extra}) and str(req.specifier) \
                and not req.marker.evaluate({"extra": ""}):
            out[_canonical(req.name)] = str(req.specifier)
    return out


def supported_range(engine: str | type) -> str:
    """The supported versions of ``engine``'s distributions, e.g. ``"mujoco>=3.3"`` (several joined by
    " and "); "" where no range is declared (the reference, a plugin without ``SUPPORTED_VERSIONS``)."""
    declared = _declared_for(engine)
    parts = [f"{d}{declared[_canonical(d)]}" for d in _distributions(engine) if _canonical(d) in declared]
    return " and ".join(parts)


#: ``{(lookup, distribution): installed version or None}``: each distribution's version read once per
#: process (``importlib.metadata`` scans the installed packages' metadata, milliseconds a read, and a
#: calibrated cell's step asks for it). An engine upgraded inside a running process is not a case
#: rockbench supports: such a process keeps the version it read first. Keyed by the lookup function
#: too, so that a replaced ``version`` (a test's) is asked afresh.
_VERSIONS: dict = {}


def _installed(d: str) -> str | None:
    """The installed version of distribution ``d``, None where it is not installed (read once, :data:`_VERSIONS`)."""
    key = (version, d)
    if key not in _VERSIONS:
        try:
            _VERSIONS[key] = version(d)
        except PackageNotFoundError:
            _VERSIONS[key] = None
    return _VERSIONS[key]


def installed_versions(engine: str | type) -> dict[str, str]:
    """``{distribution: installed version}`` of ``engine``'s distributions that are installed."""
    return {d: v for d in _distributions(engine) if (v := _installed(d)) is not None}


def installed_label(engine: str | type) -> str:
    """The installed versions as one phrase, e.g. ``"mujoco 3.2.0"``; "" when none is known."""
    return ", ".join(f"{d} {v}" for d, v in installed_versions(engine).items())


def version_label(engine: str) -> str:
    """The engine's version for run.json and labels: its first distribution's version, then the others in
    parentheses, e.g. ``"1.8.0 (warp-lang 1.19.0)"``; "unknown" when the first is not installed."""
    v = installed_versions(engine)
    first, *others = DISTRIBUTIONS[engine]
    if first not in v:
        return "unknown"
    rest = ", ".join(f"{d} {v[d]}" for d in others if d in v)
    return f"{v[first]} ({rest})" if rest else v[first]


def outside_range(engine: str | type) -> str | None:
    """One phrase when an installed distribution of ``engine`` is outside the supported range, e.g.
    ``"mujoco 3.2.0 is outside the supported range mujoco>=3.3"``; None when every installed one is
    inside it, or nothing is known."""
    from packaging.specifiers import SpecifierSet   # on first use (start-up time: the registry imports this module)
    from packaging.version import InvalidVersion, Version   # on first use (start-up time)

    declared = _declared_for(engine)
    bad = []
    for d, v in installed_versions(engine).items():
        spec = declared.get(_canonical(d))
        if not spec:
            continue
        try:
            inside = SpecifierSet(spec).contains(Version(v), prereleases=True)
        except InvalidVersion:
            continue
        if not inside:
            bad.append(f"{d} {v}")
    if not bad:
        return None
    return f"{', '.join(bad)} {'is' if len(bad) == 1 else 'are'} outside the supported range {supported_range(engine)}"


def install_advice(engine: str | type) -> str:
    """How to get a supported version, e.g. ``"pip install 'mujoco>=3.3'"``; "" when no range is known."""
    rng = supported_range(engine)
    return "pip install " + " ".join(f"'{r}'" for r in rng.split(" and ")) if rng else ""
