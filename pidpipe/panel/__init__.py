"""The panel: a simply supported sandwich plate's modes, and the particles' layout on a mode.

:mod:`.plate` (the sandwich's stiffnesses and its Navier modes), :mod:`.cells` (the honeycomb
cells' centres on the plate), :mod:`.loss` (a layout's added loss factor on a mode),
:mod:`.mass` (the particles' effective mass from the m_eff surrogate), :mod:`.layout` (the
layouts compared and the optimised one), :mod:`.response` (a layout at a modal force, solved to
consistency), :mod:`.uncertainty` (C_eq models with a standard deviation), :mod:`.check` (the
DEM check of a mode: compiled-DEM cells along the mode shape, coupled two ways).
"""
