"""The particles' effective mass in a mode's modal mass, read from the campaign's m_eff surrogate.

A filled cell adds m_eff,i phi_i^2 to the modal mass (:mod:`pidpipe.panel.loss`). Without an m_eff
surrogate the stage takes ``effective_mass_fraction`` of the bed's whole mass (1: the full mass,
the spheres smeared into the plate). With one (``results/surrogate_m_eff.json``, the Gaussian
process of one cell's m_eff(f, G, r), :func:`pidpipe.steps.design.fit_m_eff_surrogate`),
:class:`SurrogateEffectiveMass` reads cell i's m_eff at

- the mode's frequency f (the bare plate's, clipped to the surrogate's domain),
- the cell's own acceleration G_ref |phi_i|, G_ref the antinode's acceleration at which the
  environment is designed (the middle of its band of G), clipped to the domain's highest G,
- the cell's fill r;

a cell whose G_ref |phi_i| lies below the domain's lowest G has its bed resting on the floor and
adds the bed's whole mass (what the surrogate gives there too). The antinode's G is held at the
band's middle: the modal mass does not follow the response's G within the band (the mass enters
eta_p through omega M, and m_eff changes the loaded mode's M by a few per cent on the default
panel; see docs/explanation/panel.md).

:func:`check_m_eff_surrogate` refuses an m_eff surrogate fitted to another C_eq table than the C_eq
surrogate (a stale file): both keep their training rows, and the rows they share must carry
the same C_eq.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pidpipe.errors import TableError

#: designs.csv's ``modal_mass_source`` values.
FULL_MASS = "bed mass x effective_mass_fraction"
SURROGATE_MASS = "m_eff surrogate"
_KEYS = ("freq_hz", "accel_g", "fill_pct")
_CEQ = "ceq_coupon_ns_m"


@dataclass(frozen=True)
class SurrogateEffectiveMass:
    """One cell's m_eff (kg) on one mode, from an m_eff surrogate (module docstring).

    Called as ``mass(fill_pct, spheres, phi_abs)`` (arrays of one shape: fills %, spheres per cell,
    |phi| of the cells) -> m_eff per cell, kg, that shape.

    Attributes
    ----------
    surrogate
        One cell's m_eff(f, G, r), kg: ``predict`` and ``domain`` (:mod:`pidpipe.design.damper`).
    freq_hz : float
        The mode's frequency, Hz.
    accel_g : float
        G_ref, the antinode's acceleration, g.
    sphere_mass_kg : float
        One sphere's mass (a resting bed's m_eff is its whole mass), kg.
    """

    surrogate: object
    freq_hz: float
    accel_g: float
    sphere_mass_kg: float

    def __call__(self, fill_pct, spheres, phi_abs) -> np.ndarray:
        fills, spheres, phi = np.broadcast_arrays(*(np.asarray(v, dtype=float)
                                                    for v in (fill_pct, spheres, phi_abs)))
        domain = self.surrogate.domain
        g = self.accel_g * np.abs(phi)
        resting = g < domain["accel_g"][0]
        f = float(np.clip(self.freq_hz, *domain["freq_hz"]))
        read = np.asarray(self.surrogate.predict(np.full(g.shape, f), np.clip(g, *domain["accel_g"]),
                                                 np.clip(fills, *domain["fill_pct"])), dtype=float)
        return np.where(resting, spheres * self.sphere_mass_kg, read.reshape(g.shape))

    def projected_kg(self, fill_pct, spheres, phi_abs, phi2, accel_g, freq_hz: float) -> np.ndarray:
        """sum_k m_eff(f, G |phi_k|, r_k) w_k at antinode accelerations G, kg, shape (m,).

        Parameters
        ----------
        fill_pct, spheres, phi_abs, phi2 : array_like, shape (k,)
            Per cell (or bin of cells): fill %, spheres per cell, |phi|, and the weight w_k (the
            cell's phi^2, or a bin's sum of phi^2).
        accel_g : array_like, shape (m,)
            G at the antinode, g.
        freq_hz : float
        """
        fills, spheres, phi, weights = (np.asarray(v, dtype=float) for v in (fill_pct, spheres, phi_abs, phi2))
        g = np.atleast_1d(np.asarray(accel_g, dtype=float))[:, None] * np.abs(phi)[None, :]
        domain = self.surrogate.domain
        f = float(np.clip(freq_hz, *domain["freq_hz"]))
        read = np.asarray(self.surrogate.predict(
            np.full(g.shape, f), np.clip(g, *domain["accel_g"]),
            np.broadcast_to(np.clip(fills, *domain["fill_pct"])[None, :], g.shape)), dtype=float)
        mass = np.where(g < domain["accel_g"][0], (spheres * self.sphere_mass_kg)[None, :],
                        read.reshape(g.shape))
        return mass @ weights

    def describe(self) -> str:
        """How the mass is read, for logs and designs.csv."""
        return (f"{SURROGATE_MASS} at {self.freq_hz:.4g} Hz and G {self.accel_g:.3g} g x |phi| "
                "(the bed's whole mass below the surrogate's lowest G)")


def check_m_eff_surrogate(m_eff_surrogate, ceq_surrogate, path: str) -> None:
    """Refuse an m_eff surrogate fitted to another table than the C_eq surrogate.

    Both keep their training rows; the m_eff rows carry the table's ``ceq_coupon_ns_m``. They
    must share at least one grid point, and at every shared one the C_eq must be the same (to
    1e-9 relative).

    Raises
    ------
    TableError
        One line naming the file and what to rerun.
    """
    mine, theirs = getattr(m_eff_surrogate, "training", None), getattr(ceq_surrogate, "training", None)
    if mine is None or theirs is None or _CEQ not in mine or _CEQ not in theirs:
        return
    shared = mine[list(_KEYS) + [_CEQ]].merge(theirs[list(_KEYS) + [_CEQ]], on=list(_KEYS),
                                              suffixes=("_m_eff", "_ceq"))
    stale = (shared.empty or not np.allclose(shared[f"{_CEQ}_m_eff"], shared[f"{_CEQ}_ceq"],
                                             rtol=1e-9, atol=0.0))
    if stale:
        raise TableError(f"m_eff surrogate {path} is stale: it was fitted to another C_eq table "
                         f"than the C_eq surrogate ({'no grid point in common' if shared.empty else 'their C_eq differ'}); "
                         "refit it (snakemake results/surrogate_m_eff.json, or pidpipe panel "
                         "without --m-eff-surrogate)")


__all__ = ["SurrogateEffectiveMass", "check_m_eff_surrogate", "FULL_MASS", "SURROGATE_MASS"]
