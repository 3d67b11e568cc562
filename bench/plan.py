"""Benchmark of the rig planner: `mirrorscan plan` for a standing person of 1.75 m in a room of
3.0 x 3.6 m with two mirrors of at most 0.8 x 1.9 m (the whole search, the subject's distance
searched too)."""

from __future__ import annotations

import time

from mirrorcore.plan.search import plan_rig
from mirrorcore.plan.setup import parse_room, plan_camera


def run() -> dict[str, float]:
    """The planner's time for a two-mirror plan of the person.

    Returns
    -------
    dict of str to float
        {"plan_s": seconds, "plan_cpu_s": the process's CPU seconds (every thread; less moved by
        other work on the machine), "plan_coverage": the plan's coverage, "plan_v_coverage": the
        best symmetric V's}.
    """
    start, cpu = time.perf_counter(), time.process_time()
    result = plan_rig("person:1.75", 2, (0.8, 1.9), parse_room("3.0,3.6", 1.0),
                      plan_camera("kinect_v1"))
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    return {"plan_s": seconds, "plan_cpu_s": cpu, "plan_coverage": result.coverage.coverage,
            "plan_v_coverage": result.hand_made_coverage.coverage}


if __name__ == "__main__":
    print(run())
