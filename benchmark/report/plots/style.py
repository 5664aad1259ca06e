"""The one palette and the print sizes of every rockbench picture.

Colours are Okabe & Ito's colour-blind-safe set ("Color Universal Design", 2008), the only hues
any picture uses besides black, greys and white. Every pair of hues that a picture sets side by
side was checked in the rendered PNGs under simulated deuteranopia, protanopia and tritanopia
(Machado, Oliveira & Fernandes 2009 matrices at full severity; ``tests/test_pictures.py`` does the
same on the palette itself): they stay apart in lightness or in hue. Marks never rely on colour
alone: each kind also has its own shape, line dash or outline.

Figures are drawn at a journal's column widths (85 mm single, 175 mm double), with no text below
:data:`MIN_FONT_PT`, so that the PDF and SVG go into a paper at 100 % and the PNG is sharp at
:data:`~rockbench.benchmark.report.plots.output.PNG_DPI`.
"""

from __future__ import annotations

#: Okabe–Ito colours by name.
OKABE_ITO = {"black": "#000000", "orange": "#E69F00", "sky_blue": "#56B4E9", "green": "#009E73",
             "yellow": "#F0E442", "blue": "#0072B2", "vermillion": "#D55E00", "purple": "#CC79A7"}

#: A cycle for curves of different runs (engines, maps): no black (the reference's), no yellow
#: (too light for a thin line on white); green and purple last, since under deuteranopia they come
#: close to the greys of the reference curves.
CYCLE = [OKABE_ITO[k] for k in ("orange", "blue", "vermillion", "sky_blue", "green", "purple")]

#: Journal column widths [in]: 85 mm and 175 mm.
SINGLE_COLUMN_IN = 85 / 25.4
DOUBLE_COLUMN_IN = 175 / 25.4

#: The smallest font of any picture at its printed size [pt].
MIN_FONT_PT = 7.0
#: Font sizes [pt]: tick labels and legends, axis labels, panel titles, figure titles.
SMALL_PT = 7.0
LABEL_PT = 7.5
TITLE_PT = 8.0
SUPTITLE_PT = 9.0


def tint(colour: str, strength: float) -> str:
    """``colour`` mixed with white: ``strength`` 1 is the colour, 0 is white (fills under lines)."""
    c = colour.lstrip("#")
    rgb = [int(c[k:k + 2], 16) for k in (0, 2, 4)]
    return "#" + "".join(f"{round(255 - strength * (255 - v)):02x}" for v in rgb)
