"""Trajectories from other codes: a file (CSV or Parquet) or a DataFrame of a case's
observables, read, checked and turned into what the one scoring pipeline
(:mod:`.pipeline`) scores — a history and its impact records — so that an Exudyn, Siconos,
Chrono or MATLAB result is held to the same truth, over the same trusted span, with the same
measures as a daebench run.

**What a file holds.** A time column ``t`` [s] and any of the case's observables, named and
in the units the model declares (``daebench show CASE`` lists them); optionally the energy
terms ``E`` or ``E_<term>`` [J], the work ``W_<effect>`` [J] and the impact losses
``D_impacts`` [J] (the energy balance is then scored), and the constraint residuals ``C``,
``Cdot``, ``Cddot``. Times never decrease; an event-driven code writes two rows at an
impact (before and after, the same t): they are the two sides of the jump, as an exact
reference holds them, and at most two rows share a time. The file spans the case: from
t ≥ 0 to the case's t_end.

**Metadata.** A CSV file may start with comment lines ``# key: value``; a Parquet file
carries the same keys in its schema metadata; a DataFrame in ``df.attrs``. Read:
``label`` (the row's name), ``cost_s`` (the external run's cost [s], its work–precision
abscissa), ``steps`` (its step count); every other key (``code: Exudyn 1.13.6``,
``method: generalized-alpha``) is kept in the row's ``settings`` as provenance.

**Events.** The event sequence comes from an impacts table (columns ``t`` and optionally
``contact``; :func:`read_impacts`), else from the ``gap`` observable (an impact where the
gap closes: :func:`gap_events`), else — for a case with contacts — from the repeated times
of an event-driven file (contact unknown), else there is none (the row's message says so
when the case has contacts).

**Refusals.** Every problem is a :class:`ExternalDataError` (a ParamError: exit 2 at the
command line) that names the column, row or value and the fix, raised before anything is
written: no ``t``, an unknown name (did you mean…), no observable of the case, non-numbers,
NaN or inf, decreasing times, more than two rows at one time, times outside [0, t_end], a
file that is not CSV or Parquet or is larger than :data:`MAX_BYTES`, and — once the truth is
known — a column whose values are the truth's scaled by a unit factor (θ in rad where the
case declares deg: :func:`check_units`).

May import: :mod:`daebench.harness.running`, the scoring modules and the layers below the
harness (as every scoring module).
"""

from __future__ import annotations

import math
import os
import stat
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np
import pandas as pd

from daebench.core.observables import Observables
from daebench.core.params import ParamError, did_you_mean
from daebench.harness.scoring import metrics
from daebench.harness.scoring.eventseq import ANY

#: the largest file read [bytes]; a larger one is refused before it is opened
MAX_BYTES = 512 * 2 ** 20
#: file suffixes read, and the format each names
SUFFIXES = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}
PARQUET_MAGIC = b"PAR1"
#: times closer than this × max(1, t_end) [s] count as equal (the ends of the case's span)
TIME_TOL = 1e-9
#: columns besides the observables: the energy balance and the constraint residuals
ENERGY_COLUMNS = ("E", "D_impacts")
ENERGY_PREFIXES = ("E_", "W_")
RESIDUAL_COLUMNS = ("C", "Cdot", "Cddot")
#: metadata keys read (every other key is provenance, kept as text)
META_KEYS = ("label", "cost_s", "steps")
#: a gap at or below this × the file's largest |gap| is closed (an event-driven code writes 0
#: at the impact, a capturing one a small penetration)
GAP_CLOSED = 1e-9
#: unit factors told apart (the truth ÷ the file's values), with what they most likely mean
UNIT_FACTORS = ((180.0 / math.pi, "radians where the case declares degrees"),
                (math.pi / 180.0, "degrees where the case declares radians"),
                (1e-3, "a unit 1000× smaller (mm for m, mm/s for m/s, ms for s)"),
                (1e3, "a unit 1000× larger (km for m, kN for N)"),
                (1e-2, "a unit 100× smaller (cm for m)"),
                (-1.0, "the opposite sign convention"))
UNIT_FACTOR_RTOL = 0.02   # the fitted ratio within this of a factor …
UNIT_FIT_RTOL = 0.05      # … and the scaled values within this of the truth (RMS, relative): a unit error
UNIT_RAW_RTOL = 0.5       # … while the values as given are this far from it


#: read CSV numbers exactly: pandas 3 does by default (and deprecates the option), pandas 2 when asked
_EXACT_CSV = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}


class ExternalDataError(ParamError):
    """External data that cannot be scored; the message names the problem and the fix."""


@dataclass(frozen=True)
class ExternalImpact:
    """One impact of an external trajectory, as the measures read an impact record
    (:class:`daebench.core.contact.Impact`): its time, contact (:data:`ANY` when unknown) and
    episode; it carries no state, so the exact impact oracle and the energy per impact skip it."""

    t: float
    contact: int = ANY
    t_end: float = math.nan
    closed: bool = False
    min_gap: float = math.nan
    energy_loss: float = math.nan
    q: Any = None
    v_minus: Any = None
    v_plus: Any = None


@dataclass(frozen=True)
class ExternalData:
    """A checked external trajectory: its history (``t``, observables, energy terms), impact
    records, where the events came from, its metadata and what it is (``source``)."""

    history: pd.DataFrame
    impacts: tuple[ExternalImpact, ...]
    events_from: str
    meta: Mapping[str, Any] = field(default_factory=dict)
    source: str = "DataFrame"
    notes: tuple[str, ...] = ()

    @property
    def label(self) -> str:
        return str(self.meta.get("label") or "external")

    @property
    def cost_s(self) -> float:
        return float(self.meta.get("cost_s", math.nan))

    @property
    def steps(self) -> float:
        return float(self.meta.get("steps", math.nan))

    def provenance(self) -> dict[str, Any]:
        """What the row's ``settings`` say about it: the source, the event source and every
        metadata key that is not the label, cost or step count."""
        extra = {k: v for k, v in self.meta.items() if k not in META_KEYS}
        return {"source": self.source, "events": self.events_from, **extra}


# -- reading ------------------------------------------------------------------------------------
def _format_of(path: Path, what: str) -> str:
    """'csv' or 'parquet' from the file's suffix and first bytes; refused otherwise."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise ExternalDataError(f"{what} '{path}' cannot be read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ExternalDataError(f"{what} '{path}' is not a regular file; give a .csv or .parquet file")
    if st.st_size > MAX_BYTES:
        raise ExternalDataError(f"{what} '{path}' is {st.st_size / 2 ** 20:.0f} MiB, more than the "
                                f"{MAX_BYTES / 2 ** 20:.0f} MiB read; write fewer output times (the case's "
                                f"output.dt is enough) or only the observables scored")
    fmt = SUFFIXES.get(path.suffix.lower())
    if fmt is None:
        raise ExternalDataError(f"{what} '{path}' is neither CSV nor Parquet (suffix '{path.suffix}'); write a "
                                f".csv or .parquet file, e.g. pandas' df.to_csv(path, index=False)")
    with open(path, "rb") as fh:
        head = fh.read(4096)
    is_parquet = head.startswith(PARQUET_MAGIC)
    if fmt == "parquet" and not is_parquet:
        raise ExternalDataError(f"{what} '{path}' is named {path.suffix} but is not a Parquet file")
    if fmt == "csv" and (is_parquet or b"\x00" in head):
        raise ExternalDataError(f"{what} '{path}' is named .csv but is not a text file"
                                + (" (it is a Parquet file: name it .parquet)" if is_parquet else ""))
    return fmt


def _csv_metadata(path: Path) -> dict[str, str]:
    """``# key: value`` lines at the top of a CSV file (other comment lines are skipped)."""
    meta: dict[str, str] = {}
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            if not line.startswith("#"):
                break
            key, sep, value = line[1:].partition(":")
            if sep and key.strip():
                meta[key.strip()] = value.strip()
    return meta


def read_table(data: str | os.PathLike | pd.DataFrame, what: str = "the data file"
               ) -> tuple[pd.DataFrame, dict[str, Any], str]:
    """(table, metadata, source) of a path to a CSV or Parquet file, or of a DataFrame
    (metadata: its ``attrs``). CSV numbers are read exactly (round trip).

    Raises
    ------
    ExternalDataError
        Not a regular file, not CSV/Parquet, over :data:`MAX_BYTES`, unreadable.
    """
    if isinstance(data, pd.DataFrame):
        return data.copy(), dict(data.attrs), "DataFrame"
    if not isinstance(data, (str, os.PathLike)) or not str(data).strip():
        raise ExternalDataError(f"{what} must be a path to a .csv or .parquet file or a pandas DataFrame; "
                                f"got {data!r}")
    path = Path(data)
    fmt = _format_of(path, what)
    try:
        if fmt == "csv":
            meta: dict[str, Any] = _csv_metadata(path)
            df = pd.read_csv(path, comment="#", skipinitialspace=True, **_EXACT_CSV)
        else:
            import pyarrow.parquet as pq  # lazy: only a Parquet file needs its schema's metadata

            raw = pq.read_schema(path).metadata or {}
            meta = {k.decode(errors="replace"): v.decode(errors="replace") for k, v in raw.items()
                    if not k.startswith(b"pandas") and not k.startswith(b"ARROW")}
            df = pd.read_parquet(path)
    except (ValueError, OSError, UnicodeDecodeError, pd.errors.ParserError) as exc:
        raise ExternalDataError(f"{what} '{path}' cannot be read as {fmt.upper()}: {exc}") from None
    except Exception as exc:  # pyarrow's own errors for a damaged file
        raise ExternalDataError(f"{what} '{path}' cannot be read as {fmt.upper()}: "
                                f"{type(exc).__name__}: {exc}") from None
    return df, meta, str(path)


# -- checking -----------------------------------------------------------------------------------
def metadata(meta: Mapping[str, Any], overrides: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The metadata with ``overrides`` (the command line's --label, --cost-s, --steps) applied
    and ``label``, ``cost_s`` (> 0 [s]) and ``steps`` (a positive integer) checked."""
    out = {str(k): v for k, v in meta.items()}
    out.update({k: v for k, v in (overrides or {}).items() if v is not None})
    if "cost_s" in out:
        try:
            c = float(out["cost_s"])
        except (TypeError, ValueError):
            c = math.nan
        if not (math.isfinite(c) and c > 0.0):
            raise ExternalDataError(f"the cost (cost_s) must be a positive number of seconds, got {out['cost_s']!r}")
        out["cost_s"] = c
    if "steps" in out:
        try:
            n = float(out["steps"])
        except (TypeError, ValueError):
            n = math.nan
        if not (math.isfinite(n) and n >= 1 and n == int(n)):
            raise ExternalDataError(f"the step count (steps) must be a positive integer, got {out['steps']!r}")
        out["steps"] = int(n)
    if "label" in out:
        label = str(out["label"]).strip()
        if not label or len(label) > 80 or any(c in label for c in "/\\\n\r\t") or label.startswith("."):
            raise ExternalDataError(f"the label {out['label']!r} cannot name a row: use up to 80 characters "
                                    f"without '/', '\\' or a leading '.', e.g. --label exudyn-genalpha")
        out["label"] = label
    return out


def accepted_columns(system: Any, declared: Observables) -> list[str]:
    """The observable columns of a model: its history's (``system.observables`` at the start)
    and those it declares."""
    q0, v0 = system.initial_state()
    names = list(system.observables(0.0, np.asarray(q0, float), np.asarray(v0, float)))
    return list(dict.fromkeys(names + [o.name for o in declared.declared]))


def _is_energy(c: str) -> bool:
    return c in ENERGY_COLUMNS or c.startswith(ENERGY_PREFIXES)


def _numeric(df: pd.DataFrame, what: str) -> pd.DataFrame:
    """Every column as float64; a column of non-numbers is refused (its first bad cell named)."""
    out = {}
    for c in df.columns:
        col = df[c]
        if pd.api.types.is_bool_dtype(col) or not pd.api.types.is_numeric_dtype(col):
            num = pd.to_numeric(col, errors="coerce")
            bad = num.isna() & col.notna()
            if bad.any() or pd.api.types.is_bool_dtype(col):
                k = int(np.flatnonzero(bad.to_numpy())[0]) if bad.any() else 0
                raise ExternalDataError(f"{what}: column '{c}' holds something other than numbers (row {k + 1}: "
                                        f"{col.iloc[k]!r}); write plain numbers with '.' as the decimal point")
            col = num
        out[str(c)] = col.to_numpy(dtype=float)
    return pd.DataFrame(out)


def _check_finite(df: pd.DataFrame, what: str) -> None:
    for c in df.columns:
        v = df[c].to_numpy(float)
        bad = ~np.isfinite(v)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            where = f" (t = {df['t'].iloc[k]:.9g} s)" if c != "t" and "t" in df.columns else ""
            raise ExternalDataError(f"{what}: column '{c}' is {v[k]} in row {k + 1}{where}"
                                    + (f" and {int(bad.sum()) - 1} more rows" if bad.sum() > 1 else "")
                                    + "; a scored trajectory has finite values only (cut the file where the "
                                      "external run stopped and score a shorter case: --set t_end=…)")


def check_times(t: np.ndarray, t_end: float, what: str, whole_span: bool = True) -> None:
    """Times that never decrease, at most two rows per time, inside [0, t_end] and (with
    ``whole_span``) reaching t_end."""
    tol = TIME_TOL * max(1.0, abs(t_end))
    d = np.diff(t)
    if (d < 0).any():
        k = int(np.flatnonzero(d < 0)[0])
        raise ExternalDataError(f"{what}: the times decrease at row {k + 2} (t = {t[k + 1]:.12g} s after "
                                f"{t[k]:.12g} s); sort the rows by t (two rows with one time are an impact's "
                                f"two sides)")
    same = d == 0
    if (same[:-1] & same[1:]).any():
        k = int(np.flatnonzero(same[:-1] & same[1:])[0])
        raise ExternalDataError(f"{what}: three or more rows at t = {t[k]:.12g} s (rows {k + 1}–{k + 3}); at an "
                                f"impact write two rows, before and after, and no more")
    if t[0] < -tol or t[-1] > t_end + tol:
        bad = t[0] if t[0] < -tol else t[-1]
        raise ExternalDataError(f"{what}: t = {bad:.12g} s lies outside the case's span [0, {t_end:g}] s; "
                                f"write times in [0, t_end] only (or score another span: --set t_end=…)")
    if whole_span and t[-1] < t_end - tol:
        raise ExternalDataError(f"{what}: the data end at t = {t[-1]:.12g} s, before the case's t_end = {t_end:g} s; "
                                f"give the whole span, or score the case over what the file covers "
                                f"(--set t_end={t[-1]:.12g})")


def check_history(df: pd.DataFrame, t_end: float, observables: Sequence[str], scored: Sequence[str],
                  what: str = "the data") -> pd.DataFrame:
    """``df`` checked as an external history of a case whose observable columns are
    ``observables`` (``scored``: those its scene scores): returned as float columns, ``E`` added
    as the sum of the ``E_<term>`` columns when only those are given.

    Raises
    ------
    ExternalDataError
    """
    cols = [str(c) for c in df.columns]
    known = list(observables) + list(ENERGY_COLUMNS) + list(RESIDUAL_COLUMNS)
    if "t" not in cols:
        guess = next((c for c in cols if c.strip().lower() in ("t", "time", "time_s", "t_s", "t [s]", "time [s]")),
                     None)
        hint = f"; the column '{guess}' looks like it: name it 't'" if guess else ""
        raise ExternalDataError(f"{what} has no time column 't' (columns: {', '.join(cols) or 'none'}){hint}. "
                                f"Write the times in seconds in a column named t")
    twice = sorted({c for c in cols if cols.count(c) > 1})
    if twice:
        raise ExternalDataError(f"{what} has the column '{twice[0]}' twice; keep one")
    unknown = [c for c in cols if c != "t" and c not in known and not _is_energy(c)]
    if unknown:
        c = unknown[0]
        raise ExternalDataError(f"{what}: unknown column '{c}'{did_you_mean(c, [*observables, 't'])} The case's "
                                f"observables are {', '.join(observables)} (names and units: `daebench show CASE`); "
                                f"energy terms E, E_<term>, W_<effect>, D_impacts; residuals C, Cdot, Cddot")
    if not any(c in observables for c in cols):
        raise ExternalDataError(f"{what} holds no observable of the case (columns: {', '.join(cols)}); give at least "
                                f"one of {', '.join(scored or observables)}")
    if len(df) < 2:
        raise ExternalDataError(f"{what} has {len(df)} row(s); a trajectory needs at least two output times")
    out = _numeric(df, what)
    _check_finite(out, what)
    check_times(out["t"].to_numpy(float), t_end, what)
    terms = [c for c in out.columns if c.startswith("E_")]
    if "E" not in out.columns and terms:
        out["E"] = out[terms].sum(axis=1)
    return out


# -- events -------------------------------------------------------------------------------------
def gap_events(t: np.ndarray, gap: np.ndarray, contact: int = 0) -> list[ExternalImpact]:
    """Impacts from a gap series: an episode is a run of rows whose gap is closed (≤
    :data:`GAP_CLOSED` × max |gap|) after an open row; it starts where the gap crosses zero
    (linear between the open row and the first closed one; at that row when its gap is 0, as an
    event-driven code writes it) and ends at its last closed row (an instantaneous bounce: t_end
    = t). A file that starts closed starts with no impact."""
    t, g = np.asarray(t, float), np.asarray(gap, float)
    if not g.size:
        return []
    tol = GAP_CLOSED * max(float(np.max(np.abs(g))), 1e-300)
    closed = g <= tol
    out = []
    k = 1
    while k < g.size:
        if closed[k] and not closed[k - 1]:
            j = k
            while j + 1 < g.size and closed[j + 1]:
                j += 1
            g0, g1 = g[k - 1], g[k]
            t_hit = t[k] if g1 >= -tol else t[k - 1] + (t[k] - t[k - 1]) * g0 / (g0 - g1)
            still = j == g.size - 1
            out.append(ExternalImpact(float(t_hit), contact, float(t[j]), bool(still and t[j] > t[k]),
                                      float(np.min(g[k:j + 1]))))
            k = j + 1
        else:
            k += 1
    return out


def repeated_time_events(t: np.ndarray) -> list[ExternalImpact]:
    """Impacts at the times an event-driven file writes twice (contact unknown)."""
    t = np.asarray(t, float)
    k = np.flatnonzero(np.diff(t) == 0)
    return [ExternalImpact(float(t[i])) for i in k]


def read_impacts(data: Any, t_end: float, n_contacts: int, what: str = "the impacts file"
                 ) -> list[ExternalImpact]:
    """Impact records from a table with a column ``t`` [s] and optionally ``contact`` (an index
    0 … n_contacts − 1): a path to a CSV/Parquet file, a DataFrame, or a sequence of times or
    (t, contact) pairs.

    Raises
    ------
    ExternalDataError
    """
    if not isinstance(data, (str, os.PathLike, pd.DataFrame)):
        try:
            rows = [(float(x), math.nan) if np.ndim(x) == 0 else (float(x[0]), float(x[1])) for x in data]
        except (TypeError, ValueError, IndexError):
            raise ExternalDataError(f"{what} must be a file, a DataFrame with columns t and contact, or a list of "
                                    f"times or (t, contact) pairs; got {data!r}") from None
        data = pd.DataFrame(rows, columns=["t", "contact"])
    df, _, _ = read_table(data, what)
    cols = [str(c) for c in df.columns]
    if "t" not in cols:
        raise ExternalDataError(f"{what} has no column 't' (columns: {', '.join(cols) or 'none'}); give the impact "
                                f"times in a column t [s] and the contact index in a column contact")
    unknown = [c for c in cols if c not in ("t", "contact")]
    if unknown:
        raise ExternalDataError(f"{what}: unknown column '{unknown[0]}'{did_you_mean(unknown[0], ['t', 'contact'])} "
                                f"(an impacts table has the columns t and contact)")
    num = _numeric(df, what)
    t = num["t"].to_numpy(float)
    _check_finite(num[["t"]], what)
    if t.size:
        check_times(t, t_end, what, whole_span=False)
    contact = np.full(t.size, ANY)
    if "contact" in num.columns:
        c = num["contact"].to_numpy(float)
        known = np.isfinite(c)
        bad = known & ((c != np.round(c)) | (c < 0) | (c >= max(n_contacts, 1)))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ExternalDataError(f"{what}: contact {c[k]:g} in row {k + 1} is not a contact of the case (it has "
                                    f"{n_contacts} contact point(s), numbered 0 … {max(n_contacts - 1, 0)}); leave "
                                    f"the cell empty when the contact is not known")
        contact = np.where(known, c, ANY).astype(int)
    return [ExternalImpact(float(ti), int(ci)) for ti, ci in zip(t, contact)]


# -- the whole input ------------------------------------------------------------------------------
def load(data: Any, t_end: float, system: Any, declared: Observables, scored: Sequence[str],
         impacts: Any = None, overrides: Mapping[str, Any] | None = None, what: str = "the data file"
         ) -> ExternalData:
    """An external trajectory checked against its case (end time ``t_end``, the built
    ``system``, the model's ``declared`` observables, the scene's ``scored`` ones), with its
    event sequence (module docstring) and metadata (``overrides``: label, cost_s, steps).

    Raises
    ------
    ExternalDataError
    """
    df, meta, source = read_table(data, what)
    if source != "DataFrame":
        what = f"{what} '{Path(source).name}'"
    meta = metadata(meta, overrides)
    if "label" not in meta and source != "DataFrame":
        meta["label"] = Path(source).stem
    hist = check_history(df, t_end, accepted_columns(system, declared), scored, what)
    t = hist["t"].to_numpy(float)
    notes = []
    if impacts is not None:
        events, source_ev = read_impacts(impacts, t_end, int(system.n_contacts)), "impacts file"
    elif "gap" in hist.columns:
        one = 0 if int(system.n_contacts) == 1 else ANY   # one gap column of several contacts: which is not known
        events, source_ev = gap_events(t, hist["gap"].to_numpy(float), one), "gap column"
    elif system.n_contacts and (np.diff(t) == 0).any():
        events, source_ev = repeated_time_events(t), "repeated times"
    else:
        events, source_ev = [], "none"
        if system.n_contacts:
            notes.append("no event sequence given (no impacts file, no gap column, no repeated time): the "
                         "trajectory counts as one without impacts")
    missing = [c for c in scored if c not in hist.columns]
    if missing:
        notes.append(f"not in the file, not scored: {', '.join(missing)}")
    return ExternalData(hist, tuple(events), source_ev, meta, source if source == "DataFrame" else Path(source).name,
                        tuple(notes))


def check_units(history: pd.DataFrame, truth: pd.DataFrame, columns: Iterable[str], declared: Observables,
                what: str = "the data") -> None:
    """Refuse a column whose values are the truth's divided by a unit factor
    (:data:`UNIT_FACTORS`): the least-squares ratio s of the truth to the values, at the
    file's times, lies within :data:`UNIT_FACTOR_RTOL` of a factor, the scaled values fit the
    truth to :data:`UNIT_FIT_RTOL` (RMS, relative) and the values as given do not
    (:data:`UNIT_RAW_RTOL`). An integrator's error, however large, is not a constant factor.

    Raises
    ------
    ExternalDataError
    """
    t = history["t"].to_numpy(float)
    for c in columns:
        if c not in history.columns or c not in truth.columns:
            continue
        ref = metrics.interpolate(truth, c, t)
        val = history[c].to_numpy(float)
        ok = np.isfinite(ref) & np.isfinite(val)
        a, b = val[ok], ref[ok]
        nb, aa = float(np.sqrt(np.mean(b * b))) if b.size else 0.0, float(a @ a)
        if not (nb > 0.0 and aa > 0.0):
            continue
        s = float(a @ b) / aa
        fit = float(np.sqrt(np.mean((b - s * a) ** 2))) / nb
        raw = float(np.sqrt(np.mean((b - a) ** 2))) / nb
        for factor, meaning in UNIT_FACTORS:
            if abs(s / factor - 1.0) < UNIT_FACTOR_RTOL and fit < UNIT_FIT_RTOL and raw > UNIT_RAW_RTOL:
                unit = declared.get(c).unit
                raise ExternalDataError(
                    f"{what}: column '{c}' looks like a unit error — the truth is {s:.4g} × its values "
                    f"(≈ {factor:.4g}: likely {meaning}); the case declares {c} in {unit or 'its own unit'} "
                    f"(`daebench show CASE`). Convert the column and score again")
