"""Parameter estimation and the seed's calibration procedures (seed sections IV and V).

* :mod:`.ident` - the identification toolkit shared with the diagnosis: zero-phase filtering of
  accelerations and regressors, HAC (Newey-West) standard errors, effective sample sizes;
* :mod:`.data` - logged runs as the estimators see them (:class:`RunData`), the vectorized observer;
* :mod:`.npfisi` - the reduced-order NPFISI estimator of the seed's eq. (3);
* :mod:`.batch` - all parameters at once by filtered equation error (CasADi NLP), with standard errors;
* :mod:`.procedures` - the seed's procedures V.A-V.D on a rig-log dataset;
* :mod:`.calibrate` - ``maglev calibrate``: everything above on one dataset, files and figures.
"""

from .batch import BatchResult, BatchSettings, batch_estimate
from .data import RunData, observe
from .npfisi import NPFISI, NPFISIResult, NPFISISettings, run_npfisi

__all__ = [
    "NPFISI",
    "BatchResult",
    "BatchSettings",
    "NPFISIResult",
    "NPFISISettings",
    "RunData",
    "batch_estimate",
    "observe",
    "run_npfisi",
]
