"""The hooks an adapter implements, declared where the base class calls them.

A base class declares each hook it calls with :func:`required`: the declaration is a method that
raises :class:`MissingHook` with one line saying what to implement (and, where there is one, the
alternative), so an adapter that leaves a hook out fails with that line, not with an empty
``NotImplementedError``. :func:`missing_hooks` lists those lines for an adapter before anything
runs (``rockbench check-adapter`` prints them, one per hook).
"""

from __future__ import annotations

import functools
from typing import Callable

__all__ = ["MissingHook", "required", "missing_hooks", "hook_line"]


class MissingHook(NotImplementedError):
    """A hook the base class calls that the adapter does not implement; the message says what to do."""


def hook_line(cls: type, name: str, signature: str, advice: str) -> str:
    """What to do about a missing hook, in one line."""
    return f"{cls.__name__}: implement {name}{signature}: {advice}"


def required(signature: str, advice: str, *, when: Callable | None = None):
    """Declare a hook an adapter must implement.

    Parameters
    ----------
    signature : str
        The hook's parameters and what it returns, as the docs write them, e.g.
        ``"(block, s, dt_s) -> world"``.
    advice : str
        What the hook does, and the alternative where there is one.
    when : callable, optional
        ``when(adapter) -> bool``: the hook is needed only where this holds (e.g. an engine that
        offers a contact along the base); default always.
    """

    def declare(fn):
        @functools.wraps(fn)
        def stub(self, *args, **kwargs):
            raise MissingHook(hook_line(type(self), fn.__name__, signature, advice))

        stub.required_hook = (signature, advice, when)
        return stub

    return declare


def missing_hooks(adapter) -> list[str]:
    """One line per declared hook that ``adapter``'s class leaves to the declaration (and that its
    settings need), saying what to implement."""
    cls = type(adapter)
    out = []
    # in the order the base classes declare them, the most basic first
    names = dict.fromkeys(n for klass in reversed(cls.__mro__) for n in vars(klass))
    for name in names:
        declared = getattr(getattr(cls, name, None), "required_hook", None)
        if declared is None:
            continue
        signature, advice, when = declared
        if when is None or when(adapter):
            out.append(hook_line(cls, name, signature, advice))
    return out
