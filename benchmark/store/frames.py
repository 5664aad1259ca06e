"""Rows of cells as a tidy ``pandas.DataFrame`` or an ``xarray.Dataset``.

pandas and xarray are optional (``pip install 'rockbench[notebook]'``); only these two converters
need them.
"""

from __future__ import annotations

import importlib

import numpy as np

from rockbench.reference_solver.errors import ConfigError



def cell_text(v) -> str:
    """A value as the full-grid table writes it: ``true``/``false``, empty for None, else ``str``."""
    if isinstance(v, bool):
        return "true" if v else "false"
    return "" if v is None else str(v)


_FLOAT = ("eta", "w_ratio", "a_ratio", "omega_rad_s", "amplitude_mps2", "max_abs_theta_rad", "wall_s", "t_overturn_s",
          "t_uplift_s", "min_normal_mg", "max_friction_ratio")


def need(module: str):
    """The optional module ``module`` (pandas, xarray), or an ImportError saying how to install it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise ImportError(f"this needs {module}: pip install 'rockbench[notebook]' (pandas and xarray)") from None


def rows_to_dataframe(rows: list[dict]):
    """A tidy ``pandas.DataFrame`` of full-grid rows: numbers as floats, ``outcome`` categorical
    (:data:`OUTCOME_CATEGORIES`), ``valid``, ``filled`` and ``left_model`` boolean, ``flags`` a
    string (``;``-separated), ``n_impacts`` a nullable integer (missing for filled cells)."""
    pd = need("pandas")
    df = pd.DataFrame(rows)
    if df.empty:
        return df
    for c in _FLOAT:
        if c in df:
            df[c] = pd.to_numeric(df[c].replace("", np.nan), errors="coerce").astype(float)
    for c in ("i", "j"):
        df[c] = pd.to_numeric(df[c]).astype(int)
    df["n_impacts"] = pd.to_numeric(df["n_impacts"].replace("", np.nan), errors="coerce").astype("Int64")
    df.loc[df["filled"].astype(bool), "n_impacts"] = pd.NA
    for c in ("valid", "filled", "left_model"):
        df[c] = df[c].map(lambda v: v if isinstance(v, bool) else str(v).strip().lower() in ("true", "1")).astype(bool)
    status = df["status"].astype(str)
    out = df["outcome"].astype(str).where(df["outcome"].astype(str) != "", np.where(status == "missing", "missing",
                                                                                      "failed"))
    df["outcome"] = pd.Categorical(out, categories=list(OUTCOME_CATEGORIES))
    for c in ("engine", "variant", "block", "pulse", "restitution"):
        df[c] = df[c].astype("category")
    return df


def rows_to_dataset(rows: list[dict]):
    """An ``xarray.Dataset`` of one map's full-grid rows on dims ``(a_ratio, w_ratio)``.

    Coordinates ``w_ratio`` (ω/p), ``a_ratio`` (a₀/(g·tanα)), ``omega_rad_s`` and ``amplitude_mps2``;
    variables ``outcome`` (text), ``outcome_code`` (int8 with CF ``flag_values``/``flag_meanings``:
    -2 missing, -1 failed, 0 rest, 1 rocking, 2 overturn), ``valid``, ``filled``, ``left_model``,
    ``n_impacts`` (-1 where unknown), ``max_abs_theta_rad``, ``t_overturn_s``, ``min_normal_mg``,
    ``max_friction_ratio``, ``wall_s``; the map's engine, variant, block, pulse, restitution and η
    as attributes.
    """
    xr = need("xarray")
    df = rows_to_dataframe(rows)
    if df.empty:
        raise ConfigError("the map has no cells yet; let `rockbench map` finish (rerun it to resume).")
    keys = {c: df[c].astype(str).unique() for c in ("engine", "variant", "block", "pulse", "restitution")}
    if any(len(v) > 1 for v in keys.values()):
        raise ConfigError("a Dataset holds one map; these rows mix several (use the DataFrame, or one map each).")
    ni, nj = int(df["i"].max()) + 1, int(df["j"].max()) + 1
    if len(df) != ni * nj:
        raise ConfigError(f"the rows do not cover the {ni}×{nj} grid ({len(df)} rows); write the full grid first.")
    df = df.sort_values(["i", "j"])

    def grid(col, fill=np.nan, dtype=float):
        v = df[col]
        if hasattr(v, "to_numpy"):
            v = v.to_numpy(dtype=dtype, na_value=fill) if dtype is not bool else v.to_numpy(dtype=bool)
        return np.asarray(v).reshape(ni, nj)

    codes = {name: code for code, name in OUTCOME_OF_CODE.items()}
    oc = np.array([codes[str(x)] for x in df["outcome"]], dtype=np.int8).reshape(ni, nj)
    w = df["w_ratio"].to_numpy()[:nj]
    a = df["a_ratio"].to_numpy()[::nj]
    dims = ("a_ratio", "w_ratio")
    ds = xr.Dataset(
        {"outcome": (dims, np.asarray(df["outcome"].astype(str)).reshape(ni, nj)),
         "outcome_code": (dims, oc, {"flag_values": [-2, -1, 0, 1, 2],
                                     "flag_meanings": "missing failed rest rocking overturn"}),
         "valid": (dims, grid("valid", dtype=bool)), "filled": (dims, grid("filled", dtype=bool)),
         "left_model": (dims, grid("left_model", dtype=bool)),
         "n_impacts": (dims, grid("n_impacts", -1, np.int64)),
         "max_abs_theta_rad": (dims, grid("max_abs_theta_rad"), {"units": "rad"}),
         "t_overturn_s": (dims, grid("t_overturn_s"), {"units": "s"}),
         "min_normal_mg": (dims, grid("min_normal_mg"), {"long_name": "min N/(m·g) the rigid model needs"}),
         "max_friction_ratio": (dims, grid("max_friction_ratio"), {"long_name": "max |F|/N the rigid model needs"}),
         "wall_s": (dims, grid("wall_s"), {"units": "s"})},
        coords={"w_ratio": ("w_ratio", w, {"long_name": "ω/p", "units": "1"}),
                "a_ratio": ("a_ratio", a, {"long_name": "a₀/(g·tanα)", "units": "1"}),
                "omega_rad_s": ("w_ratio", df["omega_rad_s"].to_numpy()[:nj], {"units": "rad/s"}),
                "amplitude_mps2": ("a_ratio", df["amplitude_mps2"].to_numpy()[::nj], {"units": "m/s^2"})},
        attrs={**{k: str(v[0]) for k, v in keys.items()}, "eta": float(df["eta"].iloc[0])})
    return ds


#: Outcome categories of a cell, in order (``failed``: the simulation gave no outcome;
#: ``missing``: neither simulated nor inferred, an unfinished run).
OUTCOME_CATEGORIES = ("rest", "rocking", "overturn", "failed", "missing")


OUTCOME_OF_CODE = {0: "rest", 1: "rocking", 2: "overturn", -1: "failed", -2: "missing"}
