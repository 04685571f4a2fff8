"""A JSON timeline of prompts and world-space constraints (for ``ardy-export sample``).

Times are in seconds from the start of the rollout, converted to frames at ``fps``
(rounded to the nearest frame)::

    {"prompts": [{"time": 0, "text": "a person walks"}, {"time": 4, "text": "..."}],
     "constraints": [
        {"type": "waypoint", "time": 3.0, "x": 1.0, "z": 4.0, "heading": 0.0},
        {"type": "path", "start_time": 0.0, "points": [[0, 0], [0, 5]], "speed": 1.2},
        {"type": "joint", "time": 2.0, "joint": "Hand_R", "position": [0.3, 1.5, 0.4]},
        {"type": "contact", "start_time": 1.0, "end_time": 2.0, "feet": [0, 1], "value": 1}
     ]}
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ardy_export.models import layout as L
from ardy_export.sampling.constraints import (
    Constraint,
    FootContact,
    JointTarget,
    RootWaypoint,
    path_from_polyline,
    validate,
)
from ardy_export.sampling.sampler import PromptEvent


def _frame(seconds: float, fps: float) -> int:
    return round(float(seconds) * fps)


def parse_timeline(
    doc: dict[str, Any], fps: float = L.FPS
) -> tuple[list[PromptEvent], list[Constraint]]:
    prompts = [
        PromptEvent(_frame(p.get("time", 0.0), fps), p.get("text")) for p in doc.get("prompts", [])
    ]
    constraints: list[Constraint] = []
    for i, c in enumerate(doc.get("constraints", [])):
        kind = c.get("type")
        if kind == "waypoint":
            con: Constraint = RootWaypoint(
                _frame(c["time"], fps),
                float(c["x"]),
                float(c["z"]),
                None if c.get("heading") is None else float(c["heading"]),
            )
        elif kind == "path":
            con = path_from_polyline(
                c["points"],
                float(c.get("speed", 1.2)),
                _frame(c.get("start_time", 0.0), fps),
                fps,
                bool(c.get("heading", True)),
            )
        elif kind == "joint":
            name = c["joint"]
            if name not in L.JOINT_NAMES:
                raise ValueError(f"constraints[{i}]: unknown joint {name!r}")
            con = JointTarget(
                _frame(c["time"], fps),
                L.JOINT_NAMES.index(name),
                None if c.get("position") is None else np.asarray(c["position"], np.float64),
                None if c.get("rotation") is None else np.asarray(c["rotation"], np.float64),
            )
        elif kind == "contact":
            con = FootContact(
                _frame(c["start_time"], fps),
                _frame(c["end_time"], fps),
                tuple(int(f) for f in c.get("feet", (0, 1, 2, 3))),
                float(c.get("value", 1.0)),
            )
        else:
            raise ValueError(f"constraints[{i}]: unknown type {kind!r}")
        validate(con)
        constraints.append(con)
    return prompts, constraints
