"""Scoring candidate effects on held-out runs, and the verdict.

Each candidate's fit (on the training runs) is scored on the **held-out**
runs, never on the data it was fitted to:

- ``heldout_rms_before/after``: rms of the filtered residual of the baseline
  and of the augmented model [m/s^2] (both channels pooled), and
  ``reduction = 1 - after / before``;
- ``z``: significance of the held-out improvement (:func:`paired_z` on the
  per-sample losses, residuals normalized by each channel's floor);
- ``closes``: the fraction of the gap closed, ``(R_b^2 - R_a^2) / (R_b^2 - F^2)``
  in floor-normalized units, where ``F^2`` (``floor_ms``) is the mean square
  the residual would have if it were only noise: the noise model's floor
  (:mod:`.noise`), at most the data-based floor (``R^2 = 1``), which a
  dynamic effect the state maps cannot predict inflates;
- ``delta_bic``: change of the information criterion on the training runs,
  with the effective sample size ``n / inflation`` of the fitted model's
  residual for both models (:func:`delta_bic`).

Verdicts can be wrong in only one way at a time:

- ``none``: no gap is detected (no state structure beyond the floor, no
  spectral peak, no periodicity in d) **and** no candidate improves the
  held-out residual significantly. No effect is claimed.
- effect name(s): the best significant candidate closes at least
  ``closes_min`` of the gap. Candidates whose held-out residual is not
  significantly worse than the best's (paired ``|z| < confusable_z``) and that
  also close the gap form a confusable set, reported together (``a|b``). If a
  significant gap remains, forward selection adds effects one at a time, each
  refitted jointly with those already selected and kept only if its held-out
  gain is significant (``a+b``, ``a+b+c``; ``+`` binds loosest:
  ``a+b|c`` is ``a`` and one of ``b``, ``c`` the data cannot tell apart).
- ``unexplained``: a gap is detected (or a candidate helps) but no candidate,
  alone or with others, closes ``closes_min`` of it; the report says where it is.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..estimation.ident import autocorr_factor, geyer_factor
from .fit import FitResult
from .residuals import Residual
from .settings import VerdictRules
from .verdict import EffectSets, Verdict


def stack(res: Sequence[Residual], floors: np.ndarray) -> np.ndarray:
    """Floor-normalized residual samples of valid channels, stacked (NaN channels dropped)."""
    parts = []
    for c in range(2):
        for r in res:
            if r.run.n and r.run.valid[c]:
                parts.append(r.r[:, c] / floors[c])
    return np.concatenate(parts) if parts else np.zeros(0)


def raw_rms(res: Sequence[Residual], channel: int | None = None) -> float:
    """Rms [m/s^2] of the residual over valid samples (both channels, or one)."""
    parts = []
    chans = (0, 1) if channel is None else (channel,)
    for c in chans:
        for r in res:
            if r.run.n and r.run.valid[c]:
                parts.append(r.r[:, c])
    if not parts:
        return math.nan
    x = np.concatenate(parts)
    return float(np.sqrt(np.mean(x**2)))


def paired_z(e_a: np.ndarray, e_b: np.ndarray, inflation: str = "residual") -> float:
    """Significance that model b fits the held-out samples better than model a (larger z: b better).

    ``e_a``, ``e_b``: aligned floor-normalized residuals of the two models on
    the same held-out samples, ``delta = e_a - e_b`` the difference of the two
    models' predictions. If b's extra structure were fitted noise, ``delta``
    would be independent of the held-out noise ``e_b``, and
    ``mean(e_a^2) - mean(e_b^2) = 2 mean(e_b delta) + mean(delta^2)`` would have
    mean ``-mean(delta^2)`` or less and standard deviation
    ``2 sqrt(lrv / n)``, with ``lrv`` the long-run variance of the products
    ``e_b delta``. So

    ``z = (mean(e_a^2) - mean(e_b^2)) / (2 sqrt(lrv / n))``

    is conservative under "no difference", and grows as ``rms(delta) sqrt(n_eff) / (2 sigma)``
    when b captures a real gap of size ``rms(delta)``.

    Parameters
    ----------
    e_a, e_b : ndarray
        The two models' residuals on the same samples.
    inflation : {"residual", "product", "null"}
        How ``lrv`` is estimated. ``residual`` (the admission tests):
        ``sigma^2 rms(delta)^2`` times the autocorrelation inflation of ``e_b``,
        an upper bound (the products' autocorrelation is that of ``e_b`` times
        that of ``delta``, lag by lag). ``product``: the mean square of the
        products times their own autocorrelation inflation, the direct estimate
        (the Newey-West principle of Diebold and Mariano's test of predictive
        accuracy, J. Bus. Econ. Stat. 13, 1995). They differ where ``e_b``
        still holds slow structured misfit (another effect's law only nearly
        right) and ``delta`` is fast (an amplifier lag acts at the currents'
        frequencies): the bound charges the slow misfit's correlation to the
        fast difference (held-out z 3.2 against 5.8 for a 400 Hz lag beside
        LuGre friction and saturation). ``null`` (the backward check): the
        products' variance under the null, ``mean(e_b^2) mean(delta^2)``
        (``e_b`` and ``delta`` independent), times the products' own
        autocorrelation inflation. It differs from ``product`` where the
        better model's law is only nearly right where it acts: its residual
        ``e_b`` is then large on the very samples where ``delta`` is (the
        moves' current steps, for a lag of another order than the library's
        members), the products are heavy-tailed (kurtosis 255 against 3), and
        their mean square, taken as the noise, hides the gain they carry (a
        Bessel-type amplifier beside eddy drag: dBIC -420, held-out z 2.1 with
        ``product``, 5.6 with ``null``). Whether a gain is another effect's
        misfit taken up is the claim guard's question (:mod:`.stages.claims`),
        with the others at full freedom.
    """
    n = len(e_b)
    if n < 10 or len(e_a) != n:
        return 0.0
    delta = e_a - e_b
    rd = float(np.sqrt(np.mean(delta**2)))
    if rd == 0:
        return 0.0
    gain = float(np.mean(e_a**2) - np.mean(e_b**2))
    if inflation in ("product", "null"):
        prod = e_b * delta
        ms = float(np.mean(prod**2)) if inflation == "product" else float(np.mean(e_b**2)) * rd**2
        return gain / (2 * math.sqrt(ms * autocorr_factor(prod) / n)) if ms > 0 else 0.0
    if inflation != "residual":
        raise ValueError(f"inflation: {inflation!r} is not one of residual, product, null")
    sig = float(np.sqrt(np.mean(e_b**2)))
    infl = autocorr_factor(e_b)
    return float(gain / (2 * sig * rd * math.sqrt(infl / n)))


def resolved_paired_z(
    e_a: np.ndarray, e_b: np.ndarray, e_a_res: np.ndarray, e_b_res: np.ndarray, z_tie: float
) -> tuple[float, float, float]:
    """Significance that model b (an effect added) fits better, when part of the samples is not resolved.

    ``e_a``, ``e_b``: the two models' floor-normalized held-out residuals on
    all samples; ``e_a_res``, ``e_b_res``: the same on the samples whose
    velocities resolve the models' terms (:func:`.stages.refit.resolved_masks`),
    a subset. Where a guide sticks, the friction law is evaluated at
    velocities below their resolution and leaves a structured misfit, not
    noise; an effect that only takes up that misfit gains on the unresolved
    samples and nothing (or a loss) on the resolved ones, and is not evidenced.

    The test on the resolved samples asks whether the effect's gain is
    *present* there at the density the all-sample test requires, not whether
    the subset alone reaches the all-sample threshold. The paired z
    (:func:`paired_z`) of a real effect of difference ``delta`` grows as
    ``rms(delta) sqrt(n_eff) / (2 sigma)``: the same gain per sample gives a
    z smaller by ``sqrt(n_res / n)`` on a subset of ``n_res`` of ``n``
    samples (an 800 Hz lag on a foreign rig: z 6.35 over 4,800 samples,
    3.87 over the 2,388 resolved ones, 0.86 of the per-sample evidence).
    Asking ``z_min`` of the subset would drop a real effect whenever about
    half the samples are unresolved. So the resolved z is brought to the
    all-sample count, ``z_res sqrt(n / n_res)`` (the z all samples would give
    if each carried the resolved samples' evidence), and must itself pass
    ``z_tie`` (the tie level, ``confusable_z``: below it the two models fit the
    resolved samples equally well, whatever its scaled value), so a small
    resolved subset cannot pass on noise scaled up.

    The rule uses the gain, not where the difference ``delta`` lies: an
    effect that takes up a sticking guide's misfit (a lag, a saturation) acts
    on all samples, and its difference is spread over them; what
    concentrates on the unresolved samples is what it gains there.

    The premise holds both ways: the unresolved samples are evidence neither
    for an effect nor against it. There the friction law's structured misfit
    meets every other term of the model, so a real effect can also *lose*
    there (a 400 Hz lag beside LuGre friction fitted as Stribeck: held-out z
    -1.8 over all samples, 7.2 over the 48 % resolved ones, where the
    presliding the static law lacks does not act). Once the resolved samples
    show the gain (``z_res >= z_tie``), the all-sample z does not veto it.

    Returns
    -------
    z, z_all, z_res : float
        ``z = z_res sqrt(n / n_res)`` when ``z_res >= z_tie``, else
        ``min(z_all, z_res)`` (below the tie the effect is not evidenced where the
        friction law is resolved); ``z_all``, ``z_res`` the two paired z.
    """
    z_all = paired_z(e_a, e_b, inflation="null")
    z_res = paired_z(e_a_res, e_b_res, inflation="null")
    n, n_res = len(e_b), len(e_b_res)
    if n_res == 0:  # no resolved sample: nothing to restrict to
        return z_all, z_all, z_res
    if n_res >= n or z_res < z_tie:
        return min(z_all, z_res), z_all, z_res
    return z_res * math.sqrt(n / n_res), z_all, z_res


def resolved_delta_bic(e_fit: np.ndarray, e_ref: np.ndarray, k_fit: int, k_ref: int, inflation: float) -> float:
    """:func:`delta_bic` of two fitted models on a subset of the training samples (the resolved ones).

    ``e_fit``, ``e_ref``: the two models' floor-normalized training residuals on the same samples; ``k_fit``,
    ``k_ref``: their fitted parameters; ``inflation``: that of the measurement noise. Where a guide sticks the
    training samples carry the friction law's structured misfit, which any other term can trade against: the
    information criterion over all samples then measures that trade, not the effect (the resolved samples'
    premise, :func:`resolved_paired_z`). Negative: ``fit`` better.
    """
    n_eff = max(len(e_fit) / max(inflation, 1e-12), 1.0)
    ratio = max(float(np.sum(e_fit**2)), 1e-300) / max(float(np.sum(e_ref**2)), 1e-300)
    return n_eff * math.log(ratio) + (k_fit - k_ref) * math.log(n_eff)


def noise_inflation(w_y: np.ndarray, decimate: int) -> float:
    """Autocorrelation inflation ``1 + 2 sum rho_k`` of white measurement noise after the residual filter.

    ``w_y`` is the filter's kernel on the encoder readings and ``decimate``
    its decimation: the residual's noise is white noise through ``w_y``
    sampled every ``decimate`` samples, whose correlation is the kernel's
    autocorrelation at multiples of ``decimate`` (summed while the pairs stay
    positive, as :func:`~maglev_ocp.estimation.ident.autocorr_factor`). A
    structured residual cannot inflate it.
    """
    w = np.asarray(w_y, float)
    ac = np.correlate(w, w, mode="full")[len(w) - 1 :]
    if ac[0] <= 0:
        return 1.0
    return geyer_factor(ac[:: max(int(decimate), 1)] / ac[0])


def delta_bic(fit: FitResult, ref: FitResult, inflation: float | None = None) -> float:
    """Information criterion of ``fit`` minus that of ``ref`` on the same training data (negative: fit better).

    Both with the **same** effective sample size ``n_eff = n / inflation``:
    ``n_eff ln(SSE_fit / SSE_ref) + (k_fit - k_ref) ln(n_eff)``, with the
    inflation of the measurement noise (:func:`noise_inflation`) when given,
    else that of ``fit``'s residual. Each model's own residual inflation would
    penalize a fit for whitening the residual: an unexplained slow structure
    inflates the residual's autocorrelation, not the noise's.
    """
    infl = inflation if inflation is not None else fit.inflation
    n_eff = max(fit.n / max(infl, 1e-12), 1.0)
    ratio = max(fit.sse, 1e-300) / max(ref.sse, 1e-300)
    return n_eff * math.log(ratio) + (fit.k - ref.k) * math.log(n_eff)


@dataclass
class EffectScore:
    """One candidate, fitted and scored.

    Attributes
    ----------
    name : str
        Effect name (or ``a+b`` for a pair).
    fit : FitResult
        The fit on the training runs.
    params, stderr : dict
        Fitted physical values and their standard errors (readable names).
    heldout_rms_before, heldout_rms_after : float
        Held-out residual rms of the baseline and of the augmented model [m/s^2].
    per_channel : dict
        ``{channel: [before, after]}`` [m/s^2].
    reduction : float
        ``1 - after / before``.
    closes : float
        Fraction of the held-out gap above the floor that the effect closes (clipped to [-1, 1]).
    z : float
        Significance of the held-out improvement.
    delta_bic : float
        Training-run information criterion minus the baseline's (negative is better).
    significant : bool
        ``z >= z_min`` and ``delta_bic <= -bic_margin``, on a converged fit.
    selected : bool
        Part of the verdict.
    confusable_with : list of str
        Candidates that explain the gap equally well.
    note : str
        What was held fixed.
    """

    name: str
    fit: FitResult | None
    params: dict[str, float]
    stderr: dict[str, float]
    heldout_rms_before: float
    heldout_rms_after: float
    per_channel: dict[str, list[float]]
    reduction: float
    closes: float
    z: float
    delta_bic: float
    significant: bool = False
    selected: bool = False
    confusable_with: list[str] = field(default_factory=list)
    note: str = ""
    e_after: np.ndarray | None = None  # floor-normalized held-out residual (for paired comparisons)
    r2_after: float = math.nan  # mean floor-normalized squared held-out residual (1 = at the floor)
    law: str = "default"  # member of the effect's law family
    law_choice: str = ""  # how the member was chosen

    def fitted_text(self, eq: str = "=", pm: str = "±") -> str:
        """The fitted parameters and their standard errors, ``k=v±se, ...`` (``eq``, ``pm``: the separators)."""
        return ", ".join(
            f"{k}{eq}{v:.4g}" + (f"{pm}{self.stderr[k]:.2g}" if self.stderr.get(k) is not None else "")
            for k, v in self.params.items()
        )

    def to_dict(self) -> dict:
        """JSON-ready view (the issue's ``effects`` entries plus statistics)."""
        return {
            "name": self.name,
            "params": self.params,
            "stderr": self.stderr,
            "heldout_rms_before": self.heldout_rms_before,
            "heldout_rms_after": self.heldout_rms_after,
            "reduction": self.reduction,
            "selected": self.selected,
            "gap_closed": self.closes,
            "z_heldout": self.z,
            "delta_bic": self.delta_bic,
            "significant": self.significant,
            "converged": self.fit.success if self.fit is not None else True,
            "solver_status": self.fit.status if self.fit is not None else "none",
            "per_channel_rms": self.per_channel,
            "confusable_with": self.confusable_with,
            "law": self.law,
            "law_choice": self.law_choice,
            "note": self.note,
        }


def score(
    name: str,
    fit: FitResult | None,
    base_fit: FitResult,
    before: Sequence[Residual],
    after: Sequence[Residual],
    floors: np.ndarray,
    rules: VerdictRules,
    params: dict[str, float],
    stderr: dict[str, float],
    note: str = "",
    inflation: float | None = None,
    floor_ms: float = 1.0,
) -> EffectScore:
    """Score one fitted candidate on the held-out residuals ``before`` (baseline) and ``after``.

    ``inflation``: the noise's autocorrelation inflation for the information
    criterion (:func:`delta_bic`). ``floor_ms``: the mean square, in units of
    ``floors``, that the residual would have if it were only noise (the
    noise model's floor, :mod:`.noise`); the gap a candidate closes is the
    baseline's mean square above it.
    """
    eb, ea = stack(before, floors), stack(after, floors)
    Rb2, Ra2 = float(np.mean(eb**2)), float(np.mean(ea**2))
    gap = Rb2 - floor_ms
    closes = (Rb2 - Ra2) / max(gap, Rb2 - Ra2, 1e-12)
    z = paired_z(eb, ea)
    rb, ra = raw_rms(before), raw_rms(after)
    chans = {}
    for c, cname in enumerate(("vertical", "horizontal")):
        b, a = raw_rms(before, c), raw_rms(after, c)
        if math.isfinite(b):
            chans[cname] = [b, a]
    dbic = delta_bic(fit, base_fit, inflation) if fit is not None else 0.0
    # A fit whose solver did not converge is reported, never counted as evidence.
    converged = fit is None or fit.success
    sig = bool(z >= rules.z_min and dbic <= -rules.bic_margin and converged)
    return EffectScore(
        name,
        fit,
        params,
        stderr,
        rb,
        ra,
        chans,
        1 - ra / rb if rb > 0 else 0.0,
        float(np.clip(closes, -1.0, 1.0)),
        z,
        dbic,
        sig,
        note=note,
        e_after=ea,
        r2_after=Ra2,
    )


def decide(
    scores: Sequence[EffectScore], gap_detected: bool, rules: VerdictRules, gap_evidence: Sequence[str] = ()
) -> tuple[Verdict, EffectScore | None]:
    """Verdict from single-effect scores (pairs are handled by the caller via :func:`pick_second`).

    Returns the verdict and the best significant score (None if there is none).
    """
    reasons = list(gap_evidence)
    sig = [s for s in scores if s.significant]
    if not gap_detected and not sig:
        reasons.append("no gap above the noise floor and no candidate improves the held-out runs: none")
        return Verdict(EffectSets.none(), [], False, reasons), None
    if not sig:
        reasons.append("a gap is detected but no candidate improves the held-out runs significantly")
        return Verdict(EffectSets.gap_unexplained(), [], gap_detected, reasons), None
    best = max(sig, key=lambda s: (s.reduction, -s.delta_bic))
    reasons.append(
        f"best candidate {best.name}: held-out reduction {best.reduction:.1%}, closes "
        f"{best.closes:.0%} of the gap, z = {best.z:.1f}, dBIC = {best.delta_bic:.0f}"
    )
    if best.closes < rules.closes_min:
        return Verdict(EffectSets.gap_unexplained(), [], True, reasons), best
    conf = []
    for s in sig:
        if s is best or s.closes < rules.closes_min:
            continue
        zc = paired_z(s.e_after, best.e_after) if s.e_after is not None else 0.0
        if zc < rules.confusable_z:
            conf.append(s.name)
            reasons.append(f"{s.name} explains the held-out runs as well (paired z = {zc:.1f}): confusable")
    best.confusable_with = conf
    for s in sig:
        if s.name in conf:
            s.confusable_with = [best.name] + [c for c in conf if c != s.name]
    return Verdict(EffectSets.of([[best.name, *conf]]), [best.name, *conf], True, reasons), best


def rank(scores: Sequence[EffectScore]) -> list[EffectScore]:
    """Best first: the verdict's (selected) scores, then significant before not, then by held-out reduction,
    then by the information criterion (a joint candidate the selection refused, e.g. ``cogging+saturation``
    with the same reduction as ``cogging``, ranks after the verdict it did not improve)."""
    return sorted(scores, key=lambda s: (not s.selected, not s.significant, -s.reduction, s.delta_bic))


__all__ = [
    "EffectScore",
    "Verdict",
    "VerdictRules",
    "decide",
    "delta_bic",
    "noise_inflation",
    "paired_z",
    "rank",
    "raw_rms",
    "resolved_paired_z",
    "score",
    "stack",
]
