"""Fixtures shared across the test packages."""

from collections.abc import Callable
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "scenarios"


@pytest.fixture
def quick_scenario(tmp_path) -> Callable[..., Path]:
    """Write a bundled scenario into ``tmp_path`` with absolute file paths and overrides.

    ``quick_scenario("linear_peripheral", path__spacing_mm=2.0)`` sets ``path.spacing_mm``.
    """

    def write(name: str = "linear_peripheral", **changes) -> Path:
        doc = yaml.safe_load((SCENARIOS / f"{name}.yaml").read_text())
        doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
        doc["tool"] = str(SCENARIOS / doc["tool"])
        doc["material"] = str(SCENARIOS / doc["material"])
        if doc["path"].get("file"):
            doc["path"]["file"] = str(SCENARIOS / doc["path"]["file"])
        for dotted, value in changes.items():
            section, key = dotted.split("__")
            doc.setdefault(section, {})[key] = value
        p = tmp_path / f"{name}.yaml"
        p.write_text(yaml.safe_dump(doc))
        return p

    return write


# Hypothesis profiles (tests/properties, issue 17). Registered here, in the conftest pytest reads
# at startup, so that `pytest --hypothesis-profile=nightly` finds them. "ci" is the default: it
# is repeatable (derandomize) and keeps no example database in the repository.
from hypothesis import HealthCheck, settings  # noqa: E402

settings.register_profile("ci", max_examples=100, deadline=None, derandomize=True, database=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("nightly", parent=settings.get_profile("ci"), max_examples=2000,
                          derandomize=False)
settings.load_profile("ci")


def load_benchmark(name: str):
    """``benchmarks/<name>.py`` imported as module ``name`` (registered in sys.modules:
    dataclasses look their module up)."""
    import importlib.util
    import sys

    spec = importlib.util.spec_from_file_location(name, ROOT / "benchmarks" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod
