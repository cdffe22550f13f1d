"""Test tiers for the whole tree (tests and doctests): ``slow`` marks what ``make test-fast`` leaves out."""
import pytest

#: Doctests that build whole atlases or run benchmarks (seconds each): slow tier.
SLOW_DOCTESTS = ("neuraluv.atlas.build.build_atlas", "neuraluv.atlas.build.repack", "generated.ours_row")


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: end-to-end runs (whole atlases, the CLI in a subprocess, benchmarks); "
                                       "`make test-fast` deselects them with -m 'not slow'")


def pytest_collection_modifyitems(config, items):
    for item in items:
        if isinstance(item, pytest.DoctestItem) and item.name.endswith(SLOW_DOCTESTS):
            item.add_marker(pytest.mark.slow)
        if isinstance(item, pytest.DoctestItem) and "neuraluv_paper" in item.path.parts:
            item.add_marker(pytest.mark.slow)  # the harness's doctests: benchmarks, not unit tests
