"""Controllers of the stage, all on the one shared model and one ``step`` interface.

See :mod:`maglev_ocp.blocks` for the interface (``reset(y0, ref)``,
``step(y, ref) -> ControlOutput``).
"""
