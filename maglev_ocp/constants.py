"""Hardware constants, actuator limits and stroke of the 2-DOF stage.

Everything here is fixed by ``shared/spec/MODEL.md`` (the seed paper's Table I
plus the choices the spec makes where the paper is silent). SI units.
"""

from __future__ import annotations

import math

# --- Table I of the seed paper -------------------------------------------------
b0: float = 12.7e-3  #: stator slot width [m]
t1: float = 19.05e-3  #: stator slot pitch [m]
W: int = 900  #: turns per phase [-]
p_pairs: int = 3  #: stator pole pairs [-]
hm: float = 5e-3  #: magnet height [m]
LA: float = 50e-3  #: magnet length (depth) [m]
pm: int = 4  #: number of magnets [-]
tau: float = 57.15e-3  #: pole pitch [m]
taup: float = 28.58e-3  #: magnet width [m]
Hc: float = 875400.0  #: magnet coercivity [A/m]
Mh: float = 1.594  #: horizontal moving mass [kg]
Mv: float = 4.350  #: vertical moving mass [kg]
G: float = 9.81  #: gravitational acceleration [m/s^2]
mu0: float = 4.0 * math.pi * 1e-7  #: vacuum permeability [H/m]
mu_rec: float = 1.05  #: magnet recoil permeability (assumed, NdFeB) [-]
Br: float = mu0 * Hc  #: magnet remanence used by B(g) [T]

# --- Rig timing and sensors ------------------------------------------------------
Ts: float = 1e-3  #: control period [s] (1 kHz, zero-order hold on the currents)
encoder_resolution: float = 1e-5  #: linear encoder resolution [m]

# --- Actuator limits and stroke ----------------------------------------------------
i_axis_max: float = 8.0  #: bound on each of i_q and i_d [A]
i_amp_max: float = 8.0  #: bound on sqrt(i_q^2 + i_d^2) [A]
g_stop: tuple[float, float] = (8e-3, 32e-3)  #: mechanical stops of the gap [m]
d_stop: tuple[float, float] = (-60e-3, 60e-3)  #: mechanical stops of d [m]
g_envelope: tuple[float, float] = (15e-3, 25e-3)  #: tracking envelope, gap [m]
d_envelope: tuple[float, float] = (-50e-3, 50e-3)  #: tracking envelope, d [m]
position_tolerance: float = 1e-4  #: positioning target on both axes [m]

# --- Cogging law reference point -----------------------------------------------------
g_cog_ref: float = 0.010  #: gap at which xi(g) = xi0 [m]
