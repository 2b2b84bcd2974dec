"""Sonar frames in, SLAM map out: the one sonar-to-SLAM path (see sonar_slam.py).

Used alike by the scenario runner, the gym envs, the dataset exporter and ``undersea
sss-slam`` on recordings; it takes plain arrays (:class:`SonarFrame`) and never a
simulator object.
"""

from slam.pipeline.config import (
    REAL_SIDESCAN,
    EstimatorSpec,
    PipelineConfig,
    build_estimator,
    make_frontend,
    segmenter,
    with_real_sidescan_rules,
)
from slam.pipeline.frame import SONAR_KINDS, FrameTruth, SonarFrame, SonarGeometry
from slam.pipeline.lagged import LaggedSlam, PoseRecord, apply_increment
from slam.pipeline.replay import Release, recording_events, replay
from slam.pipeline.scoring import DetectionTally, PolarScore, score_polar
from slam.pipeline.sonar_slam import FrameOutput, SonarSlam, Update

__all__ = [
    "REAL_SIDESCAN",
    "SONAR_KINDS",
    "DetectionTally",
    "EstimatorSpec",
    "FrameOutput",
    "FrameTruth",
    "LaggedSlam",
    "PipelineConfig",
    "PolarScore",
    "PoseRecord",
    "Release",
    "SonarFrame",
    "SonarGeometry",
    "SonarSlam",
    "Update",
    "apply_increment",
    "build_estimator",
    "make_frontend",
    "recording_events",
    "replay",
    "score_polar",
    "segmenter",
    "with_real_sidescan_rules",
]
