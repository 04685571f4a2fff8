"""A compact copy of a processed dataset, for moving it to a training machine.

``clips.npz`` holds 258 float32 features per frame (about 290 MB for the Bandai Namco
data). Most of them follow from a few: this archive keeps per frame the local joint
rotations as float16 quaternions, the root position (float32) and the four contact bits,
plus each clip's bone vectors, and rebuilds the features by forward kinematics on the
other side (``unpack_compact``), at about a sixth of the size. The rebuilt features match
the originals to float16 rotation precision (about 1e-3 rad, a millimetre or two at the
hands), which is far below what training can see.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np

from ardy_export.data.dataset import CLIPS_FILE, INDEX_FILE, LABELS_FILE, SKELETON_FILE
from ardy_export.data.features import (
    CONTACT_SLICE,
    features_from_local,
    motion_from_features,
)
from ardy_export.data.rotations import matrix_to_quaternion, quaternion_to_matrix
from ardy_export.data.skeleton import PARENTS, local_from_global_rotations

COMPACT_FILE = "compact.npz"
_SIDE_FILES = (INDEX_FILE, LABELS_FILE, SKELETON_FILE)


def bone_vectors(global_rotations: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Each joint's offset in its parent's frame [J, 3], averaged over the clip's frames."""
    offsets = np.zeros((positions.shape[1], 3))
    for j, parent in enumerate(PARENTS):
        if parent >= 0:
            delta = positions[:, j] - positions[:, parent]
            local = np.einsum("tba,tb->ta", global_rotations[:, parent], delta)
            offsets[j] = local.mean(axis=0)
    return offsets


def pack_compact(
    processed_dir: str | Path, out_dir: str | Path, split: str | None = None
) -> dict[str, float]:
    """Writes ``out_dir/compact.npz`` and the index files; returns sizes in bytes.

    ``split`` ("train" or "test") keeps only that split's clips (a training machine needs
    only the training clips)."""
    processed_dir, out_dir = Path(processed_dir), Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    index = json.loads((processed_dir / INDEX_FILE).read_text(encoding="utf-8"))
    wanted = {e["name"] for e in index["clips"] if split is None or e["split"] == split}
    with np.load(processed_dir / CLIPS_FILE) as data:
        features = data["features"]
        all_starts = data["starts"]
        all_names = data["names"]
    keep = [k for k in range(len(all_names)) if str(all_names[k]) in wanted]
    names = all_names[keep]
    lengths = [int(all_starts[k + 1] - all_starts[k]) for k in keep]
    starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    quaternions, roots, contacts, offsets = [], [], [], []
    for k in keep:
        clip = features[all_starts[k] : all_starts[k + 1]].astype(np.float64)
        global_rotations, positions = motion_from_features(clip)
        local = local_from_global_rotations(global_rotations, PARENTS)
        q = matrix_to_quaternion(local)
        quaternions.append(q.astype(np.float16))
        roots.append(positions[:, 0].astype(np.float32))
        contacts.append(clip[:, CONTACT_SLICE] > 0.5)
        offsets.append(bone_vectors(global_rotations, positions).astype(np.float32))
    np.savez_compressed(
        out_dir / COMPACT_FILE,
        quaternions=np.concatenate(quaternions),
        roots=np.concatenate(roots),
        contacts=np.packbits(np.concatenate(contacts), axis=-1),
        offsets=np.stack(offsets),
        starts=starts,
        names=names,
    )
    for name in _SIDE_FILES:
        shutil.copyfile(processed_dir / name, out_dir / name)
    index["clips"] = [e for e in index["clips"] if e["name"] in wanted]
    (out_dir / INDEX_FILE).write_text(json.dumps(index, indent=1) + "\n", encoding="utf-8")
    return {
        "clips_npz_bytes": float((processed_dir / CLIPS_FILE).stat().st_size),
        "compact_bytes": float(
            sum((out_dir / n).stat().st_size for n in (COMPACT_FILE, *_SIDE_FILES))
        ),
    }


def unpack_compact(compact_dir: str | Path, out_dir: str | Path) -> int:
    """Rebuilds ``clips.npz`` (and copies the index files) into ``out_dir``; returns frames."""
    compact_dir, out_dir = Path(compact_dir), Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    fps = float(json.loads((compact_dir / INDEX_FILE).read_text(encoding="utf-8"))["fps"])
    with np.load(compact_dir / COMPACT_FILE) as data:
        quaternions = data["quaternions"].astype(np.float64)
        roots = data["roots"].astype(np.float64)
        contacts = np.unpackbits(data["contacts"], axis=-1)[:, :4].astype(np.float64)
        offsets = data["offsets"].astype(np.float64)
        starts = data["starts"]
        names = data["names"]
    clips = []
    for k in range(len(starts) - 1):
        rows = slice(starts[k], starts[k + 1])
        q = quaternions[rows]
        q /= np.linalg.norm(q, axis=-1, keepdims=True)
        clips.append(
            features_from_local(
                quaternion_to_matrix(q), roots[rows], offsets[k], fps, contacts[rows]
            )
        )
    features = np.concatenate(clips).astype(np.float32)
    tmp = out_dir / (CLIPS_FILE + ".tmp.npz")
    np.savez(tmp, features=features, starts=starts, names=names)
    tmp.replace(out_dir / CLIPS_FILE)
    for name in _SIDE_FILES:
        shutil.copyfile(compact_dir / name, out_dir / name)
    return int(features.shape[0])
