"""run_hopper's errors name the Python argument, not ddoc-hopper's flag (issue 47).

Every keyword that maps onto a ddoc-hopper flag (--method, --preset, --hops, --seconds,
--offline-latency, --push, --robot, --model-mjcf, --render/--width/--height/--fps) with a bad value:
the ValueError names the keyword and never the flag.
"""
import math
import pathlib
import re

import pytest

import ddoc

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENARIO = str(ROOT / "models/scenarios/default.xml")

pytestmark = pytest.mark.skipif(not hasattr(ddoc, "run_hopper"),
                                reason="built without the MuJoCo application")

CASES = [
    (dict(hops=-1), r"^hops must be >= 0, got -1$"),
    (dict(seconds=-0.5), r"^seconds must be a finite number >= 0, got -0\.5$"),
    (dict(seconds=math.nan), r"^seconds must be a finite number >= 0, got nan$"),
    (dict(seconds=math.inf, hops=1), r"^seconds must be a finite number >= 0, got inf$"),
    (dict(method="bogus", hops=1), r'^method "bogus": expected alg1, ocfb or mrl$'),
    (dict(preset="fast", hops=1), r'^preset "fast": expected default, paper or identified$'),
    (dict(offline_latency=-0.01, hops=1),
     r"^offline_latency must be a finite number >= 0 \(s\), got -0\.01$"),
    (dict(offline_latency=math.nan, hops=1),
     r"^offline_latency must be a finite number >= 0 \(s\), got nan$"),
    (dict(pushes=[(0.1, 5.0, -0.1)], hops=1), r"^pushes\[0\]: "),
    (dict(robot="no_such_robot.xml", hops=1), r"^robot "),
    (dict(model_mjcf="no_such_model.xml", hops=1), r"^model_mjcf "),
]


@pytest.mark.parametrize("kwargs,message", CASES, ids=[str(c[0]) for c in CASES])
def test_bad_keyword_names_the_python_argument(kwargs, message):
    with pytest.raises(ValueError) as info:
        ddoc.run_hopper(SCENARIO, log_every=0, **kwargs)
    text = str(info.value)
    assert re.search(message, text), text
    assert not re.search(r"--(hops|seconds|method|preset|offline-latency|robot|model-mjcf)\b",
                         text), text


def test_render_settings_name_the_python_argument(tmp_path):
    if not ddoc.HAVE_RENDER:
        with pytest.raises(ValueError, match=r"^render_dir: this build has no OSMesa rendering"):
            ddoc.run_hopper(SCENARIO, hops=1, render_dir=str(tmp_path))
        return
    for kwargs, message in [
            (dict(width=-5), r"^width must be in \[1, \d+\] pixels, got -5$"),
            (dict(height=0), r"^height must be in \[1, \d+\] pixels, got 0$"),
            (dict(fps=math.inf), r"^fps must be > 0 and finite, got inf$")]:
        with pytest.raises(ValueError, match=message):
            ddoc.run_hopper(SCENARIO, hops=1, log_every=0, render_dir=str(tmp_path), **kwargs)
    with pytest.raises(ValueError, match=r"^render_dir: cannot create output directory "
                                         r"'/proc/ddoc_no/frames'"):
        ddoc.run_hopper(SCENARIO, hops=1, log_every=0, render_dir="/proc/ddoc_no/frames")


def test_offline_latency_above_the_flight_time_names_the_argument():
    # The upper bound (the gait's shortest flight) is the controller's check, after the model.
    with pytest.raises(ValueError, match=r"^offline_latency: .*offline_latency = 10"):
        ddoc.run_hopper(SCENARIO, offline_latency=10.0, hops=1, log_every=0)
