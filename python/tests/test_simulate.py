"""sid.simulate gives sid_simulate --robot's log; a hidden term is named by sid.diagnose."""

import subprocess

import numpy as np
import pytest

import sid

import tx40


# The TX40's last link turns no inertia about its axis: the simulated arm gets a rotor there.
ROTOR = "armature_j6:0.01"


def robot():
    return sid.Robot.from_urdf(tx40.URDF)


def test_gives_the_clis_log(cli, tmp_path):
    out = tmp_path / "run.csv"
    subprocess.run(
        [str(cli.parent / "sid_simulate"), "-q", "--robot", str(tx40.URDF), "--T", "2",
         "--Ts", "0.002", "--seed", "7", "--effect", "coulomb_j2:1.5", "--effect", "armature_j6:0.01", "-o",
         str(out)],
        check=True, capture_output=True,
    )
    expected = sid.Run.from_csv(out)
    run = sid.simulate(robot(), duration=2, sample_time=0.002, seed=7,
                       effects=["coulomb_j2:1.5", "armature_j6:0.01"])
    np.testing.assert_allclose(run.t, expected.t, rtol=1e-15)
    np.testing.assert_allclose(run.q, expected.q, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(run.tau, expected.tau, rtol=1e-15, atol=1e-15)


def test_names_the_spring_hidden_in_a_simulated_log():
    run, truth = sid.simulate(robot(), duration=10, sample_time=0.002, seed=3,
                              sigma_tau2=1e-2, effects=[ROTOR, "spring_j3:2"], truth=True)
    assert run.q.shape == (5001, 6) and truth.qdd.shape == (5001, 6)
    # The log is the truth plus noise of the variances asked for.
    assert np.std(run.q - truth.q) == pytest.approx(1e-3, rel=0.05)
    assert np.std(run.tau - truth.tau) == pytest.approx(0.1, rel=0.05)
    assert truth.theta[truth.parameter_names.index("k_3")] == 2.0
    d = sid.diagnose(robot(), run)
    assert [t.id for t in d.named] == ["spring_j3"]
    assert d.named[0].value == pytest.approx(2.0, abs=max(0.1, 4 * d.named[0].std))


def test_bad_options_raise_value_error():
    with pytest.raises(ValueError, match="sample_time"):
        sid.simulate(robot(), sample_time=0.0, effects=ROTOR)
    with pytest.raises(ValueError, match="duration"):
        sid.simulate(robot(), duration=0.001, sample_time=0.002)
    with pytest.raises(ValueError, match="sigma_q2"):
        sid.simulate(robot(), sigma_q2=-1.0)
    with pytest.raises(ValueError, match="bogus_j2"):
        sid.simulate(robot(), effects=["bogus_j2:1"])
    with pytest.raises(ValueError, match="harmonics"):
        sid.simulate(robot(), harmonics=0)
    with pytest.raises(ValueError, match="transmission"):
        sid.simulate(tx40.robot())


def test_excite_designs_a_better_conditioned_motion_the_simulation_follows(tmp_path):
    e = sid.excite(robot(), max_evaluations=40, seed=2)
    assert e.condition_number < e.random_condition_number
    assert e.a.shape == (6, 5) and e.q0.shape == (6,)
    assert "designed excitation: condition number" in e.report
    run, truth = sid.simulate(robot(), duration=10, sample_time=0.01, trajectory=e,
                              effects=ROTOR, truth=True)
    # The trajectory's angle at its start: q0 minus the cosine terms, at rest at t = 0.
    harmonics = np.arange(1, 6)
    w = 2 * np.pi * e.base_frequency
    start = e.q0 - (e.b / (harmonics * w)).sum(axis=1)
    np.testing.assert_allclose(truth.q[0], start, atol=1e-6)
    np.testing.assert_allclose(truth.qd[0], 0.0, atol=1e-6)
    path = tmp_path / "excitation.csv"
    e.write(path)
    with pytest.raises(ValueError, match="exists"):
        e.write(path)
    again = sid.simulate(robot(), duration=10, sample_time=0.01, trajectory=path, effects=ROTOR)
    np.testing.assert_array_equal(again.q, run.q)
    with pytest.raises(ValueError, match="harmonics"):
        sid.excite(robot(), harmonics=1)


def test_montecarlo_gives_the_clis_study(cli, tmp_path):
    out = tmp_path / "study.json"
    subprocess.run(
        [str(cli.parent / "sid_montecarlo"), "--runs", "4", "--levels", "1e-6,1e-4", "--methods",
         "css,oracle", "--seed", "5", "--json", str(out)],
        check=True, capture_output=True,
    )
    import json

    expected = json.loads(out.read_text())
    got = sid.montecarlo(runs=4, levels=(1e-6, 1e-4), methods=["css", "oracle"], seed=5,
                         threads=1)
    assert set(got) == set(expected)
    for a, b in zip(got["levels"], expected["levels"]):
        for method in ("css", "oracle"):
            np.testing.assert_allclose(a["methods"][method]["mean"], b["methods"][method]["mean"],
                                       rtol=1e-12)
    with pytest.raises(ValueError, match="--runs must be >= 2"):
        sid.montecarlo(runs=1)
    with pytest.raises(ValueError, match="unknown method 'magic'"):
        sid.montecarlo(methods="magic")


def test_montecarlo_of_a_chain_gives_the_clis_study(data, cli, tmp_path):
    urdf = data / "urdf" / "arm_hand.urdf"
    out = tmp_path / "study.json"
    subprocess.run(
        [str(cli.parent / "sid_montecarlo"), "--robot", str(urdf), "--tip", "link2", "--runs",
         "2", "--levels", "1e-6", "--methods", "css_gcv", "--duration", "4", "--rate", "200",
         "--seed", "3", "--json", str(out)],
        check=True, capture_output=True,
    )
    import json

    expected = json.loads(out.read_text())
    arm = sid.Robot.from_urdf(urdf, tip="link2")
    got = sid.montecarlo(robot=arm, runs=2, levels=[1e-6], methods="css_gcv", duration=4,
                         rate=200, seed=3, threads=1)
    assert set(got) == set(expected)
    assert json.dumps(got["levels"], sort_keys=True) == json.dumps(expected["levels"],
                                                                   sort_keys=True)
    with pytest.raises(ValueError, match="--rate must be"):
        sid.montecarlo(robot=arm, rate=10)


def test_a_cheap_arms_sensors_as_the_cli(data, cli, tmp_path):
    urdf = data / "urdf" / "arm_hand.urdf"
    arm = sid.Robot.from_urdf(urdf, tip="link2")
    out = tmp_path / "run.csv"
    subprocess.run(
        [str(cli.parent / "sid_simulate"), "-q", "--robot", str(urdf), "--tip", "link2", "--T",
         "2", "--seed", "4", "--encoder-bits", "12,14", "--encoder-ratio", "1,50",
         "--torque-delay", "0.004", "-o", str(out)],
        check=True, capture_output=True,
    )
    expected = sid.Run.from_csv(out)
    run = sid.simulate(arm, duration=2, seed=4, encoder_bits=[12, 14], encoder_ratio=[1, 50],
                       torque_delay=0.004)
    np.testing.assert_allclose(run.q, expected.q, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(run.tau, expected.tau, rtol=1e-15, atol=1e-15)
    step = 2 * np.pi / 4096
    np.testing.assert_allclose(run.q[:, 0] / step, np.round(run.q[:, 0] / step), atol=1e-6)

    study = tmp_path / "study.json"
    subprocess.run(
        [str(cli.parent / "sid_montecarlo"), "--robot", str(urdf), "--tip", "link2", "--runs",
         "2", "--levels", "1e-8", "--methods", "css,css_tcv", "--duration", "3", "--rate", "200",
         "--seed", "3", "--encoder-bits", "12", "--torque-delay", "0.01",
         "--estimate-torque-delay", "0.05", "--json", str(study)],
        check=True, capture_output=True,
    )
    import json

    expected = json.loads(study.read_text())
    got = sid.montecarlo(robot=arm, runs=2, levels=[1e-8], methods="css,css_tcv", duration=3,
                         rate=200, seed=3, threads=1, encoder_bits=12, torque_delay=0.01,
                         estimate_torque_delay=0.05)
    assert got["sensors"] == expected["sensors"]
    assert json.dumps(got["levels"], sort_keys=True) == json.dumps(expected["levels"],
                                                                   sort_keys=True)
    assert len(got["levels"][0]["torque_delays"]) == 2
    with pytest.raises(ValueError, match="study of a robot"):
        sid.montecarlo(encoder_bits=12)
    with pytest.raises(ValueError, match="add css_tcv"):
        sid.montecarlo(robot=arm, estimate_torque_delay=0.01)
