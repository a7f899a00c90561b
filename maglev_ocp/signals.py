"""Names and units of every signal: log columns, plot labels and model I/O.

One table, so that a column in a rig log, a label on a plot and an entry of a
CasADi Function all say the same thing.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Signal:
    """A named physical signal.

    Parameters
    ----------
    name : str
        Column / variable name (``g``, ``i_q``, ...).
    unit : str
        SI unit as printed on plots.
    description : str
        One line saying what the signal is.
    """

    name: str
    unit: str
    description: str

    @property
    def label(self) -> str:
        """Plot label with unit, e.g. ``"g [m]"``."""
        return f"{self.name} [{self.unit}]"


STATES: tuple[Signal, ...] = (
    Signal("g", "m", "air gap (stator teeth to magnet surface)"),
    Signal("g_dot", "m/s", "air-gap rate"),
    Signal("d", "m", "horizontal position"),
    Signal("d_dot", "m/s", "horizontal velocity"),
)
INPUTS: tuple[Signal, ...] = (
    Signal("i_q", "A", "quadrature current (thrust)"),
    Signal("i_d", "A", "direct current (normal force)"),
)
MEASUREMENTS: tuple[Signal, ...] = (
    Signal("g", "m", "air gap as read by its 10 µm encoder"),
    Signal("d", "m", "horizontal position as read by its 10 µm encoder"),
)
PARAMETERS: tuple[Signal, ...] = (
    Signal("C1", "m/s^2/A", "lumped thrust constant"),
    Signal("C2", "m/s^2/T^2", "lumped PM attraction constant"),
    Signal("C3", "m/s^2/(T A)", "lumped PM-current normal-force constant"),
    Signal("C4", "m/s^2/A^2", "lumped reluctance normal-force constant"),
    Signal("xi0", "N", "peak cogging force at g = 10 mm"),
    Signal("ell", "m", "decay length of the peak cogging force"),
    Signal("Mh", "kg", "horizontal moving mass"),
    Signal("Mv", "kg", "vertical moving mass"),
)

STATE_NAMES: tuple[str, ...] = tuple(s.name for s in STATES)
INPUT_NAMES: tuple[str, ...] = tuple(s.name for s in INPUTS)
PARAM_NAMES: tuple[str, ...] = tuple(s.name for s in PARAMETERS)

_ALL = {s.name: s for s in (*STATES, *INPUTS, *PARAMETERS)}
_ALL.update(
    {
        "t": Signal("t", "s", "time"),
        "g_ref": Signal("g_ref", "m", "gap reference"),
        "d_ref": Signal("d_ref", "m", "horizontal reference"),
        "g_true": Signal("g_true", "m", "true gap (simulation only)"),
        "d_true": Signal("d_true", "m", "true horizontal position (simulation only)"),
        "g_dot_true": Signal("g_dot_true", "m/s", "true gap rate (simulation only)"),
        "d_dot_true": Signal("d_dot_true", "m/s", "true horizontal velocity (simulation only)"),
        "g_dot_hat": Signal("g_dot_hat", "m/s", "estimated gap rate"),
        "d_dot_hat": Signal("d_dot_hat", "m/s", "estimated horizontal velocity"),
        "step_time_us": Signal("step_time_us", "us", "controller computation time"),
    }
)


def signal(name: str) -> Signal:
    """Return the :class:`Signal` called ``name`` (KeyError if unknown)."""
    return _ALL[name]


def label(name: str) -> str:
    """Plot label with unit for ``name``; the bare name if it is not registered."""
    return _ALL[name].label if name in _ALL else name


#: Rows of a reference sample, in the order every controller's reference input uses
#: (FL's ``ref`` vector, the NMPC's reference matrix, one column per node) with units.
def _reference_axis(axis: str, position: str, rate: str, acceleration: str) -> tuple[Signal, Signal, Signal]:
    """The reference rows of one axis: its position and the position's first two time derivatives."""
    return (
        Signal(axis, "m", f"reference {position}"),
        Signal(f"{axis}_dot", "m/s", f"reference {rate}"),
        Signal(f"{axis}_ddot", "m/s^2", f"reference {acceleration}"),
    )


REFERENCE: tuple[Signal, ...] = (
    *_reference_axis("g", "air gap", "air-gap rate", "air-gap acceleration"),
    *_reference_axis("d", "horizontal position", "horizontal velocity", "horizontal acceleration"),
)
REF_FIELDS: tuple[str, ...] = tuple(s.name for s in REFERENCE)
