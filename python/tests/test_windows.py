"""sid.identify_windows gives sid_identify --window's numbers, as a table a DataFrame takes."""

import json
import subprocess

import numpy as np
import pytest

import sid

import tx40


@pytest.fixture(scope="module")
def tx40_csv(tmp_path_factory):
    return tx40.write_csv(tmp_path_factory.mktemp("tx40") / "tx40.csv")


def test_gives_the_clis_windows_and_drifts(tx40_csv, cli, tmp_path):
    out = tmp_path / "drift.json"
    subprocess.run(
        [str(cli), "--robot", str(tx40.URDF), "--transmission", str(tx40.TRANSMISSION),
         "--window", "1.5", "--json", str(out), str(tx40_csv)],
        check=True, capture_output=True,
    )
    expected = json.loads(out.read_text())
    w = sid.identify_windows(tx40.robot(), sid.Run.from_csv(tx40_csv), window=1.5)
    assert w.to_dict() == expected
    assert len(w.windows) == len(expected["windows"]) == 6
    p = len(w.parameters)
    assert w.value.shape == w.std_dev.shape == (6, p)
    # A window whose motion leaves a parameter undetermined has null there, NaN here.
    theta = [np.nan if v is None else v for v in expected["windows"][2]["theta"]]
    np.testing.assert_allclose(w.value[2], theta, rtol=1e-15)
    rows = w.rows()
    assert len(rows) == 6 * p
    assert rows[p]["window"] == 1 and rows[p]["parameter"] == w.parameters[0]["name"]
    assert rows[p]["value"] == w.value[1, 0]
    # Six stretches of one real run of a few seconds: nothing drifts, and 1.5 s of this motion
    # do not excite every parameter of a six-axis arm: the windows regroup some differently.
    assert w.drifting() == []
    assert len(w.warnings) == 1 and "determined by some windows only" in w.warnings[0]
    assert "Drift over the operating time" in w.report


def test_refuses_what_it_cannot_do(tx40_csv):
    run = sid.Run.from_csv(tx40_csv)
    with pytest.raises(ValueError, match="is no length"):
        sid.identify_windows(tx40.robot(), run, window="10parsecs")
    with pytest.raises(ValueError, match="the estimators are ls and wls"):
        sid.identify_windows(tx40.robot(), run, estimator="iv")
