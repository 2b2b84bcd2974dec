"""A recorded sequence of pipeline inputs, replayed: the real-data entry to SonarSlam.

A sequence is a list of events in the order they happened: :class:`~slam.types.Odometry`
increments, :class:`~slam.pipeline.SonarFrame` frames and :class:`Release` points. The
scenario runner produces exactly such a stream (odometry cut at each ping and tick, a
frame per ping, a release per tick, a final release); a recording gives one with
:func:`recording_events`. :func:`replay` feeds any stream to a SonarSlam, so the same
stream gives the same detections and updates whoever feeds it.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from slam.pipeline.frame import SonarFrame
from slam.pipeline.sonar_slam import FrameOutput, SonarSlam, Update
from slam.types import Odometry


@dataclass(frozen=True)
class Release:
    """Release SLAM up to time ``t`` s; ``final``: end of input (segment what is left,
    then feed everything pending)."""

    t: float
    final: bool = False


def recording_events(frames: Sequence[SonarFrame], odometry: Sequence[Odometry]) -> list:
    """The stream of a recording with one odometry increment per frame interval:
    ``odometry[i - 1]`` (ending at frame i's time) before frame i, a release after each
    frame, a final release at the last frame's time."""
    if len(odometry) != max(len(frames) - 1, 0):
        raise ValueError(
            f"need one odometry increment between consecutive frames: {len(frames)} frames, "
            f"{len(odometry)} increments"
        )
    events: list = []
    for i, f in enumerate(frames):
        if i > 0:
            events.append(odometry[i - 1])
        events += [f, Release(f.time)]
    if frames:
        events.append(Release(frames[-1].time, final=True))
    return events


def replay(slam: SonarSlam, events: Iterable) -> tuple[list[FrameOutput], list[Update]]:
    """Feed ``events`` in order. Returns the outputs that processed something (windows,
    polar results, complete scans) and all updates, in order."""
    outs: list[FrameOutput] = []
    updates: list[Update] = []
    for e in events:
        if isinstance(e, Odometry):
            slam.add_odometry(e)
        elif isinstance(e, SonarFrame):
            out = slam.add_frame(e)
            if out.window is not None or out.polar is not None or out.frames:
                outs.append(out)
        elif isinstance(e, Release):
            if e.final:
                outs += slam.flush()
            updates += slam.release(e.t, final=e.final)
        else:
            raise TypeError(f"event {e!r}: expected Odometry, SonarFrame or Release")
    return outs, updates
