"""Library of the effects that the nominal model leaves out (``shared/spec/NOTES.md``).

The library is a package, one module per effect (or small group); every name is re-exported here.

Each effect is a small, physically parametrized class that modifies the shared
model's acceleration contributions (``get_model().accel_terms``) with CasADi
expressions. The same code serves

* the plant simulator (numeric effect parameters, one CasADi Function per set
  of effects, see :mod:`maglev_ocp.plant`), and
* the gap diagnosis, which fits an effect's parameters as a CasADi NLP: it
  builds the modified accelerations from symbolic ``x, u, p`` and the effect
  parameter vector ``theta`` with :meth:`EffectSet.accel` (or the Function from
  :meth:`EffectSet.accel_function`), and takes names, defaults and physical
  bounds from :attr:`Effect.params`.

The nominal model (seed eq. (2) plus the spec's cogging law) is never retyped:
every effect starts from the model's terms ``a_grav, a_pm, a_id, a_rel,
a_cogn`` (vertical) and ``a_thrust, a_cogx`` (horizontal) and scales them or
adds new terms. Composition order is fixed (:data:`EFFECT_ORDER`), so a set of
effects means the same thing whatever order a user lists it in.

The amplifier lag is the one dynamic effect: its applied currents are extra
plant states and its delay is a buffer of whole samples, so it does not act in
:meth:`EffectSet.accel` (which takes the currents the motor actually carries);
use :meth:`AmplifierLag.filter_currents` to turn commanded into applied
currents offline.
"""

from __future__ import annotations

from .amplifier import AmplifierLag
from .base import MAGNETIC_TERMS, Effect, EffectParam, Terms
from .cogging import Cogging
from .commutation import CommutationOffset
from .effectset import EFFECT_ORDER, EFFECTS, EffectSet, effect, effect_delta_function
from .end_effect import EndEffect
from .friction import Friction
from .lumped import EddyDrag, ParameterError
from .saturation import Saturation

__all__ = [
    "EFFECTS",
    "EFFECT_ORDER",
    "MAGNETIC_TERMS",
    "AmplifierLag",
    "Cogging",
    "CommutationOffset",
    "EddyDrag",
    "Effect",
    "EffectParam",
    "EffectSet",
    "EndEffect",
    "Friction",
    "ParameterError",
    "Saturation",
    "Terms",
    "effect",
    "effect_delta_function",
]
