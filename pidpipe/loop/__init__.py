"""Closing the loop: the designs checked by DEM, and the C_eq model checked on a vibrating host.

:mod:`.verify` shakes each environment's band_mean and peak design at its fill on the band's
corners and centre and compares the DEM's C_eq with the surrogate's prediction.

A single-degree-of-freedom host carries a design's filled cells and is forced around its
resonance; :mod:`.coupled_sweep` runs it coupled to the compiled DEM
(:mod:`pidpipe.dem.coupled`), :mod:`.equivalent` replaces the cells by the surrogate's C_eq as a
linear dashpot (:mod:`.sdof` is the analytic single-degree-of-freedom response), and
:mod:`.compare` reads the two amplitude-frequency curves: peak amplitude, peak frequency,
equivalent loss factor. :mod:`.host` puts them together for one design.
"""
