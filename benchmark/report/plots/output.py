"""Writing a figure to files: PNG for screens, SVG and PDF for print.

One place decides how every picture of rockbench leaves matplotlib:

- PNG at :data:`PNG_DPI` (print quality; the HTML report scales it to the page width);
- SVG with its text as ``<text>`` elements (``svg.fonttype = none``), so a journal's editor can
  still edit and search the words;
- PDF with TrueType fonts embedded as fonts (``pdf.fonttype = 42``), not as outlines.

The figures themselves are drawn at a journal's column widths (:mod:`.style`), so their fonts keep
their point sizes in print. The format names and their parser need no matplotlib, so the command
line can check ``--figure-format`` before anything runs.
"""

from __future__ import annotations

import io
from pathlib import Path

from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.store.atomic import write_atomic

#: The formats a figure can be written in, by file suffix.
FORMATS = ("png", "svg", "pdf")

#: Resolution of every PNG [dots per inch]: a journal asks for 300 dpi for line art with grey fills.
PNG_DPI = 300

#: matplotlib settings while saving: text stays text in SVG, fonts are embedded as TrueType in PDF.
_SAVE_RC = {"svg.fonttype": "none", "pdf.fonttype": 42, "ps.fonttype": 42}


def parse_formats(text, option: str = "--figure-format") -> tuple[str, ...]:
    """``"png,svg"`` into ``("png", "svg")`` (order kept, repeats dropped); ConfigError otherwise."""
    if isinstance(text, (list, tuple)):
        text = ",".join(str(t) for t in text)
    names = [t.strip().lower().lstrip(".") for t in str(text or "").split(",") if t.strip()]
    if not names:
        raise ConfigError(f"{option} takes one or more of {', '.join(FORMATS)} separated by commas, got {text!r}.")
    bad = [n for n in names if n not in FORMATS]
    if bad:
        raise ConfigError(f"{option} takes one or more of {', '.join(FORMATS)} separated by commas, "
                          f"got {bad[0]!r}; e.g. {option} png,pdf.")
    return tuple(dict.fromkeys(names))


def format_of(path, option: str) -> str:
    """The figure format a file name asks for by its suffix; ConfigError for any other suffix."""
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in FORMATS:
        raise ConfigError(f"{option} must name a .png, .svg or .pdf file, got {str(path)!r}.")
    return suffix


def save_figure(fig, path, fmt: str | None = None) -> Path:
    """Write ``fig`` to ``path`` (atomically) in ``fmt`` (default: the path's suffix)."""
    import matplotlib  # matplotlib on first drawing (start-up time)


    path = Path(path)
    fmt = fmt or format_of(path, "figure path")

    def write(tmp):
        with matplotlib.rc_context(_SAVE_RC):
            fig.savefig(tmp, format=fmt, dpi=PNG_DPI, metadata=_metadata(fmt))

    return write_atomic(path, write)


def save_formats(fig, stem, formats=("png",)) -> list[Path]:
    """Write ``fig`` as ``stem.<format>`` for each of ``formats``; returns the paths in that order."""
    stem = Path(stem)
    return [save_figure(fig, stem.with_name(f"{stem.name}.{fmt}"), fmt) for fmt in formats]


def figure_bytes(fig, fmt: str = "png") -> bytes:
    """``fig`` as the bytes of a file in ``fmt`` (for the report's embedded pictures)."""
    import matplotlib  # matplotlib on first drawing (start-up time)

    buf = io.BytesIO()
    with matplotlib.rc_context(_SAVE_RC):
        fig.savefig(buf, format=fmt, dpi=PNG_DPI, metadata=_metadata(fmt))
    return buf.getvalue()


def _metadata(fmt: str) -> dict:
    # no creation date in SVG/PDF, so that the same figure gives the same bytes
    if fmt == "pdf":
        return {"Creator": "rockbench", "CreationDate": None}
    if fmt == "svg":
        return {"Creator": "rockbench", "Date": None}
    return {"Software": "rockbench"}
