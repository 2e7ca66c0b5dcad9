"""sid.diagnose gives sid_diagnose --robot's result on the same data; plots draw."""

import json
import re
import subprocess

import numpy as np
import pytest

import sid

import tx40


@pytest.fixture(scope="module")
def tx40_csv(tmp_path_factory):
    return tx40.write_csv(tmp_path_factory.mktemp("tx40") / "tx40.csv")


@pytest.fixture(scope="module")
def diagnosis(tx40_csv):
    return sid.diagnose(tx40.robot(), sid.Run.from_csv(tx40_csv))


def test_names_the_real_tx40s_coulomb_friction(diagnosis):
    # The real TX40's drives show Coulomb friction on joints 1-5 and the coupled wrist motor
    # (docs/discrepancy-workflow.md), and neither a spring nor a torque offset.
    named = {t.id for t in diagnosis.named}
    assert named == {f"coulomb_j{j}" for j in range(1, 6)} | {"coulomb_m6"}
    for t in diagnosis.named:
        assert t.value > 5 * t.std and t.unit == "N m" and t.reason == ""
    for t in diagnosis.not_named:
        assert t.reason
        if t.reason.startswith("not significant"):
            assert abs(t.value) <= t.detection_limit
    assert np.all(diagnosis.final_residual_rms <= diagnosis.nominal_residual_rms)
    assert diagnosis.noise_floor.shape == (6,)
    # GCV leaves the real log's angles at the top of its range: smoothed as sid_identify does.
    assert "held-out torque prediction" in diagnosis.smoothing
    assert diagnosis.cutoff_hz.shape == (6,)


def test_gives_the_clis_result(tx40_csv, diagnosis, cli, tmp_path):
    out = tmp_path / "diagnosis.json"
    subprocess.run(
        [str(cli.parent / "sid_diagnose"), "--robot", str(tx40.URDF), "--transmission",
         str(tx40.TRANSMISSION), "--json", str(out), "--report", str(tmp_path / "d.html"),
         str(tx40_csv)],
        check=True, capture_output=True,
    )
    expected = json.loads(out.read_text())
    got = diagnosis.to_dict()
    assert set(got) == set(expected)
    assert [t["id"] for t in got["named"]] == [t["id"] for t in expected["named"]]
    np.testing.assert_allclose([t["value"] for t in got["named"]],
                               [t["value"] for t in expected["named"]], rtol=1e-12)
    assert diagnosis.motion_not_explained == expected["free_simulation"]["beyond"]
    assert diagnosis.smoothing == expected["smoothing"]
    np.testing.assert_array_equal(diagnosis.cutoff_hz, expected["cutoff_hz"])
    # The same page, but for the wall times it reports.
    def timeless(page):
        return re.sub(r"[0-9.]+ s \(the free simulations [0-9.]+ s\)", "", page)

    page = diagnosis.report_html()
    assert page.startswith("<!DOCTYPE html>") and "<svg" in page
    assert timeless(page) == timeless((tmp_path / "d.html").read_text())


def test_bad_input_raises_value_error(tx40_csv):
    run = sid.Run.from_csv(tx40_csv)
    with pytest.raises(ValueError, match="candidates"):
        sid.diagnose(tx40.robot(), run, candidates="gravity_waves")
    with pytest.raises(ValueError, match="negligible"):
        sid.diagnose(tx40.robot(), run, negligible_size=2.0)
    with pytest.raises(ValueError, match="no run"):
        sid.diagnose(tx40.robot(), [])


def test_plots_the_fit_and_the_diagnosis(diagnosis, tx40_csv, tmp_path):
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    fit = sid.identify(tx40.robot(), sid.Run.from_csv(tx40_csv))
    figure = fit.plot()
    assert len(figure.axes) == 12  # per joint: torques, residual
    figure.savefig(tmp_path / "fit.png")
    ax = diagnosis.plot()
    labels = [t.get_text() for t in ax.texts]
    assert any(label.startswith("coulomb_j2") for label in labels)
    ax.figure.savefig(tmp_path / "diagnosis.png")
    with pytest.raises(ValueError, match="run must be"):
        fit.plot(run=3)
