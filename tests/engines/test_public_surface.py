"""An adapter is its hooks and its declarations (issue 51): docs/engines.md lists the contact base's whole
public surface, and the list cannot drift from the code.

The section "An adapter's whole public surface" holds two tables: every public callable of
:class:`~rockbench.engines.contact.ContactEngine` (compared with ``dir``, and with the count the section
states), and the shared policy as functions of ``engines/calibration/`` that take the adapter (each one
must exist there, and none may be a method the base hands an adapter).
"""

from __future__ import annotations

import importlib
import inspect
import re
from pathlib import Path

from rockbench.engines.contact import ContactEngine

ROOT = Path(__file__).resolve().parents[2]
TITLE = "#### An adapter's whole public surface"


def public_callables(cls: type) -> set[str]:
    """The names of ``cls``'s public callables (methods and class methods)."""
    return {n for n in dir(cls) if not n.startswith("_") and callable(getattr(cls, n))}


def _section() -> str:
    text = (ROOT / "docs" / "engines.md").read_text(encoding="utf-8")
    start = text.index(TITLE)
    return text[start:text.index("\n### ", start)]


def _tables(section: str) -> list[list[str]]:
    """Each markdown table of ``section``: its body rows' second cells."""
    tables, rows = [], None
    for line in section.splitlines():
        if line.startswith("|---"):
            rows = []
            tables.append(rows)
        elif line.startswith("| ") and rows is not None:
            rows.append(line.split(" | ", 1)[1])
        elif not line.startswith("|"):
            rows = None
    return tables


def test_the_doc_lists_every_public_callable_of_the_contact_base_and_no_other():
    listed_table, _ = _tables(_section())
    listed = {n for cell in listed_table for n in re.findall(r"`([a-z_]+)`", cell)}
    code = public_callables(ContactEngine)
    assert listed == code, (f"docs/engines.md lists {sorted(listed - code)} that ContactEngine lacks and omits "
                            f"{sorted(code - listed)}")
    stated = re.search(r"`ContactEngine` has (\d+) public\s+callables", _section())
    assert stated and int(stated.group(1)) == len(code), f"the section states a count; the base has {len(code)}"


def test_the_policy_the_doc_names_is_functions_of_engines_calibration_not_methods():
    _, policy_table = _tables(_section())
    named = [m for cell in policy_table for m in re.findall(r"`(\w+)\.(\w+)\(", cell)]
    assert len(named) >= 9, named
    for module, name in named:
        fn = getattr(importlib.import_module(f"rockbench.engines.calibration.{module}"), name, None)
        assert inspect.isfunction(fn), f"docs/engines.md names {module}.{name}, which engines/calibration lacks"
        assert not hasattr(ContactEngine, name), f"{name} is a function of the adapter, not a method of the base"
