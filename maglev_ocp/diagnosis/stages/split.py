"""Stage 1, split: whole runs held out for scoring, runs cut at stop contacts, every run filtered.

Whole runs are held out (sorted by fixture and mean gap, every ``holdout_every``-th from the second); a
dataset with fewer than three runs is cut into three pieces per run first (:func:`split_runs`). Samples
where the mover touches a mechanical stop are left out (:func:`off_stops`). The result is a :class:`Split`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ... import constants as k
from ...errors import DataError
from ...riglog import Dataset as RigDataset
from ..pool import dataset_tag
from ..residuals import PreparedRun, ResidualSettings, RunInput, ZeroPhaseFilter, prepare_run
from ..settings import DiagnoseSettings


def runs_from_dataset(ds: RigDataset) -> list[RunInput]:
    """The dataset's runs as :class:`RunInput` (commanded currents, encoder readings, fixtures)."""
    out = []
    for r in ds.runs:
        t = r.t
        if len(t) > 2:
            dt = np.diff(t)
            if np.max(np.abs(dt - ds.sample_time)) > 0.05 * ds.sample_time:
                raise DataError(f"{r.file}: rows are not evenly spaced by sample_time {ds.sample_time:g} s")
        out.append(RunInput(r.file, float(ds.sample_time), r.y, r.u, tuple(r.locked), float(t[0]) if len(t) else 0.0))
    return out


#: A position within this distance of a mechanical stop (MODEL.md: g in [8, 32] mm, d in [-60, 60] mm) counts
#: as touching it: 10 encoder counts, far above the encoder noise, far below any setpoint a controller tracks.
STOP_MARGIN_M: float = 1e-4


#: Samples left out on each side of a contact with a stop: the impact and the bounce before the position leaves
#: the margin (the contact force is in no model; the filter's window then starts clear of it).
STOP_PAD: int = 20


def off_stops(runs: Sequence[RunInput]) -> tuple[list[RunInput], list[str]]:
    """The runs cut where the mover touches a mechanical stop, and a note for each run that did.

    A rig that loses the levitation (a force the controller cannot hold, a bad
    gain) hits the stops; the contact force is in no model and no effect's law,
    so one crash would dominate every fit (seen: an upper-stop contact in one
    of six runs made a saturation fit worse at the true law than a wrong one).
    Samples within :data:`STOP_MARGIN_M` of a stop of an axis that is not locked,
    padded by :data:`STOP_PAD` samples, are left out: a run becomes the
    contact-free pieces between them (named ``<file>@<t0>s``), each filtered on
    its own, so no residual sample's window spans a contact.
    """
    out: list[RunInput] = []
    notes: list[str] = []
    lo = np.array([k.g_stop[0], k.d_stop[0]]) + STOP_MARGIN_M
    hi = np.array([k.g_stop[1], k.d_stop[1]]) - STOP_MARGIN_M
    for r in runs:
        free = np.array(["g" not in r.locked, "d" not in r.locked])
        y = np.asarray(r.y, float)
        at = ((y <= lo) | (y >= hi)) & free if len(y) else np.zeros((0, 2), bool)
        touch = at.any(axis=1)
        if not touch.any():
            out.append(r)
            continue
        bad = np.convolve(touch.astype(float), np.ones(2 * STOP_PAD + 1), mode="same") > 0
        edges = np.flatnonzero(np.diff(np.concatenate([[1], bad.astype(int), [1]])))
        for a, b in zip(edges[::2], edges[1::2], strict=True):  # clean pieces [a, b)
            t0 = r.t0 + a * r.Ts
            out.append(RunInput(f"{r.name}@{t0:.3f}s", r.Ts, y[a:b], np.asarray(r.u)[a:b], r.locked, t0))
        which = [ax for j, ax in enumerate(("g", "d")) if at[:, j].any()]
        notes.append(
            f"{r.name}: the mover touches a mechanical stop ({', '.join(which)}) in {int(touch.sum())} samples; "
            f"{int(bad.sum())} samples around the contacts left out (the contact force is in no model)"
        )
    return out, notes


def split_runs(runs: Sequence[RunInput], every: int = 3) -> tuple[list[RunInput], list[RunInput]]:
    """Hold out whole runs: sorted by fixture and mean gap, every ``every``-th from the second.

    With fewer than three runs, each run is first cut into three contiguous
    pieces (named ``<file>#1/3`` ...), so that scoring still uses data the fit
    has not seen. Pooled datasets (:func:`..pool.pool_datasets`) are split each
    on its own, so that every dataset has held-out runs.
    """
    tags = sorted({dataset_tag(r.name) for r in runs})
    if len(tags) > 1:
        parts = [_split_one([r for r in runs if dataset_tag(r.name) == t], every) for t in tags]
        return [r for tr, _ in parts for r in tr], [r for _, te in parts for r in te]
    return _split_one(runs, every)


def _split_one(runs: Sequence[RunInput], every: int) -> tuple[list[RunInput], list[RunInput]]:
    """:func:`split_runs` on the runs of one dataset."""
    runs = list(runs)
    if len(runs) < 3:
        pieces = []
        for r in runs:
            n = len(r.y)
            cuts = np.linspace(0, n, 4).astype(int)
            for j in range(3):
                a, b = cuts[j], cuts[j + 1]
                pieces.append(RunInput(f"{r.name}#{j + 1}/3", r.Ts, r.y[a:b], r.u[a:b], r.locked, r.t0 + a * r.Ts))
        runs = pieces
    order = sorted(range(len(runs)), key=lambda i: (runs[i].locked, float(np.mean(runs[i].y[:, 0]))))
    test_idx = set(order[1::every]) if len(order) > 1 else set()
    train = [runs[i] for i in range(len(runs)) if i not in test_idx]
    test = [runs[i] for i in range(len(runs)) if i in test_idx]
    return train, test


@dataclass(frozen=True)
class Split:
    """Stage 1: the runs split and filtered (training and held-out)."""

    filt: ZeroPhaseFilter
    train_in: list[RunInput]
    test_in: list[RunInput]
    train: list[PreparedRun]
    test: list[PreparedRun]
    has: tuple[bool, bool]  # the training runs carry a vertical / horizontal channel
    stops: tuple[str, ...] = ()  # runs cut at a stop contact (:func:`off_stops`)

    @property
    def u_train(self) -> list[np.ndarray]:
        """Commanded currents of the training runs."""
        return [r.u for r in self.train_in]

    @property
    def u_test(self) -> list[np.ndarray]:
        """Commanded currents of the held-out runs."""
        return [r.u for r in self.test_in]


def split_dataset(dataset: RigDataset, st: DiagnoseSettings) -> Split:
    """Stage 1: hold out whole runs, filter every run; refuse runs too short for the filter."""
    runs = runs_from_dataset(dataset)
    Ts = float(dataset.sample_time)
    filt = ZeroPhaseFilter(ResidualSettings(st.fc_hz, st.numtaps | 1, st.decimate), Ts)
    train_in, test_in = split_runs(runs, st.holdout_every)
    # whole runs are held out first, then cut at stop contacts: a crash does not move a run between the sets
    (train_in, notes_a), (test_in, notes_b) = off_stops(train_in), off_stops(test_in)
    train = [(ri, pr) for ri in train_in if (pr := prepare_run(ri, filt)).n > 0]
    test = [(ri, pr) for ri in test_in if (pr := prepare_run(ri, filt)).n > 0]
    if not train or not test:
        raise DataError(
            f"{dataset.folder or 'dataset'}: runs are too short for the residual filter "
            f"({st.numtaps} taps at {Ts:g} s); need at least {3 * st.numtaps} samples per run"
            + (" clear of the mechanical stops" if notes_a or notes_b else "")
        )
    tr = [b for _, b in train]
    has = (any(r.valid[0] for r in tr), any(r.valid[1] for r in tr))
    return Split(
        filt, [a for a, _ in train], [a for a, _ in test], tr, [b for _, b in test], has, tuple(notes_a + notes_b)
    )


__all__ = ["STOP_MARGIN_M", "STOP_PAD", "Split", "off_stops", "runs_from_dataset", "split_dataset", "split_runs"]
