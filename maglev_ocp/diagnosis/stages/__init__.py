"""The diagnosis' stages, one module each, each with its own result (:mod:`..diagnose` orders them).

:mod:`.split` (training and held-out runs), :mod:`.baseline` (the calibrated model, residuals, floors),
:mod:`.localization` (where the baseline misses; the noise model), :mod:`.models` (the selection's context
:class:`~.models.Run` and record :class:`~.models.Attribution`), :mod:`.selection` (single effects, law
families, forward selection), :mod:`.joint` (joint models: backward check, confusable slots, shares, laws),
:mod:`.guards` (checks that can overturn a verdict), :mod:`.refit` (constants on the clean and on the
resolved samples), :mod:`.quantify` (the final model's residuals, what stays unexplained, consequences).
The stages never import :mod:`..diagnose`, :mod:`..report` or :mod:`..closed_loop` (an import-linter
contract).
"""
