"""The plugin keeps bwbench's backend contract (run with the plugin installed)."""

from bwbench.engine import registry
from bwbench.testing import check_backend


def test_registered_through_the_entry_point():
    assert registry.get("example-coordinate-search").family == "plugin"


def test_keeps_the_contract():
    check_backend("example-coordinate-search")
