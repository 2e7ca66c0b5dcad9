import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"


@pytest.fixture
def data() -> Path:
    return DATA


@pytest.fixture
def cli():
    """The sid_identify built beside the package (SID_APPS_DIR), to compare with; else skip."""
    apps = os.environ.get("SID_APPS_DIR")
    tool = Path(apps) / "sid_identify" if apps else None
    if tool is None or not tool.exists():
        pytest.skip("SID_APPS_DIR does not hold sid_identify")
    return tool
