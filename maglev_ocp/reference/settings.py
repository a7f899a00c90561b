"""The ``reference:`` block of a scenario: how targets become references (:class:`ReferenceSettings`)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from ..config import Strict


class ReferenceSettings(Strict):
    """How targets become references (a scenario's ``reference:`` block).

    Attributes
    ----------
    shaping : {"trajectory", "step", "min_time"}
        ``trajectory``: plan a current-feasible move to each target (default);
        ``step``: jump the set-point to the target at its switch time;
        ``min_time``: the minimum-time move of the controller's model within
        ``current_fraction`` of the current limits (``i_d`` within
        ``i_d_fraction`` of its axis limit if given)
        (:func:`maglev_ocp.ocp.min_time.solve_min_time`, gap kept between the
        start and target gaps), a move at the limits for a controller that
        handles them itself (an option of the NMPC, see
        :meth:`maglev_ocp.controllers.nmpc.NMPCSettings.reference_defaults`); a move the
        solver does not converge on falls back to ``trajectory``.
    current_fraction : float
        Fraction of the current limits the planned feedforward may use; the
        rest is left to the feedback.
    ramp_fraction : float
        Fraction of the move spent ramping the acceleration up or down
        (0 = pure bang-bang; at most 0.25).
    axis_fraction : float or None
        Fraction of the per-axis limit (8 A on ``i_q`` and on ``i_d``) the
        planned feedforward may use, when it should differ from
        ``current_fraction`` (which then bounds the amplitude only): a move that
        saturates ``i_d`` leaves the open-loop unstable gap axis no feedback.
    i_d_fraction : float or None
        Fraction of the ``i_d`` axis limit the planned feedforward may use, when
        it should differ from the ``i_q`` axis's (``axis_fraction``, else
        ``current_fraction``): ``i_d`` holds the open-loop unstable gap, whose
        feedback needs headroom when a fast gap move drives ``i_d`` to its limit,
        while the thrust's ``i_q`` is only bounded by the amplitude.
    d_timing : {"symmetric", "free"}
        ``symmetric``: the horizontal axis accelerates for half of the move and
        brakes for the other half; ``free``: it accelerates for a share
        (:data:`D_SPLITS`) of the move and brakes, harder or softer, for the
        rest, whichever gives the shortest feasible move. The minimum-time moves
        show why: a move that changes the gap accelerates at the smaller gap,
        where the thrust per ampere ``L1 = C1 f1`` is larger, harder and for a
        shorter time than it brakes at the larger gap (or the other way round).
    gap_timing : {"with_d", "free"}
        ``with_d``: both axes share the move's duration (a straight line in the
        ``(g, d)`` plane); ``free``: the gap changes in a part of the move (a
        share of :data:`GAP_SHARES` of its duration, placed at one of
        :data:`GAP_PLACES` of the rest), whichever gives the shortest feasible
        move. The minimum-time moves (:mod:`maglev_ocp.ocp.min_time`) show why:
        the thrust per ampere is larger at a smaller gap (``L1 = C1 f1``), and a
        gap that opens while the mover brakes needs less ``i_d``, which leaves
        more of the current amplitude to ``i_q``.
    min_time_solver : {"profile", "nlp"}
        How ``shaping: min_time`` finds its move: ``profile`` (default), the
        time-optimal parameterization of the straight path at the bounds the
        limits give at each point (:mod:`maglev_ocp.reference.profile_plan`,
        milliseconds per move); ``nlp``, the minimum-time NLP
        (:func:`maglev_ocp.ocp.min_time.solve_min_time`, 0.1-0.4 s per move,
        1-3 % shorter moves: it may bend the path within the gap's 0.1 mm band).
    """

    shaping: Literal["trajectory", "step", "min_time"] = "trajectory"
    current_fraction: float = Field(0.85, gt=0.05, le=1.0)
    ramp_fraction: float = Field(0.05, ge=0.0, le=0.25)
    axis_fraction: float | None = Field(None, gt=0.05, le=1.0)
    i_d_fraction: float | None = Field(None, gt=0.05, le=1.0)
    gap_timing: Literal["with_d", "free"] = "with_d"
    d_timing: Literal["symmetric", "free"] = "symmetric"
    min_time_solver: Literal["profile", "nlp"] = "profile"

    @property
    def axis_limit_fraction(self) -> float:
        """Fraction of the per-axis limit: ``axis_fraction``, else ``current_fraction``."""
        return self.current_fraction if self.axis_fraction is None else self.axis_fraction

    @property
    def i_d_limit_fraction(self) -> float:
        """Fraction of the ``i_d`` axis limit: ``i_d_fraction``, else :attr:`axis_limit_fraction`."""
        return self.axis_limit_fraction if self.i_d_fraction is None else self.i_d_fraction


#: Shares of the move the horizontal axis may spend accelerating with ``d_timing: free`` (0.5: symmetric).
D_SPLITS: tuple[float, ...] = (0.5, 0.45, 0.55, 0.4, 0.6, 0.35, 0.65)
#: Shares of the gap's part of the move the gap may spend accelerating with ``gap_timing: free``.
GAP_SPLITS: tuple[float, ...] = (0.5, 0.35, 0.65, 0.2, 0.8)
#: Shares of the move's duration the gap may take with ``gap_timing: free`` (the fastest move is kept).
GAP_SHARES: tuple[float, ...] = (1.0, 0.75, 0.55, 0.4)
#: Where the gap's part of the move starts, as a fraction of the time left beside it (0: at the start, 1: at the end).
GAP_PLACES: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)
