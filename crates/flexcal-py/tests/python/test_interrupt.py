"""Ctrl-C: long calls return with KeyboardInterrupt instead of running to the
end. The interrupt is simulated with _thread.interrupt_main, which raises the
SIGINT flag that the calls check. The check does not time the calls: the
interrupt is sent after a small fraction of the uninterrupted call's duration,
and the test asserts that the call itself raised (it never returned), not
how fast it did.

_thread.interrupt_main does nothing when SIGINT is ignored (a suite started
in the background, under nohup, or by a runner that ignores SIGINT): every
test here runs with Python's default SIGINT handler installed, and the
previous one restored after it."""

import _thread
import pathlib
import signal
import threading
import time

import pytest
from conftest import configurations

import flexcal


@pytest.fixture(autouse=True)
def default_sigint_handler():
    """Python's default SIGINT handler (KeyboardInterrupt) for the test's
    duration, whatever the process inherited."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("SIGINT handlers can only be installed from the main thread")
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def call_was_interrupted(delay, call):
    """True when `call` raised KeyboardInterrupt before returning. When it
    returned, an interrupt that was already sent is absorbed within a
    bounded wait (one second), so that it cannot land in another test."""
    returned = False
    fired = threading.Event()

    def interrupt():
        fired.set()
        _thread.interrupt_main()

    timer = threading.Timer(delay, interrupt)
    timer.start()
    try:
        call()
        returned = True
    except KeyboardInterrupt:
        pass
    finally:
        timer.cancel()
    timer.join()
    if returned and fired.is_set():
        try:
            time.sleep(1.0)
        except KeyboardInterrupt:
            pass
    return not returned


def test_batched_fk_stops_between_batches(ur10):
    # About thirty batches: the interrupt arrives while most are still to run.
    q = configurations(ur10, 500_000, seed=31)
    start = time.perf_counter()
    ur10.fk(q, threads=1)
    full = time.perf_counter() - start
    assert call_was_interrupted(full / 20, lambda: ur10.fk(q, threads=1))


def worker_threads():
    """Ids of this process's threads named flexcal-worker (Linux: /proc).
    Threads a worker starts inherit its name: a thread pool first used
    inside a worker keeps it for the life of the process."""
    tasks = pathlib.Path("/proc/self/task")
    return {t.name for t in tasks.iterdir() if (t / "comm").read_text().strip() == "flexcal-worker"}


def workers_end_within(seconds, known):
    """Polls until no flexcal-worker thread other than `known` is left, or
    `seconds` have passed; returns whether they all ended."""
    start = time.perf_counter()
    while worker_threads() - known and time.perf_counter() - start < seconds:
        time.sleep(0.01)
    return not worker_threads() - known


def test_calibrate_returns_at_once_and_its_worker_stops(ur10):
    if not pathlib.Path("/proc/self/task").is_dir():
        pytest.skip("needs /proc to see the worker thread (Linux)")
    q = configurations(ur10, 4000, seed=32)
    positions = ur10.fk(q)[:, :3, 3]
    data = flexcal.MeasurementSet.from_arrays(q, positions + 1e-4)
    start = time.perf_counter()
    result = flexcal.calibrate(ur10, data, model="elasto-geometric", select="none")
    full = time.perf_counter() - start
    # Threads that outlive a finished call are pools, not workers.
    time.sleep(0.2)
    pools = worker_threads()
    assert call_was_interrupted(
        full / 20, lambda: flexcal.calibrate(ur10, data, model="elasto-geometric", select="none")
    )
    # The identification was cancelled with the call: its worker ends within
    # a solver iteration, long before the uninterrupted run would have (it
    # had about 95 % of it left, spread over many iterations).
    assert len(result.cost_history) > 5
    assert workers_end_within(0.75 * full, pools), (
        f"worker still running {0.75 * full:.2f} s after Ctrl-C "
        f"(the whole identification takes {full:.2f} s)"
    )
