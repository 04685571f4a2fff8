"""Motion made by the C++ runtime: runs ``ardy-generate`` on JSON timelines, in parallel.

Evaluation numbers come from the shipped package as the plugin runs it, so every generated
motion here is the CLI's per-frame JSON (``--out-json``), read back as arrays.
"""

from __future__ import annotations

import json
import subprocess
import tempfile
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ardy_export.data.rotations import quaternion_to_matrix

# Where scripts/build.sh puts the CLI, newest build first.
DEFAULT_CLI_PATHS = (
    "build/template_release/src/ardy-generate",
    "build/template_debug/src/ardy-generate",
)


@dataclass
class Job:
    """One CLI run: a timeline, a length and the sampling settings."""

    timeline: dict[str, Any]
    seconds: float
    seed: int = 0
    steps: int | None = None
    extra_args: list[str] = field(default_factory=list)


@dataclass
class Generated:
    fps: float
    joints: list[str]
    parents: list[int]
    positions: np.ndarray  # [T, J, 3] world, metres
    local_rotations: np.ndarray  # [T, J, 3, 3] parent-relative (root: world)
    contacts: np.ndarray  # [T, C] the model's foot contact channels
    wall_seconds: float

    def global_rotations(self) -> np.ndarray:
        """[T, J, 3, 3] world rotations (parents come before their children)."""
        out = np.empty_like(self.local_rotations)
        for j, parent in enumerate(self.parents):
            local = self.local_rotations[:, j]
            out[:, j] = local if parent < 0 else out[:, parent] @ local
        return out


def find_cli(explicit: str | None = None) -> Path:
    """The ``ardy-generate`` binary: ``explicit`` or the newest local build."""
    candidates = [explicit] if explicit else list(DEFAULT_CLI_PATHS)
    for candidate in candidates:
        if candidate and Path(candidate).is_file():
            return Path(candidate)
    raise FileNotFoundError(
        f"ardy-generate not found (looked at {', '.join(str(c) for c in candidates)}); "
        "build it with scripts/build.sh or pass --cli"
    )


def read_motion(path: Path, wall_seconds: float = 0.0) -> Generated:
    doc = json.loads(path.read_text(encoding="utf-8"))
    frames = doc["frames"]
    quats = np.asarray([f["local_rotations"] for f in frames], np.float64)  # x, y, z, w
    return Generated(
        fps=float(doc["fps"]),
        joints=list(doc["joints"]),
        parents=[int(p) for p in doc["parents"]],
        positions=np.asarray([f["positions"] for f in frames], np.float64),
        local_rotations=quaternion_to_matrix(quats[..., [3, 0, 1, 2]]),
        contacts=np.asarray([f["contacts"] for f in frames], np.float64),
        wall_seconds=wall_seconds,
    )


class CliRunner:
    """Runs jobs through one package with ``workers`` CLI processes of ``threads`` each."""

    def __init__(self, cli: Path, model_dir: Path, threads: int = 1, workers: int = 2) -> None:
        self.cli = cli
        self.model_dir = model_dir
        self.threads = threads
        self.workers = workers

    def _run(self, job: Job, scratch: Path, index: int) -> Generated:
        timeline = scratch / f"timeline_{index}.json"
        out = scratch / f"motion_{index}.json"
        timeline.write_text(json.dumps(job.timeline), encoding="utf-8")
        command = [
            str(self.cli),
            "--model",
            str(self.model_dir),
            "--timeline",
            str(timeline),
            "--seconds",
            f"{job.seconds:g}",
            "--seed",
            str(job.seed),
            "--threads",
            str(self.threads),
            "--out-json",
            str(out),
            *(["--steps", str(job.steps)] if job.steps else []),
            *job.extra_args,
        ]
        done = subprocess.run(command, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise RuntimeError(
                f"ardy-generate failed ({done.returncode}) on {timeline}: {done.stderr.strip()}"
            )
        wall = _reported_seconds(done.stdout)
        motion = read_motion(out, wall)
        timeline.unlink()
        out.unlink()
        return motion

    def run(
        self, jobs: Sequence[Job], progress: Callable[[int, int], None] | None = None
    ) -> list[Generated]:
        results: list[Generated | None] = [None] * len(jobs)
        with (
            tempfile.TemporaryDirectory(prefix="ardy-eval-") as tmp,
            ThreadPoolExecutor(self.workers) as pool,
        ):
            futures = {pool.submit(self._run, job, Path(tmp), i): i for i, job in enumerate(jobs)}
            for done, future in enumerate(futures, 1):
                results[futures[future]] = future.result()
                if progress:
                    progress(done, len(jobs))
        return [r for r in results if r is not None]


def _reported_seconds(stdout: str) -> float:
    """The CLI's own "... in S s" figure (generation plus loading), or 0 if absent."""
    words = stdout.split()
    for i, word in enumerate(words[:-1]):
        if word == "in" and words[i + 1].replace(".", "", 1).isdigit():
            return float(words[i + 1])
    return 0.0
