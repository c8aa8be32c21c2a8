"""The working set of a long recording: the blocks of it the diagnosis works on.

The cost of a diagnosis grows with the samples it holds (every parameter change is an
inverse dynamics over all of them, cached), so an hour at 1 kHz (3.6e6 rows) cannot be
diagnosed whole in bounded memory.  A recording longer than ``max_samples`` is read once,
in blocks of rows (:func:`cosim.recording.iter_recording`: memory one block), and reduced
to a working set of at most ``max_samples`` rows:

1. it is cut into consecutive blocks of ``block_seconds`` (20 s: many cycles of an
   exciting motion, and 0.5 % of a block lost to the smoother's margins at its ends);
2. the blocks are grouped into consecutive strata of equal length, as many as the budget
   holds blocks.  When the length is known beforehand (Parquet, HDF5, a recording in
   memory) the strata have their final length at once; the length of a CSV file is known
   only at its end, so there strata start one block long and, whenever there would be
   more than the budget holds, neighbours are merged two by two (one pass; the working set
   then holds between half and all of ``max_samples``);
3. each stratum keeps its most exciting block: the largest sum over joints of
   ``log det`` of the information matrix of the columns (joint acceleration, rate, sign of
   the rate, 1) along the block, the inertia, viscous, Coulomb and constant-effort
   signatures (a D-optimal choice among the stratum's blocks; a block at rest scores low).

The blocks are kept at the full rate and whole: inside each one the residual is formed
exactly as on a short recording (zero-order-hold efforts, the central difference of the
rates, the smoother, delays up to ``max_delay``), and the pipeline
(:class:`~cosim.discrepancy.residuals.Pipeline` with ``segments``) evaluates it only at
samples a smoothing half-window plus the largest delay away from a block's ends, so no
filter reaches across two blocks.  Nothing is low-pass filtered or resampled, so the
assumptions of the noise model (white reading and effort noise, the variance inflation
of the smoother) and of the errors in variables (the measured rates and accelerations
noisy, the reference ``qref`` free of noise and the instrument of the masses) hold in the
working set as in the recording.  The blocks are chosen on the motion (``qref`` when the
recording has it, else the readings ``q``), never on the efforts, so the effort noise of
the working set is a sample of the recording's, not selected.  Strata spread the working
set over the whole recording: its last blocks, the held-out part, come from its end.

Example
-------
>>> from cosim.discrepancy.working_set import working_set
>>> ws = working_set("run.parquet", max_samples=200_000)         # doctest: +SKIP
>>> ws.recording, ws.segments, ws.summary()["blocks"]            # doctest: +SKIP
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError

#: samples at the full rate a diagnosis holds at most (100 s at 1 kHz: about 1.7 GB peak
#: and 1-2 minutes on one core for the 6-PUS; bench/long_recording.py measures it)
MAX_SAMPLES = 100_000
#: length of a block of the working set [s]
BLOCK_SECONDS = 20.0


@dataclass
class WorkingSet:
    """Blocks of a recording, concatenated.

    Attributes
    ----------
    recording : cosim.recording.Recording
        The rows of the chosen blocks, in time order, with their own times (gaps between
        blocks); the source's sidecar fields.
    segments : list of (int, int)
        Row ranges ``[start, stop)`` of the blocks in ``recording`` (one range when the
        whole source is kept).
    source_rows : int
        Rows of the source read.
    source_duration : float
        Its length [s].
    block_rows : int
        Rows of a block.
    stratum_blocks : int
        Blocks per stratum (1: every block kept).
    scores : list of float
        Excitation score of each chosen block (sum over joints of log det).
    """

    recording: object
    segments: list
    source_rows: int
    source_duration: float
    block_rows: int
    stratum_blocks: int
    scores: list = field(default_factory=list)

    @property
    def whole(self) -> bool:
        """The working set is the whole source."""
        return len(self.recording) == self.source_rows

    def summary(self) -> dict:
        """What the diagnosis says of its working set (``Diagnosis.settings["working_set"]``)."""
        t = self.recording.time
        return {"source_rows": self.source_rows, "source_duration": self.source_duration,
                "rows": len(self.recording), "whole": self.whole, "block_rows": self.block_rows,
                "stratum_blocks": self.stratum_blocks,
                "blocks": [[float(t[a]), float(t[b - 1])] for a, b in self.segments],
                "scores": [float(s) for s in self.scores]}


def excitation_score(rec) -> float:
    """Sum over joints of ``log det`` of the normalised information matrix of the columns
    (acceleration, rate, sign of the rate, 1) of the block's motion (``qref`` when present,
    else ``q``), the rate and acceleration differences over 5 ms.  Larger: more excited."""
    m = np.asarray(rec.qref if rec.qref is not None else rec.q, float)
    n = len(m)
    if n < 8:
        return -np.inf
    dt = float(rec.time[-1] - rec.time[0]) / (n - 1)
    lag = max(1, int(round(0.005 / dt)))
    h = lag * dt
    m = m[::lag]
    if len(m) < 5:
        return -np.inf
    v = np.gradient(m, h, axis=0)
    a = np.gradient(v, h, axis=0)
    band = 0.02 * np.sqrt(np.mean(v * v, axis=0)) + 1e-300
    s = np.sign(v) * (np.abs(v) > band)
    total = 0.0
    for j in range(m.shape[1]):
        X = np.column_stack([a[:, j], v[:, j], s[:, j], np.ones(len(v))])
        M = X.T @ X / len(X)
        M += np.eye(4) * (1e-12 * np.trace(M) / 4 + 1e-300)
        total += float(np.linalg.slogdet(M)[1])
    return total


def _merge(pair):
    """Two neighbouring strata as one: the better block, the blocks seen by both."""
    best = max(pair, key=lambda s: s[1])
    return [best[0], best[1], sum(s[2] for s in pair), best[3]]


def concat(blocks, copy: bool = False) -> object:
    """Consecutive :class:`~cosim.recording.Recording` blocks as one (the first block's
    sidecar fields); ``copy``: new arrays even for a single block (a block cut from a larger
    chunk would keep all of it alive)."""
    from ..recording import Recording

    blocks = list(blocks)
    if len(blocks) == 1 and not copy:
        return blocks[0]
    b0 = blocks[0]

    def cat(name):
        parts = [getattr(b, name) for b in blocks]
        return None if parts[0] is None else np.concatenate(parts)  # a copy, even of one part

    return Recording(b0.robot, cat("time"), cat("q"), cat("qd"), cat("tau"), cat("qref"), cat("pose"),
                     {k: np.concatenate([b.extra[k] for b in blocks]) for k in b0.extra},
                     dict(b0.parameters), dict(b0.controller), b0.notes, b0.path, dict(b0.joint_convention),
                     f_ext=cat("f_ext"), sidecar=dict(b0.sidecar))


def _rows_of(source, chunk_rows):
    """(iterator of Recording chunks, rows in total or None)."""
    from ..recording import Recording
    from ..recording_io import table_format

    if isinstance(source, Recording):
        return (source.slice(k, k + chunk_rows) for k in range(0, len(source), chunk_rows)), len(source)
    if isinstance(source, (str, Path)):
        path = Path(source)
        total = None
        try:
            if table_format(path) == "parquet":
                import pyarrow.parquet as pq

                total = pq.ParquetFile(path).metadata.num_rows
            elif table_format(path) == "hdf5":
                import h5py

                with h5py.File(path, "r") as f:
                    cols = list(f.attrs.get("columns", []))
                    c0 = cols[0].decode() if cols and isinstance(cols[0], bytes) else (str(cols[0]) if cols else None)
                    total = len(f[c0]) if c0 in f else None
        except Exception:  # noqa: BLE001 - only the bar's total; the reader says what is wrong
            total = None
        return _file_chunks(path, chunk_rows), total
    return iter(source), None


def _file_chunks(path, chunk_rows):
    """The file in chunks (memory one chunk); where Arrow's stream refuses a cell, the
    careful whole-file reader takes over from there: it says where the file is wrong, or
    reads what only it reads (as :func:`cosim.recording.read_recording` does)."""
    from ..recording import RecordingError, iter_recording, read_recording

    done = 0
    try:
        for c in iter_recording(path, chunk_rows=chunk_rows):
            done += len(c)
            yield c
    except RecordingError:
        rec = read_recording(path)
        for k in range(done, len(rec), chunk_rows):
            yield rec.slice(k, k + chunk_rows)


def _blocks(chunks, block_seconds, max_samples, duration):
    """Blocks of ``block_seconds`` (at most ``max_samples`` rows) from chunks of any size,
    the first ``duration`` seconds only when given; the first item is (block length in
    rows, sampling step [s] or None)."""
    buf, rows, block, t_end = [], 0, None, None
    for c in chunks:
        if t_end is None:
            t_end = c.time[0] + duration if duration is not None else np.inf
        if c.time[0] >= t_end:
            break
        if c.time[-1] >= t_end:
            c = c.slice(0, int(np.searchsorted(c.time, t_end)))
        if block is None and len(c) >= 2:
            dt = float(c.time[-1] - c.time[0]) / (len(c) - 1)
            block = max(2, min(int(round(block_seconds / dt)), int(max_samples)))
            yield block, dt
        buf.append(c)
        rows += len(c)
        while block is not None and rows >= block:
            whole = concat(buf)
            yield concat([whole.slice(0, block)], copy=True)
            rest = whole.slice(block, len(whole))
            buf, rows = ([rest], len(rest)) if len(rest) else ([], 0)
    if rows:
        if block is None:
            yield max(rows, 2), None
        yield concat(buf, copy=True)


def working_set(source, *, max_samples: int = MAX_SAMPLES, block_seconds: float = BLOCK_SECONDS,
                duration: float | None = None, chunk_rows: int = 100_000, progress: bool | None = None) -> WorkingSet:
    """The working set of a recording (see the module's text): the whole recording when it
    has at most ``max_samples`` rows, else one block of ``block_seconds`` per stratum.

    Parameters
    ----------
    source : str, Path, cosim.recording.Recording or iterable of Recording
        A recording file (CSV, Parquet, HDF5: read once, in blocks of ``chunk_rows`` rows),
        a recording in memory, or its consecutive blocks.
    max_samples : int
        Largest number of rows kept (a CSV's working set holds between half and all of it).
    block_seconds : float
        Length of a block [s].
    duration : float, optional
        Only the first ``duration`` seconds of the source [s].
    chunk_rows : int
        Rows read at a time from a file.
    progress : bool, optional
        Progress bar of the rows read (default: on a terminal, after 2 s).

    Returns
    -------
    WorkingSet

    Raises
    ------
    cosim.recording.RecordingError
        A malformed file (names the file, row, column).
    ValueError
        ``max_samples`` or ``block_seconds`` not positive.

    Example
    -------
    >>> import numpy as np
    >>> from cosim.recording import Recording
    >>> t = np.arange(10_000) * 1e-3
    >>> rec = Recording("fourbar", t, np.sin(t)[:, None], np.cos(t)[:, None], np.zeros((10_000, 1)))
    >>> ws = working_set(rec, max_samples=4000, block_seconds=1.0)
    >>> len(ws.recording), ws.stratum_blocks, len(ws.segments)
    (4000, 3, 4)
    """
    from tqdm import tqdm

    if not (isinstance(max_samples, (int, np.integer)) and max_samples > 0):
        raise InputError(f"max_samples = {max_samples!r} must be a positive whole number of rows")
    if not (isinstance(block_seconds, (int, float)) and np.isfinite(block_seconds) and block_seconds > 0):
        raise InputError(f"block_seconds = {block_seconds!r} must be a positive number of seconds")
    from ..recording import Recording

    if isinstance(source, Recording) and len(source) <= max_samples and duration is None:
        return WorkingSet(source, [(0, len(source))], len(source), float(source.time[-1] - source.time[0]),
                          len(source), 1, [])
    chunks, total = _rows_of(source, chunk_rows)
    name = Path(source).name if isinstance(source, (str, Path)) else "recording"
    strata = []   # [best block, its score, blocks seen, start row of the best block]
    per, rows, t0, t1 = 1, 0, None, None
    with tqdm(total=total, unit="row", unit_scale=True, desc=f"reading {name}", delay=2.0, leave=False,
              disable=None if progress is None else not progress) as bar:
        gen = _blocks(chunks, block_seconds, max_samples, duration)
        first = next(gen, None)
        if first is None:
            from ..recording import RecordingError

            raise RecordingError(name, "has no data rows")
        block_rows, dt = first
        k_max = max(1, int(max_samples) // block_rows)
        if total is not None and dt is not None:  # the length is known: strata of their final length at once
            if duration is not None:
                total = min(total, int(math.ceil(duration / dt)) + 1)
            per = max(1, math.ceil(max(1, int(total / block_rows + 0.5)) / k_max))  # a short tail is no block
        for b in gen:
            t0 = b.time[0] if t0 is None else t0
            t1 = b.time[-1]
            start, rows = rows, rows + len(b)
            bar.update(len(b))
            if len(b) < block_rows / 2 and (per > 1 or len(strata) >= k_max):
                continue  # a short tail and no room for it: read, not a block of its own
            score = excitation_score(b)
            if strata and strata[-1][2] < per:
                s = strata[-1]
                if score > s[1]:
                    s[0], s[1], s[3] = b, score, start
                s[2] += 1
            else:
                strata.append([b, score, 1, start])
            if len(strata) > k_max:  # twice as long strata: neighbours merged, the better block kept
                per *= 2
                strata = [_merge(strata[i:i + 2]) for i in range(0, len(strata), 2)]
    rec, segments = _joined(strata)
    return WorkingSet(rec, segments, rows, float(t1 - t0) if t0 is not None else 0.0,
                      block_rows, per, [s[1] for s in strata] if per > 1 else [])


def _joined(strata) -> tuple:
    """``(recording, segments)``: the kept blocks of ``strata`` ([block, score, blocks seen,
    start row] each) end to end, and the (start, end) rows of each contiguous run of them in
    it (one segment for all of them when nothing was dropped)."""
    segs, kept, start = [], [], 0
    for s in strata:
        b = s[0]
        if segs and s[3] == segs[-1][2]:
            segs[-1][1] += len(b)
            segs[-1][2] += len(b)
        else:
            segs.append([start, start + len(b), s[3] + len(b)])
        kept.append(b)
        start += len(b)
    return concat(kept), [(a, b) for a, b, _ in segs]


def sentence(summary: dict) -> str:
    """What a diagnosis worked on, in words ("" for a whole recording)."""
    if not summary or summary.get("whole", True):
        return ""
    blocks = summary["blocks"]
    return (f"working set: {len(blocks)} blocks of {summary['block_rows']} samples ({summary['rows']:,} of "
            f"{summary['source_rows']:,} rows), the most exciting block of every {summary['stratum_blocks']} "
            f"consecutive ones over the {summary['source_duration']:.0f} s recorded (first at "
            f"{blocks[0][0]:.1f} s, last at {blocks[-1][0]:.1f} s), each at the full rate")
