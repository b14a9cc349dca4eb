"""Identification, refinement and sweeps release the interpreter: another
Python thread keeps running while they compute."""

import threading
import time

import frameid
from conftest import CASE1


# Shortest time the calls are measured over: long enough for a hundred ticks
# whatever the speed of the calls (three refinements took 50 ms by 2026-11-28,
# under the 0.05 s the check needs to mean anything).
MIN_SECONDS = 0.2


def ticks_during(call):
    """Runs ``call`` in a thread, again until it has run for ``MIN_SECONDS``;
    counts 1 ms sleeps of this thread meanwhile. Returns (ticks, seconds the
    calls took)."""
    started, done = threading.Event(), threading.Event()
    took = []

    def work():
        started.set()
        t0 = time.perf_counter()
        while True:
            call()
            if time.perf_counter() - t0 >= MIN_SECONDS:
                break
        took.append(time.perf_counter() - t0)
        done.set()

    thread = threading.Thread(target=work)
    thread.start()
    started.wait()
    ticks = 0
    while not done.is_set():
        time.sleep(0.001)
        ticks += 1
    thread.join()
    return ticks, took[0]


def check(call):
    ticks, seconds = ticks_during(call)
    # Holding the interpreter would stall this thread for the whole call
    # (a tick or two at its edges); released, it ticks about once a
    # millisecond. A tenth of that allows for a loaded machine.
    assert seconds > 0.05, seconds
    assert ticks > 0.1 * seconds / 0.001, (ticks, seconds)


def test_identify_with_refinement_releases_the_interpreter(case1):
    camp, _ = case1
    check(lambda: [frameid.identify(camp, refine=True) for _ in range(3)])


def test_sweep_releases_the_interpreter():
    check(lambda: frameid.sweep(CASE1, noise=[0.01], trials=4, seed=2, threads=1))


def test_frf_estimation_and_identification_release_the_interpreter(case1):
    camp, _ = case1
    frfs = frameid.frf(camp, exponential_end=0.01)
    check(lambda: [frameid.frf(camp, exponential_end=0.01) for _ in range(10)])
    check(lambda: [frameid.identify_frf(frfs, refine=True) for _ in range(3)])
