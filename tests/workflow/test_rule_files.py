"""The rule files' layout (workflow/rules/*.smk, workflow/report): read, not run."""

from __future__ import annotations

import re

from pidpipe.config import REPO_ROOT

RULES = REPO_ROOT / "workflow" / "rules"


def _rule_files():
    return sorted(RULES.glob("*.smk"))


def test_helpers_live_in_common_smk_only():
    for path in _rule_files():
        if path.name != "common.smk":
            text = path.read_text(encoding="utf-8")
            assert not re.search(r"^\s*(def|import|from)\s", text, re.M), path.name


def test_the_case_and_packing_patterns_are_spelled_once():
    """Rules spell their paths with CASE_PATTERN and PACKING_PATTERN (common.smk)."""
    for path in _rule_files():
        text = path.read_text(encoding="utf-8")
        if path.name == "common.smk":
            assert text.count('"r{fill}pct_rep{replicate}"') == 1
        else:
            assert "pct_rep{replicate}" not in text, path.name


def test_no_rule_is_switched_off_by_a_pattern_that_never_matches():
    for path in _rule_files():
        assert "(?!)" not in path.read_text(encoding="utf-8"), path.name
    assert "NEVER_MATCHES" not in (REPO_ROOT / "pidpipe" / "steps" / "params.py").read_text()


def test_report_categories_are_numbered_once_each():
    categories = set()
    for path in _rule_files():
        categories |= set(re.findall(r'category="([^"]+)"', path.read_text(encoding="utf-8")))
    numbers = [re.match(r"(\d+)\. ", c).group(1) for c in categories]
    assert len(numbers) == len(set(numbers)), sorted(categories)
    assert sorted(map(int, numbers)) == list(range(1, len(numbers) + 1)), sorted(categories)


def test_every_engine_has_its_rule_file():
    from pidpipe.config.sections import ENGINES

    for engine in ENGINES:
        assert (RULES / f"simulate_{engine}.smk").is_file()
