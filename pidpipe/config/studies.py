"""Typed, frozen settings of the studies beside the campaign: ``fidelity_study`` and ``scene``.

Each is parsed from a validated config (:func:`pidpipe.config.validate_config`) and checks what
the schema cannot (unique names and cases, a baseline that names a variant), naming the key.
The studies themselves (:mod:`pidpipe.studies.fidelity`, :mod:`pidpipe.studies.scene`) read
these settings by attribute.
"""

from __future__ import annotations

from dataclasses import dataclass

from pidpipe.cases import CaseSpec
from pidpipe.errors import ConfigError

#: The name of the fidelity study's reference setting (no variant may take it).
REFERENCE = "reference"


@dataclass(frozen=True)
class StudyCase:
    """A case of a study: frequency (Hz), acceleration amplitude (g) and, for the fidelity
    study, fill (percent), the numbers as the config wrote them."""

    freq_hz: float
    accel_g: float
    fill_pct: float | None = None

    def __post_init__(self) -> None:
        if not (self.freq_hz > 0 and self.accel_g > 0
                and (self.fill_pct is None or 0 < self.fill_pct <= 100)):
            raise ConfigError(f"a study case needs freq_hz > 0, accel_g > 0 and fill_pct in "
                              f"(0, 100]; got {self}")


@dataclass(frozen=True)
class StudyVariant:
    """A variant of the fidelity settings (an entry of ``fidelity_study.variants``).

    Attributes
    ----------
    name, label : str
        Its name (file names, the table's variant column) and legend label ("" : the name).
    changes_physics : bool
        It changes the modelled physics (friction or rotation off), not the numerics.
    fidelity : dict
        Values that replace the campaign's ``fidelity`` values.
    """

    name: str
    label: str = ""
    changes_physics: bool = False
    fidelity: dict | None = None


@dataclass(frozen=True)
class FidelityStudySettings:
    """The fidelity study (``fidelity_study``; ``snakemake --cores 2 fidelity``).

    Attributes
    ----------
    cases : tuple of StudyCase
        Reference cases (replicate 0), in config order; no case twice.
    reference : dict
        The reference setting's fidelity overrides.
    variants : tuple of StudyVariant
        The settings compared with the reference; unique names, none ``reference``.
    baseline : str
        The variant CPU costs are relative to.
    error_target_fraction : float
        The summary's error target, a fraction of C_eq.
    """

    cases: tuple[StudyCase, ...]
    reference: dict
    variants: tuple[StudyVariant, ...]
    baseline: str
    error_target_fraction: float

    def __post_init__(self) -> None:
        seen = set()
        for index, case in enumerate(self.cases):
            case_id = CaseSpec(float(case.freq_hz), float(case.accel_g),
                               float(case.fill_pct)).case_id
            if case_id in seen:
                entry = {"freq_hz": case.freq_hz, "accel_g": case.accel_g,
                         "fill_pct": case.fill_pct}
                raise ConfigError(f"config key fidelity_study.cases[{index}] = {entry!r} is not "
                                  "allowed: this case is listed twice")
            seen.add(case_id)
        names = {REFERENCE}
        for index, variant in enumerate(self.variants):
            if variant.name in names:
                why = ("reserved for the reference" if variant.name == REFERENCE
                       else "another variant has it")
                raise ConfigError(f"config key fidelity_study.variants[{index}].name = "
                                  f"{variant.name!r} is not allowed: {why}")
            names.add(variant.name)
        if self.baseline not in names - {REFERENCE}:
            raise ConfigError(f"config key fidelity_study.baseline = {self.baseline!r} is not "
                              f"allowed: it must name one of the variants "
                              f"({', '.join(v.name for v in self.variants)})")
        if not self.error_target_fraction > 0:
            raise ConfigError(f"config key fidelity_study.error_target_fraction = "
                              f"{self.error_target_fraction!r} is not allowed: it must be > 0")

    @classmethod
    def from_config(cls, config: dict) -> "FidelityStudySettings":
        study = config["fidelity_study"]
        cases = tuple(StudyCase(c["freq_hz"], c["accel_g"], c["fill_pct"]) for c in study["cases"])
        variants = tuple(StudyVariant(str(v["name"]), str(v.get("label") or ""),
                                      bool(v.get("changes_physics")), dict(v.get("fidelity") or {}))
                         for v in study["variants"])
        return cls(cases, dict(study["reference"]), variants, str(study["baseline"]),
                   float(study["error_target_fraction"]))

    def key_of(self, name: str) -> str:
        """The config key that holds a setting's fidelity overrides."""
        if name == REFERENCE:
            return "fidelity_study.reference"
        index = [v.name for v in self.variants].index(name)
        return f"fidelity_study.variants[{index}].fidelity"


@dataclass(frozen=True)
class SceneSettings:
    """The scene study (``scene``; ``snakemake --cores 2 scene``).

    Attributes
    ----------
    cases : tuple of StudyCase
        (frequency, acceleration) of each scene, at the fill ``fill_pct``.
    fill_pct : float
        Fill of every cell, percent.
    singles : int
        Replicate packings shaken alone, one run each (at least 19, the larger patch).
    coupon_columns, coupon_rows : int
        The coupon's cells across and along.
    coupon_cpu_limit_s : float
        Largest CPU time of the coupon's run, s.
    """

    cases: tuple[StudyCase, ...]
    fill_pct: float = 50.0
    singles: int = 19
    coupon_columns: int = 21
    coupon_rows: int = 21
    coupon_cpu_limit_s: float = 1200.0

    def __post_init__(self) -> None:
        if not self.cases:
            raise ConfigError("config key scene.cases is not allowed empty: list at least one "
                              "{freq_hz, accel_g}")
        if self.singles < 19 or self.coupon_columns < 1 or self.coupon_rows < 1:
            raise ConfigError(f"config key scene needs singles >= 19 and coupon_columns, "
                              f"coupon_rows >= 1; got {self.singles}, {self.coupon_columns}, "
                              f"{self.coupon_rows}")
        if not (0 < self.fill_pct <= 100 and self.coupon_cpu_limit_s > 0):
            raise ConfigError(f"config key scene needs 0 < fill_pct <= 100 and "
                              f"coupon_cpu_limit_s > 0; got {self.fill_pct}, "
                              f"{self.coupon_cpu_limit_s}")

    @classmethod
    def from_config(cls, config: dict) -> "SceneSettings":
        scene = config["scene"]
        return cls(tuple(StudyCase(c["freq_hz"], c["accel_g"]) for c in scene["cases"]),
                   float(scene["fill_pct"]), int(scene["singles"]), int(scene["coupon_columns"]),
                   int(scene["coupon_rows"]), float(scene["coupon_cpu_limit_s"]))

    @property
    def coupon_cells(self) -> int:
        """Cells of the coupon, columns x rows."""
        return self.coupon_columns * self.coupon_rows
