"""Ctrl-C: long calls return with KeyboardInterrupt long before they would
have finished. The interrupt is simulated with _thread.interrupt_main,
which raises the SIGINT flag that the calls check; the bound is relative to
the uninterrupted call timed just before, with a wide margin for a loaded
machine."""

import _thread
import threading
import time

import numpy as np
import pytest
from conftest import configurations

import flexcal


def interrupted_after(delay, call):
    timer = threading.Timer(delay, _thread.interrupt_main)
    start = time.perf_counter()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            call()
            # Had the call ignored the flag, the interrupt lands here at the latest.
            time.sleep(60)
    finally:
        timer.cancel()
    return time.perf_counter() - start


def test_batched_fk_stops_between_batches(ur10):
    q = configurations(ur10, 200_000, seed=31)
    start = time.perf_counter()
    ur10.fk(q, threads=1)
    full = time.perf_counter() - start
    elapsed = interrupted_after(full / 10, lambda: ur10.fk(q, threads=1))
    assert elapsed < 0.6 * full, (elapsed, full)


def test_calibrate_returns_at_once(ur10):
    q = configurations(ur10, 1000, seed=32)
    positions = ur10.fk(q)[:, :3, 3]
    data = flexcal.MeasurementSet.from_arrays(q, positions + 1e-4)
    start = time.perf_counter()
    flexcal.calibrate(ur10, data, model="elasto-geometric")
    full = time.perf_counter() - start
    elapsed = interrupted_after(
        full / 10, lambda: flexcal.calibrate(ur10, data, model="elasto-geometric")
    )
    assert elapsed < 0.6 * full, (elapsed, full)
