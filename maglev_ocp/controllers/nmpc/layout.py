"""Layout of the NMPC step's packed vectors: the controller state, the measurement and the statistics.

The step Function ``nmpc_step(state_in, meas, ref, p) -> (u, state_out, stats,
x_hat)`` keeps all its memory in one flat vector; :class:`StateLayout` says
where each piece lives and documents it (size, unit, meaning), which is the
table the code generator writes into the C header. ``ref`` has the rows of
:data:`maglev_ocp.signals.REF_FIELDS`, one column per shooting node.
"""

from __future__ import annotations

from dataclasses import dataclass

NX, NU = 4, 2  #: states (g, g_dot, d, d_dot) and inputs (i_q, i_d)
N_MEAS = 3  #: meas = (g, d, fault)  [m, m, -]
STATUS_OK, STATUS_INACCURATE, STATUS_FALLBACK = 0, 1, 2
STATUS_TEXT = {STATUS_OK: "ok", STATUS_INACCURATE: "inaccurate", STATUS_FALLBACK: "fallback"}

#: The ``meas`` input: name, unit, meaning.
MEAS_TABLE: tuple[tuple[str, str, str], ...] = (
    ("g", "m", "air gap reading"),
    ("d", "m", "horizontal reading"),
    ("fault", "-", "test flag, 0 in operation"),
)

#: The ``stats`` output: name, unit, meaning (in order).
STATS_TABLE: tuple[tuple[str, str, str], ...] = (
    ("status", "-", "0 ok, 1 inaccurate (ADMM residuals above tolerance), 2 fallback"),
    ("fallback", "-", "1 when the LQR fallback was applied"),
    ("iterations", "-", "ADMM iterations run (fixed budget)"),
    ("iters_to_tol", "-", "first residual checkpoint below tolerance"),
    ("qp_r_prim", "A or mm", "ADMM primal residual (infinity norm)"),
    ("qp_r_dual", "scaled", "ADMM dual residual (infinity norm)"),
    ("plan_t", "s", "time since the planned move started"),
    ("plan_T", "s", "duration of the planned move"),
    ("dist_g", "m/s^2", "gap disturbance estimate"),
    ("dist_d", "m/s^2", "horizontal disturbance estimate"),
    ("n_fail", "-", "consecutive fallbacks"),
)
STATS_NAMES: tuple[str, ...] = tuple(name for name, _, _ in STATS_TABLE)


@dataclass(frozen=True)
class StateLayout:
    """Offsets and documentation of the pieces of the NMPC's state vector (``state_in`` / ``state_out``).

    Pieces: ``xhat`` (4) observer state, ``dist`` (2) acceleration disturbance
    [m/s^2], ``u_prev`` (2) last applied currents [A], ``fresh`` (1) 1 right
    after reset (skip the observer prediction once), ``plan`` (7) planner
    ``(g_start, d_start, g_target, d_target, t, h, tj)``, ``X`` ((N+1) x 4)
    shooting nodes, ``U`` (N x 2) currents, ``y`` ADMM duals (2N + n_gap),
    ``nfail`` (1) consecutive fallbacks and, with a computation delay of
    ``n_delay`` periods, ``u_flight`` (n_delay x 2) the commands sent but not
    yet applied, oldest first (then ``u_prev`` is the command applied over the
    last period, the one sent ``n_delay + 1`` periods ago); with ``n_adapt``
    adapted constants, ``theta`` their relative errors and ``ups`` the
    observer's sensitivities to them.
    """

    N: int
    n_gap: int
    n_delay: int = 0
    n_adapt: int = 0

    @property
    def pieces(self) -> tuple[tuple[str, int], ...]:
        """Names and sizes in order."""
        return tuple((name, size) for name, size, _, _ in self.table())

    def table(self) -> tuple[tuple[str, int, str, str], ...]:
        """The port table: ``(name, size, unit, meaning)`` of every piece, in order."""
        N = self.N
        return (
            (
                ("xhat", NX, "m, m/s", "observer estimate (g, g_dot, d, d_dot)"),
                ("dist", 2, "m/s^2", "acceleration disturbance estimate (gap, horizontal)"),
                ("u_prev", NU, "A", "currents applied over the last period (i_q, i_d)"),
                ("fresh", 1, "-", "1 right after nmpc_init (the observer skips one prediction), else 0"),
                ("plan", 7, "m, m, m, m, s, s, s", "move planner (g_start, d_start, g_target, d_target, t, h, tj)"),
                ("X", (N + 1) * NX, "m, m/s", f"shooting nodes, {N + 1} columns of (g, g_dot, d, d_dot), column-major"),
                ("U", N * NU, "A", f"planned currents, {N} columns of (i_q, i_d), column-major"),
                (
                    "y",
                    N * NU + self.n_gap,
                    "A / mm scaled",
                    f"ADMM duals: {NU * N} current rows, then {self.n_gap} soft gap rows",
                ),
                ("nfail", 1, "-", "consecutive fallbacks"),
            )
            + (
                (
                    (
                        "u_flight",
                        self.n_delay * NU,
                        "A",
                        f"{self.n_delay} commands sent but not yet applied (computation delay), oldest first",
                    ),
                )
                if self.n_delay
                else ()
            )
            + (
                (
                    ("theta", self.n_adapt, "-", "relative errors of the adapted model constants (settings.adapt)"),
                    (
                        "ups",
                        6 * self.n_adapt,
                        "m, m/s, m/s^2",
                        "sensitivities of (g, g_dot, a_g, d, d_dot, a_d) estimates to them, one column each",
                    ),
                    ("cov", self.n_adapt**2, "-", "covariance of their estimate (recursive least squares)"),
                    ("since", 1, "periods", "periods since the reference last moved (the update's window)"),
                    ("age", 1, "periods", "periods since nmpc_init (no update during the observer's start-up)"),
                    ("noise", 2, "m^2", "mean square of the innovation per axis while the constants are not updated"),
                )
                if self.n_adapt
                else ()
            )
        )

    @property
    def size(self) -> int:
        """Length of the state vector."""
        return sum(n for _, n in self.pieces)

    def slices(self) -> dict[str, slice]:
        """Slice of each piece."""
        out, i = {}, 0
        for name, n in self.pieces:
            out[name] = slice(i, i + n)
            i += n
        return out

    def split(self, v):
        """Dict of the pieces of ``v`` (numpy array or CasADi vector)."""
        return {name: v[s] for name, s in self.slices().items()}


__all__ = [
    "MEAS_TABLE",
    "NU",
    "NX",
    "N_MEAS",
    "STATS_NAMES",
    "STATS_TABLE",
    "STATUS_FALLBACK",
    "STATUS_INACCURATE",
    "STATUS_OK",
    "STATUS_TEXT",
    "StateLayout",
]
