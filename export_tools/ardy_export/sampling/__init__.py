"""Reference sampler: guidance, per-window constraint conversion, DDIM windows, rollout."""

from ardy_export.sampling.constraints import (
    FootContact,
    JointTarget,
    PoseKeyframe,
    RootPath,
    RootWaypoint,
    WindowGoals,
    window_goals,
)
from ardy_export.sampling.guidance import Branch, combine, guidance_branches
from ardy_export.sampling.sampler import (
    ModelBundle,
    PromptEvent,
    RolloutConfig,
    RolloutResult,
    WindowRequest,
    rollout,
    sample_windows,
)

__all__ = [
    "Branch",
    "FootContact",
    "JointTarget",
    "ModelBundle",
    "PoseKeyframe",
    "PromptEvent",
    "RolloutConfig",
    "RolloutResult",
    "RootPath",
    "RootWaypoint",
    "WindowGoals",
    "WindowRequest",
    "combine",
    "guidance_branches",
    "rollout",
    "sample_windows",
    "window_goals",
]
