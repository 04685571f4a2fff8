"""The C++ text fixtures: committed as generated, and the fake encoder computes its reference."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import onnx
import onnxruntime as ort
import pytest

from ardy_export import cpp_fixtures
from fixture_compare import REGENERATE, assert_same_fixture


@pytest.fixture(scope="module")
def text_dir(repo_root: Path) -> Path:
    return repo_root / "tests" / "data" / "text"


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("text")
    cpp_fixtures.write_text_fixtures(out)
    return out


@pytest.mark.parametrize(
    "name",
    [
        cpp_fixtures.CASES_FILE,
        cpp_fixtures.FAKE_ENCODER_FILE,
        cpp_fixtures.FAKE_ENCODER_GOLDEN_FILE,
        cpp_fixtures.VOCAB_FILE,
    ],
)
def test_committed_files_equal_a_fresh_generation(
    text_dir: Path, regenerated: Path, name: str
) -> None:
    """The fake encoder graph and its golden embeddings by value within float32 tolerance;
    the tokenizer cases and the vocabulary (pure data) by bytes."""
    committed = text_dir / name
    found = regenerated / name
    if name in (cpp_fixtures.CASES_FILE, cpp_fixtures.VOCAB_FILE):
        assert committed.is_file(), f"{committed} missing: run {REGENERATE}"
        assert found.read_bytes() == committed.read_bytes(), (
            f"{name} differs from a fresh generation: run {REGENERATE}"
        )
    else:
        assert_same_fixture(found, committed)


def test_cases_cover_the_rules(text_dir: Path) -> None:
    doc = json.loads((text_dir / cpp_fixtures.CASES_FILE).read_text(encoding="utf-8"))
    assert doc["max_tokens"] == cpp_fixtures.CASES_MAX_TOKENS
    cases = doc["cases"]
    assert len(cases) >= 60
    lengths = [len(case["input_ids"]) for case in cases]
    assert max(lengths) == cpp_fixtures.CASES_MAX_TOKENS  # truncation is exercised
    assert any(100 in case["input_ids"] for case in cases)  # [UNK]
    assert any(102 in case["input_ids"][1:-1] for case in cases)  # [SEP] written in the text
    for case in cases:
        assert case["input_ids"][0] == 101 and case["input_ids"][-1] == 102
        assert case["attention_mask"] == [1] * len(case["input_ids"])


def test_fake_encoder_signature(text_dir: Path) -> None:
    model = onnx.load(str(text_dir / cpp_fixtures.FAKE_ENCODER_FILE))
    onnx.checker.check_model(model, full_check=True)
    session = ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])
    assert [(i.name, i.type, i.shape) for i in session.get_inputs()] == [
        ("input_ids", "tensor(int64)", ["batch", "tokens"]),
        ("attention_mask", "tensor(int64)", ["batch", "tokens"]),
    ]
    assert [(o.name, o.type, o.shape) for o in session.get_outputs()] == [
        ("embedding", "tensor(float)", ["batch", cpp_fixtures.EMBEDDING_SIZE])
    ]


def test_fake_encoder_matches_numpy_with_padding(text_dir: Path) -> None:
    session = ort.InferenceSession(
        str(text_dir / cpp_fixtures.FAKE_ENCODER_FILE), providers=["CPUExecutionProvider"]
    )
    rng = np.random.default_rng(7)
    ids = rng.integers(0, 30522, size=(3, 9), dtype=np.int64)
    mask = np.ones_like(ids)
    mask[1, 5:] = 0  # padded rows
    mask[2, 2:] = 0
    (out,) = session.run(["embedding"], {"input_ids": ids, "attention_mask": mask})
    a, c = cpp_fixtures.fake_encoder_weights()
    np.testing.assert_allclose(out, cpp_fixtures.fake_encoder_reference(ids, mask, a, c), atol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(out, axis=-1), 1.0, atol=1e-5)
    # Padding is invisible: row 2 alone equals row 2 padded.
    (alone,) = session.run(
        ["embedding"], {"input_ids": ids[2:, :2], "attention_mask": mask[2:, :2]}
    )
    np.testing.assert_allclose(alone[0], out[2], atol=1e-6)


def test_golden_embeddings_match_the_reference(text_dir: Path) -> None:
    doc = json.loads((text_dir / cpp_fixtures.FAKE_ENCODER_GOLDEN_FILE).read_text(encoding="utf-8"))
    a, c = cpp_fixtures.fake_encoder_weights()
    for entry in doc["prompts"]:
        ids = np.array([entry["input_ids"]], dtype=np.int64)
        expected = cpp_fixtures.fake_encoder_reference(ids, np.ones_like(ids), a, c)[0]
        np.testing.assert_array_equal(np.array(entry["embedding"], dtype=np.float32), expected)


def test_committed_vocab_is_the_encoders(text_dir: Path) -> None:
    committed = (text_dir / cpp_fixtures.VOCAB_FILE).read_bytes()
    assert committed == cpp_fixtures.package_vocab_path().read_bytes()
