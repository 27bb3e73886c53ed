"""Bad inputs raise MeshError subclasses with the command line's message;
cancellation through the progress callback and Ctrl-C."""

import math
import os
import signal
import threading
import time

import numpy as np
import pytest

import bubblemesh
from conftest import EXAMPLES, FIXTURES


def square():
    return str(EXAMPLES / "square.toml")


def test_missing_file():
    with pytest.raises(bubblemesh.InputError, match="no_such_part.step"):
        bubblemesh.mesh("no_such_part.step", progress=False)


def test_unknown_input_type(tmp_path):
    p = tmp_path / "part.txt"
    p.write_text("x")
    with pytest.raises(bubblemesh.InputError, match="unknown input type"):
        bubblemesh.mesh(p, progress=False)


def test_bad_expression():
    with pytest.raises(bubblemesh.SpacingError) as e:
        bubblemesh.mesh(square(), size="0.1 +* x", progress=False)
    assert isinstance(e.value, bubblemesh.MeshError)


def test_non_positive_size():
    with pytest.raises(bubblemesh.SpacingError):
        bubblemesh.mesh(square(), size=-0.1, progress=False)
    with pytest.raises(bubblemesh.SpacingError):
        bubblemesh.mesh(square(), size="0.1 - x", progress=False)


def test_callable_returning_nan():
    def d(p):
        v = np.full(len(p), 0.05)
        v[p[:, 0] > 0.5] = np.nan
        return v

    with pytest.raises(bubblemesh.SpacingError, match="NaN"):
        bubblemesh.mesh(square(), size=d, progress=False)


def test_callable_returning_non_positive():
    with pytest.raises(bubblemesh.SpacingError, match="finite and > 0"):
        bubblemesh.mesh(square(), size=lambda p: 0.05 - p[:, 0], progress=False)


@pytest.mark.parametrize(
    "bad",
    [
        lambda p: np.full((len(p), 1), 0.05),
        lambda p: np.full(len(p) + 1, 0.05),
        lambda p: 0.05,
        lambda p: np.full((len(p), 3), 0.05),
    ],
    ids=["column", "one-too-many", "scalar", "n-by-3"],
)
def test_callable_returning_wrong_shape(bad):
    with pytest.raises(bubblemesh.SpacingError, match="shape"):
        bubblemesh.mesh(square(), size=bad, progress=False)


def test_callable_raising():
    def d(p):
        raise ZeroDivisionError("boom")

    with pytest.raises(bubblemesh.SpacingError, match="boom") as e:
        bubblemesh.mesh(square(), size=d, progress=False)
    assert isinstance(e.value.__cause__, ZeroDivisionError)


def test_callable_returning_strings():
    with pytest.raises(bubblemesh.SpacingError):
        bubblemesh.mesh(square(), size=lambda p: ["a"] * len(p), progress=False)


def test_bad_options():
    with pytest.raises(bubblemesh.InputError, match="--dim 5"):
        bubblemesh.mesh(square(), dim=5, progress=False)
    with pytest.raises(bubblemesh.MeshError, match="not in 1..="):
        bubblemesh.mesh(square(), threads=100000, progress=False)
    with pytest.raises(bubblemesh.InputError, match="view"):
        bubblemesh.mesh(square(), view=(1, 2, 3), progress=False)
    with pytest.raises(bubblemesh.InputError, match="--curvature"):
        bubblemesh.mesh(square(), curvature=-1.0, progress=False)
    with pytest.raises(TypeError):
        bubblemesh.mesh(square(), size=object(), progress=False)
    with pytest.raises(TypeError):
        bubblemesh.mesh(object(), progress=False)


def test_cancel_by_progress_returning_false():
    seen = []

    def progress(info):
        seen.append(info)
        return False

    t0 = time.perf_counter()
    with pytest.raises(bubblemesh.Cancelled):
        bubblemesh.mesh(str(FIXTURES / "cube.step"), size=0.05, dim=3, progress=progress)
    assert len(seen) == 1 and seen[0]["event"] in ("stage1", "step", "pass", "done")
    assert time.perf_counter() - t0 < 5


def test_cancel_by_progress_raising_after_some_steps():
    seen = []

    class Stop(Exception):
        pass

    def progress(info):
        seen.append(info)
        if info["event"] == "step" and len(seen) > 3:
            raise Stop("enough")

    with pytest.raises(Stop):
        bubblemesh.mesh(str(FIXTURES / "cube.step"), size=0.05, dim=3, progress=progress)
    assert any(s["event"] == "step" for s in seen)
    # a later run works (nothing left cancelled or stuck)
    m = bubblemesh.mesh(square(), size=0.2, progress=False)
    assert len(m.triangles) > 0


def test_progress_sees_the_whole_run():
    events = []
    m = bubblemesh.mesh(square(), size=0.05, progress=lambda i: events.append(i))
    kinds = {e["event"] for e in events}
    assert {"stage1", "step", "done"} <= kinds, kinds
    assert len(m.triangles) > 0


def test_ctrl_c_raises_keyboard_interrupt():
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals reach the main thread only")
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    t0 = time.perf_counter()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            # long enough to be interrupted (several seconds uninterrupted)
            bubblemesh.mesh(str(FIXTURES / "block_holes.step"), size=0.5, dim=3, progress=False)
    finally:
        timer.cancel()
    assert time.perf_counter() - t0 < 10
    m = bubblemesh.mesh(square(), size=0.2, progress=False)
    assert len(m.triangles) > 0
