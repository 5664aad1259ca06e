"""Colour-vision deficiency simulation for the picture tests: how a colour, or a whole
rendered PNG, looks to a reader with protanopia, deuteranopia or tritanopia.

Machado, Oliveira & Fernandes (2009), "A physiologically-based model for simulation of color vision
deficiency", IEEE TVCG 15(6): the 3×3 matrices at severity 1.0, applied to linear RGB.
"""

from __future__ import annotations

import numpy as np

MATRICES = {
    "protanopia": np.array([[0.152286, 1.052583, -0.204868], [0.114503, 0.786281, 0.099216],
                            [-0.003882, -0.048116, 1.051998]]),
    "deuteranopia": np.array([[0.367322, 0.860646, -0.227968], [0.280085, 0.672501, 0.047413],
                              [-0.011820, 0.042940, 0.968881]]),
    "tritanopia": np.array([[1.255528, -0.076749, -0.178779], [-0.078411, 0.930809, 0.147602],
                            [0.004733, 0.691367, 0.303900]]),
}


def _to_linear(c):
    c = np.asarray(c, float)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _to_srgb(c):
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def hex_rgb(colour: str) -> np.ndarray:
    c = colour.lstrip("#")
    return np.array([int(c[k:k + 2], 16) for k in (0, 2, 4)], float) / 255.0


def simulate(rgb, kind: str) -> np.ndarray:
    """sRGB values in [0, 1] (any shape ending in 3) as seen with ``kind``."""
    lin = _to_linear(rgb)
    return _to_srgb(lin @ MATRICES[kind].T)


def lab(rgb) -> np.ndarray:
    """CIELAB (D65) of sRGB values in [0, 1]."""
    lin = _to_linear(rgb)
    m = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]])
    xyz = lin @ m.T / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])], -1)


def delta_e(c1: str, c2: str, kind: str | None = None) -> float:
    """CIE76 colour difference of two hex colours, as seen with ``kind`` (None: normal vision)."""
    a, b = hex_rgb(c1), hex_rgb(c2)
    if kind:
        a, b = simulate(a, kind), simulate(b, kind)
    return float(np.linalg.norm(lab(a) - lab(b)))


def simulate_png(src, dst, kind: str) -> None:
    """Write the PNG ``src`` as seen with ``kind`` to ``dst`` (to look at a rendered picture)."""
    from matplotlib import image
    img = image.imread(src)
    out = img.copy()
    out[..., :3] = simulate(img[..., :3], kind)
    image.imsave(dst, out)
