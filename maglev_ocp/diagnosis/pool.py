"""Several rig-log datasets pooled into one for a single diagnosis (``maglev diagnose run DATA1 DATA2 ...``).

Active diagnosis (:mod:`.experiment`) adds a second dataset, recorded on the
excitation a run plan chose, to the first; the diagnosis then decides on both
together. Each run keeps its file name behind its dataset's tag
(``ds<k>~<file>``), and the held-out split holds out runs of each dataset on its
own (:func:`.stages.split.split_runs` splits per tag), so the scoring runs cover
every dataset's conditions.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..errors import DataError
from ..riglog import Dataset as RigDataset

#: Separates a pooled run's dataset tag from its file name.
POOL_SEP: str = "~"


def dataset_tag(run_name: str) -> str:
    """The dataset tag of a pooled run's name (``ds2`` of ``ds2~plan_01.csv``); ``""`` for an unpooled run."""
    return run_name.split(POOL_SEP, 1)[0] if POOL_SEP in run_name else ""


def pool_datasets(datasets: Sequence[RigDataset]) -> RigDataset:
    """One dataset holding every run of ``datasets`` (one dataset is returned as it is).

    Raises
    ------
    DataError
        Datasets with different sample times (one model period cannot serve both).
    """
    if len(datasets) == 1:
        return datasets[0]
    if not datasets:
        raise DataError("no dataset to diagnose")
    ts = {float(ds.sample_time) for ds in datasets}
    if len(ts) > 1:
        names = ", ".join(f"{ds.folder or '?'} ({ds.sample_time:g} s)" for ds in datasets)
        raise DataError(f"datasets with different sample times cannot be pooled: {names}")
    runs = [
        r.renamed(f"ds{k + 1}{POOL_SEP}{r.file}", source=str(ds.folder or f"dataset {k + 1}"))
        for k, ds in enumerate(datasets)
        for r in ds.runs
    ]
    meta = {"pooled": [str(ds.folder or f"dataset {k + 1}") for k, ds in enumerate(datasets)]}
    return RigDataset(
        sample_time=datasets[0].sample_time,
        encoder_resolution=max(float(ds.encoder_resolution) for ds in datasets),
        runs=runs,
        folder=datasets[0].folder,
        meta=meta,
    )


__all__ = ["POOL_SEP", "dataset_tag", "pool_datasets"]
