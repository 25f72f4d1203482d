"""The fit policy: which rows a noise-aware surrogate fits and which it drops."""

import numpy as np
import pandas as pd
import pytest

from pidpipe.design.fit_policy import DROP_FLAGS, SPREAD_FLAGS, classify_row, row_flags, split_for_fit

VALUE, SEM = "ceq_coupon_ns_m", "ceq_coupon_sem_ns_m"


def table(rows) -> pd.DataFrame:
    """rows: (status, flags, value, sem)."""
    frame = pd.DataFrame(rows, columns=["status", "flags", VALUE, SEM])
    frame.insert(0, "freq_hz", 100.0 + np.arange(len(frame)))
    return frame


def test_precision_flags_keep_the_row_and_failed_checks_drop_it():
    rows = [("ok", "", 10.0, 1.0)]
    rows += [("flagged", flag, 3.0, 2.0) for flag in SPREAD_FLAGS]
    rows += [("flagged", flag, 3.0, 2.0) for flag in DROP_FLAGS]
    rows += [("flagged", "not_stationary;timestep_check", 3.0, 2.0)]  # one failed check is enough
    fitted, dropped = split_for_fit(table(rows), VALUE, SEM)
    assert list(fitted["flags"]) == ["", *SPREAD_FLAGS]
    assert len(dropped) == len(DROP_FLAGS) + 1
    assert list(dropped["drop_reason"]) == [f"failed check: {f}" for f in DROP_FLAGS] + [
        "failed check: timestep_check"]


def test_failed_missing_non_finite_and_unknown_rows_are_dropped():
    rows = [("failed", "", np.nan, np.nan), ("missing", "", np.nan, np.nan),
            ("flagged", "not_resolved", np.inf, 1.0), ("ok", "", 5.0, np.nan),
            ("ok", "", 5.0, -1.0), ("flagged", "new_check", 5.0, 1.0), ("ok", "", 5.0, 0.0)]
    fitted, dropped = split_for_fit(table(rows), VALUE, SEM)
    assert list(dropped["drop_reason"]) == ["status failed", "status missing", "value not finite",
                                            "SEM not finite", "SEM not finite",
                                            "unknown flag: new_check"]
    assert len(fitted) == 1 and fitted.index[0] == 6  # a zero SEM is a valid (exact) value


def test_replicate_prefixes_are_read_and_replicate_notes_do_not_count():
    assert row_flags("rep1:not_stationary;rep0:failed;rep2:flagged") == ["not_stationary"]
    assert row_flags(np.nan) == [] and row_flags("") == [] and row_flags(None) == []
    assert classify_row("ok", row_flags("rep1:failed"), 4.0, 0.5) == ""
    assert classify_row("flagged", row_flags("rep0:sphere_above_lid"), 4.0, 0.5).startswith("failed")


def test_a_table_without_status_or_flags_fits_every_finite_row():
    frame = pd.DataFrame({"freq_hz": [1.0, 2.0], VALUE: [1.0, np.nan], SEM: [0.1, 0.1]})
    fitted, dropped = split_for_fit(frame, VALUE, SEM)
    assert list(fitted.index) == [0] and list(dropped["drop_reason"]) == ["value not finite"]


def test_a_generic_value_column_and_a_missing_one():
    frame = pd.DataFrame({"m_eff_cell_kg": [1e-4, 2e-4], "m_eff_cell_sem_kg": [1e-5, np.nan]})
    fitted, _ = split_for_fit(frame, "m_eff_cell_kg", "m_eff_cell_sem_kg")
    assert list(fitted.index) == [0]
    with pytest.raises(KeyError):
        split_for_fit(frame, VALUE, SEM)


def test_every_flag_the_campaign_writes_is_classed():
    # the measurement's flags by their constants; the checks of pidpipe.liggghts.shake and
    # pidpipe.dem.case are written as literals there
    from pidpipe.measurement.adaptive import TARGET_NOT_REACHED, UNSTEADY_FLAGS
    from pidpipe.measurement.harmonics import LEDGER_FLAG
    from pidpipe.measurement.steady_state import SIGN_FLAGS

    written = {"sphere_below_floor", "sphere_above_lid", "timestep_check", "ledger_mismatch",
               TARGET_NOT_REACHED, LEDGER_FLAG, *UNSTEADY_FLAGS, *SIGN_FLAGS}
    assert written == set(DROP_FLAGS) | set(SPREAD_FLAGS)
    assert not set(DROP_FLAGS) & set(SPREAD_FLAGS)
