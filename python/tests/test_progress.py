"""Progress reports, cancellation from the callback, and Ctrl-C."""
import os
import signal
import threading
import time

import numpy as np
import pytest

import phks
from shapes import creature


@pytest.fixture(scope="module")
def mesh():
    return phks.Mesh(*creature(3, seed=5))


def test_progress_reports_every_stage_in_order(mesh):
    calls = []
    sig = phks.signature(mesh, progress=lambda s, f: calls.append((s, f)))
    assert len(sig) > 0
    stages = [s for s, _ in calls]
    assert all(isinstance(s, phks.Stage) for s in stages)
    assert stages == sorted(stages)
    assert set(stages) == set(phks.Stage)
    assert all(0 <= f <= 1 for _, f in calls)
    spectrum_calls = []
    phks.spectrum(mesh, progress=lambda s, f: spectrum_calls.append(s))
    assert phks.Stage.EIGEN in spectrum_calls
    assert phks.Stage.PERSISTENCE not in spectrum_calls


class Stop(Exception):
    pass


@pytest.mark.parametrize("compute", [phks.signature, phks.spectrum])
def test_an_exception_in_progress_cancels_and_propagates(mesh, compute):
    calls = []

    def progress(stage, fraction):
        calls.append(stage)
        if stage == phks.Stage.EIGEN:
            raise Stop("enough")

    with pytest.raises(Stop, match="enough"):
        compute(mesh, progress=progress)
    # Not called again once it raised.
    assert calls[-1] == phks.Stage.EIGEN and calls.count(phks.Stage.EIGEN) == 1


def test_returning_false_cancels(mesh):
    calls = []

    def progress(stage, fraction):
        calls.append(stage)
        return stage != phks.Stage.HKS

    with pytest.raises(phks.Error) as e:
        phks.signature(mesh, progress=progress)
    assert e.value.status == phks.Status.CANCELLED
    assert calls[-1] == phks.Stage.HKS
    # True and None continue.
    assert len(phks.signature(mesh, progress=lambda s, f: True)) > 0
    with pytest.raises(TypeError):
        phks.signature(mesh, progress=42)


def test_spectrum_signature_reports_and_cancels(mesh):
    spec = phks.spectrum(mesh, eigen_count=50)
    calls = []
    spec.signature(progress=lambda s, f: calls.append(s))
    assert phks.Stage.PERSISTENCE in calls
    with pytest.raises(Stop):
        spec.signature(progress=lambda s, f: (_ for _ in ()).throw(Stop()))


@pytest.mark.skipif(threading.current_thread() is not threading.main_thread(),
                    reason="signals reach the main thread only")
def test_ctrl_c_cancels_a_call_without_a_progress_callable():
    # 800 eigenpairs of 10k vertices take about 10 s on one core: SIGINT
    # arrives while the library runs without the GIL, the library's
    # callback sees it through PyErr_CheckSignals and cancels within
    # tenths of a second.
    big = phks.Mesh(*creature(5, seed=3))
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    start = time.perf_counter()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            phks.spectrum(big, threads=1, eigen_count=800)
    finally:
        timer.cancel()
        timer.join()
    assert time.perf_counter() - start < 2.5
