"""Clip names, label ids -> names, and left/right label mirroring."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

# Content labels that swap under a left/right mirror (both datasets). Every other label,
# content or style, is symmetric and stays as it is.
MIRROR_CONTENT: dict[str, str] = {
    "walk-left": "walk-right",
    "walk-right": "walk-left",
    "walk-turn-left": "walk-turn-right",
    "walk-turn-right": "walk-turn-left",
    "wave-left-hand": "wave-right-hand",
    "wave-right-hand": "wave-left-hand",
    "raise-up-left-hand": "raise-up-right-hand",
    "raise-up-right-hand": "raise-up-left-hand",
}

_CLIP_NAME = re.compile(r"^(dataset-\d+)_(.+)_([^_]+)_(\d+)$")


@dataclass(frozen=True)
class ClipName:
    dataset: str
    content: str
    style: str
    take: int


def parse_clip_name(name: str) -> ClipName:
    """Split ``dataset-2_walk-turn-left_elderly_012`` into its parts (no extension)."""
    match = _CLIP_NAME.match(name)
    if not match:
        raise ValueError(f"clip name {name!r} is not of the form dataset-N_CONTENT_STYLE_TAKE")
    return ClipName(match.group(1), match.group(2), match.group(3), int(match.group(4)))


def mirror_content(content: str) -> str:
    """The content label of the mirrored motion (left <-> right; others unchanged)."""
    return MIRROR_CONTENT.get(content, content)


def mirror_style(style: str) -> str:
    """Styles have no side; unchanged."""
    return style


def read_label_names(dataset_root: Path) -> tuple[list[str], list[str]]:
    """Content and style names in id order from ``cfg/content_label.txt`` and
    ``cfg/style_label.txt`` of an unpacked dataset, without the ``dataset-N_`` prefix."""
    names: list[list[str]] = []
    for file in ("content_label.txt", "style_label.txt"):
        path = dataset_root / "cfg" / file
        lines = [ln.strip() for ln in path.read_text(encoding="utf-8").splitlines()]
        names.append([re.sub(r"^dataset-\d+_", "", ln) for ln in lines if ln])
    return names[0], names[1]


def read_clip_labels(json_path: Path, contents: list[str], styles: list[str]) -> tuple[str, str]:
    """(content, style) names of a clip's label JSON (numeric ids, ``{"content": 6, ...}``)."""
    data = json.loads(json_path.read_text(encoding="utf-8"))
    try:
        return contents[int(data["content"])], styles[int(data["style"])]
    except (KeyError, IndexError, TypeError, ValueError) as error:
        raise ValueError(f"{json_path}: bad label ids {data!r} ({error})") from None
