"""The plant simulator (the stand-in for the rig) and its settings.

>>> from maglev_ocp.plant import Plant, PlantConfig, load_plant_config, StopEvent
>>> cfg = PlantConfig.from_profile("default")          # or load_plant_config("my_rig.yaml")
>>> plant = Plant(cfg, params=NOMINAL, seed=7)
>>> y = plant.reset()                                  # Measurement at t = 0
>>> y = plant.step([0.0, 1.5])                         # ZOH over Ts, Measurement at t + Ts
>>> plant.log.save("run.csv")

See :mod:`maglev_ocp.plant.plant` for the integration, :mod:`maglev_ocp.plant.config`
for the YAML settings, and ``profiles/`` for the ``default`` and ``ideal`` rig profiles.
"""

from .config import PlantConfig, available_profiles, load_plant_config
from .plant import Plant, StopEvent, build_step

__all__ = ["Plant", "PlantConfig", "StopEvent", "available_profiles", "build_step", "load_plant_config"]
