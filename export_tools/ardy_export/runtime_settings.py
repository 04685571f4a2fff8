"""The runtime's sampling settings that a package's model.json carries beside the step count
and guidance weights (docs/model_contract.md), with the values a package gets by default.
Kept apart from ``package`` so that the command line can name them without importing the
exporter (torch, ONNX)."""

from __future__ import annotations

from typing import Any

# Sigma (frames) of the runtime's Gaussian output filter over the decoded motion: the 4-frame
# patches of the tokenizer leave seams (see src/motion_filter.hpp and docs/evaluation). 1.0
# since stage 13: 1.5 made its motion smoother than the data (jerk 24.7 against 60.2 m/s^3)
# and cost R-precision; 1.0 gives 40.7 with the seams still 1.3x the inside of a patch.
OUTPUT_SMOOTHING_FRAMES = 1.0
# The most the runtime takes (src/motion_filter.hpp kMaxSmoothingFrames).
MAX_OUTPUT_SMOOTHING_FRAMES = 10.0

# Multiplier of w_con in windows whose goals are a dense root path alone (src/sampler.hpp
# WindowInput::path_guidance_scale): at full w_con a character standing or walking under a
# steered path slides its feet (stage 29: 0.48 m/s on the evaluation's dense paths, standing
# gestures 0.25 m/s against the data's 0.004); at half, 0.26 and 0.02 with every constraint
# error unchanged (the root is overwritten with the path either way).
PATH_GUIDANCE_SCALE = 0.5

# Multiplier of w_text in windows with a prompt and no goals, at the steps in the upper half
# of the schedule (src/sampler.hpp WindowInput::text_only_guidance_scale). With goals, a
# stronger text row pulls the body off them (w_text 3 everywhere: model-only waypoints
# 0.324 -> 0.374 m, over their 0.35 m bar). Alone, the shipped model at 1.5 was recognized
# better (R-precision 0.556 -> 0.593), but the C++ continuity session then flicked a foot past
# its bound in a standing gesture in 4 of 80 sampler seeds (0 at 1; 6 of 40 when every step
# was scaled), so packages ship with 1 (docs/evaluation/tried, text-only guidance).
TEXT_ONLY_GUIDANCE_SCALE = 1.0
# The most the runtime takes (src/package.hpp kMaxTextOnlyGuidanceScale).
MAX_TEXT_ONLY_GUIDANCE_SCALE = 4.0

# The runtime's sampling settings that model.json carries beside steps and guidance weights,
# with the values a package gets when neither the caller nor the checkpoint's
# ``sampling_defaults`` (a training config's ``sampling``, or ``recover-checkpoint`` of a
# package) names them.
RUNTIME_SAMPLING_DEFAULTS: dict[str, float | bool] = {
    "output_smoothing_frames": OUTPUT_SMOOTHING_FRAMES,
    "interpolate_root": True,
    "path_guidance_scale": PATH_GUIDANCE_SCALE,
    "text_only_guidance_scale": TEXT_ONLY_GUIDANCE_SCALE,
}

# What the runtime uses where a package's model.json lacks the setting (a package older than
# it): the filter off, no root interpolation, both guidance scales 1.
RUNTIME_SAMPLING_ABSENT: dict[str, float | bool] = {
    "output_smoothing_frames": 0.0,
    "interpolate_root": False,
    "path_guidance_scale": 1.0,
    "text_only_guidance_scale": 1.0,
}


def runtime_sampling(
    checkpoint_defaults: dict[str, Any], **given: float | bool | None
) -> dict[str, float | bool]:
    """The runtime sampling settings of RUNTIME_SAMPLING_DEFAULTS' keys: each one ``given``
    (not None) wins, then the checkpoint's ``sampling_defaults``, then the package default."""
    settings: dict[str, float | bool] = {}
    for name, fallback in RUNTIME_SAMPLING_DEFAULTS.items():
        value = given.get(name)
        if value is None:
            value = checkpoint_defaults.get(name, fallback)
        settings[name] = bool(value) if isinstance(fallback, bool) else float(value)
    return settings
