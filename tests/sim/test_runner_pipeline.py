"""The runner feeds SLAM only through slam.pipeline.SonarSlam: the stream of odometry,
frames and releases it produced, replayed through the real-data entry
(slam.pipeline.replay, what ``undersea sss-slam`` uses) into a freshly built pipeline
with the ground truth stripped from every frame, gives the identical updates and map."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sim.runner.build import nav_bias_model, pipeline_config
from sim.runner.schedule import ScenarioRun
from sim.scenario.schema import load_scenario
from slam.estimators.nav_bias import NavBiasSlam
from slam.pipeline import (
    EstimatorSpec,
    Release,
    SonarFrame,
    SonarSlam,
    build_estimator,
    make_frontend,
    replay,
)


class RecordingSlam:
    """A SonarSlam that records every call made to it (the runner's stream)."""

    def __init__(self, inner: SonarSlam) -> None:
        self.inner = inner
        self.events: list = []
        self.updates: list = []

    def add_odometry(self, odo):
        self.events.append(odo)
        return self.inner.add_odometry(odo)

    def add_frame(self, frame):
        self.events.append(frame)
        return self.inner.add_frame(frame)

    def flush(self):
        return self.inner.flush()  # replay's final Release flushes, as the runner does

    def release(self, t, *, final=False):
        self.events.append(Release(t, final))
        u = self.inner.release(t, final=final)
        self.updates += u
        return u

    def __getattr__(self, name):
        return getattr(self.inner, name)


@pytest.fixture(scope="module")
def recorded():
    scn = load_scenario(
        "shipwreck-survey",
        {
            "outputs.figures": False,
            "outputs.recording": False,
            "frontend.window_pings": 60,
            "frontend.hop_pings": 30,
        },
    ).with_overrides(duration_s=40.0)
    run = ScenarioRun(scn)
    v = run.vehicles[0]
    rec = RecordingSlam(v.slam)
    v.slam = rec
    assert run.run(scn.duration_s)
    return scn, run, v, rec


def _fresh_pipeline(run, v) -> SonarSlam:
    vs = v.spec
    cfg = pipeline_config(vs)
    fronts = {s.spec.name: make_frontend(s.geometry, cfg) for s in v.sonars}
    pose0 = v.slam.dr_pose[0]
    est = build_estimator(EstimatorSpec(vs.slam.estimator, vs.slam.params), pose0, cfg)
    if nav_bias_model(vs) is not None:  # the run's navigation bias states
        est = NavBiasSlam(est, nav_bias_model(vs), t0=v.slam.dr_t[0])
    return SonarSlam(fronts, est, cfg, t0=v.slam.dr_t[0], pose0=pose0)


def test_replayed_runner_stream_without_truth_gives_identical_updates(recorded):
    _, run, v, rec = recorded
    assert rec.updates, "the recorded sequence must exercise SLAM (no update in 40 s)"
    n_frames = sum(isinstance(e, SonarFrame) for e in rec.events)
    assert n_frames > 300
    events = [replace(e, truth=None) if isinstance(e, SonarFrame) else e for e in rec.events]
    fresh = _fresh_pipeline(run, v)
    _, updates = replay(fresh, events)
    assert len(updates) == len(rec.updates)
    for a, b in zip(rec.updates, updates):
        assert a.t == b.t
        assert [o.z.tolist() for o in a.observations] == [o.z.tolist() for o in b.observations]
        assert [o.R.tolist() for o in a.observations] == [o.R.tolist() for o in b.observations]
    xa, Pa = rec.inner.estimator.pose()
    xb, Pb = fresh.estimator.pose()
    np.testing.assert_array_equal(xa, xb)
    np.testing.assert_array_equal(Pa, Pb)
    np.testing.assert_array_equal(
        rec.inner.estimator.landmarks()[0], fresh.estimator.landmarks()[0]
    )
