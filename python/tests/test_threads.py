"""Long calls release the GIL: Python keeps running while they work, so threads run fits side
by side, each giving what it gives alone."""

import threading

import numpy as np

import sid

import tx40


def test_identify_and_smooth_release_the_gil():
    t, q, tau = tx40.samples()
    run = sid.Run(t, q, tau)
    results = {}

    def work():
        results["fit"] = sid.identify(tx40.robot(), run)
        x = np.linspace(0.0, 1.0, 2_000_000)
        results["spline"] = sid.smooth(x, np.sin(x), lam=1e-6)

    worker = threading.Thread(target=work)
    ticks = 0
    worker.start()
    while worker.is_alive():
        ticks += 1  # runs only while the worker's call has let go of the GIL
    worker.join()
    # Held, the GIL would let this loop run only in the switch intervals around the worker's
    # Python lines (about 7e4 ticks beside three 80 ms GIL-holding calls here). Released, it
    # runs throughout the second of compiled work (about 5e6 ticks here).
    assert ticks > 1_000_000
    alone = sid.identify(tx40.robot(), run)
    np.testing.assert_array_equal(results["fit"].theta, alone.theta)


def test_fits_in_threads_equal_fits_in_turn():
    t, q, tau = tx40.samples()
    halves = [sid.Run(t[:4500], q[:4500], tau[:4500]), sid.Run(t[4500:], q[4500:], tau[4500:])]
    in_turn = [sid.identify(tx40.robot(), r).theta for r in halves]
    out = [None, None]

    def fit(i):
        out[i] = sid.identify(tx40.robot(), halves[i]).theta

    threads = [threading.Thread(target=fit, args=(i,)) for i in range(2)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for a, b in zip(out, in_turn):
        np.testing.assert_array_equal(a, b)
