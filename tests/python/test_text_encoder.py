"""The MiniLM text encoder: ONNX export parity, tokenizer parity cases, embedding cache, and
that the embeddings of the grammar's sentences actually separate the labels."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import onnx
import onnxruntime as ort
import pytest

from ardy_export.text import export as text_export
from ardy_export.text import sentences as S
from ardy_export.text.encoder import (
    EMBEDDING_SIZE,
    MAX_TOKENS,
    TextEncoder,
    embed_all_labels,
    load_embedding_cache,
    model_path,
)

ATOL = 1e-4


@pytest.fixture(scope="session")
def encoder() -> TextEncoder:
    return TextEncoder()


@pytest.fixture(scope="session")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    """text_encoder.onnx and vocab.txt, exported once per session."""
    out = tmp_path_factory.mktemp("text_package")
    return out, text_export.export_text_encoder(out)


@pytest.fixture(scope="session")
def session(exported: tuple[Path, dict[str, Any]]) -> ort.InferenceSession:
    options = ort.SessionOptions()
    options.intra_op_num_threads = 2
    path = exported[0] / text_export.GRAPH_FILE
    return ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])


@pytest.fixture(scope="session")
def cases(repo_root: Path) -> dict[str, Any]:
    path = repo_root / "tests" / "data" / "text" / "wordpiece_cases.json"
    assert path.stat().st_size < 200_000, "keep wordpiece_cases.json small"
    return json.loads(path.read_text(encoding="utf-8"))


def _run(session: ort.InferenceSession, ids: np.ndarray, mask: np.ndarray) -> np.ndarray:
    return session.run(["embedding"], {"input_ids": ids, "attention_mask": mask})[0]


def _mixed_texts(count: int, seed: int) -> list[str]:
    rng = np.random.default_rng(seed)
    labels = S.labels()
    pool = [text_export.LONG_PROMPT, "", "Run!", "Café naïve WAVE-Right-Hand!!"]
    texts = []
    for _ in range(count):
        if rng.random() < 0.25:
            texts.append(pool[int(rng.integers(len(pool)))])
        else:
            label = labels[int(rng.integers(len(labels)))]
            texts.append(S.sample_sentence(label.dataset, label.content, label.style, rng))
    return texts


def test_graph_interface(exported: tuple[Path, dict[str, Any]]) -> None:
    out, settings = exported
    model = onnx.load(str(out / text_export.GRAPH_FILE), load_external_data=False)
    onnx.checker.check_model(model)

    def shape(value: onnx.ValueInfoProto) -> list[str | int]:
        return [d.dim_param or d.dim_value for d in value.type.tensor_type.shape.dim]

    inputs = {v.name: v for v in model.graph.input}
    assert list(inputs) == ["input_ids", "attention_mask"]
    for value in inputs.values():
        assert value.type.tensor_type.elem_type == onnx.TensorProto.INT64
        assert shape(value) == ["batch", "tokens"]
    (output,) = model.graph.output
    assert output.name == "embedding"
    assert output.type.tensor_type.elem_type == onnx.TensorProto.FLOAT
    assert shape(output) == ["batch", EMBEDDING_SIZE]
    assert {o.domain or "ai.onnx": o.version for o in model.opset_import}["ai.onnx"] == 18
    assert settings["inputs"] == [
        {"name": "input_ids", "dtype": "int64", "shape": ["batch", "tokens"]},
        {"name": "attention_mask", "dtype": "int64", "shape": ["batch", "tokens"]},
    ]
    assert settings["outputs"] == [
        {"name": "embedding", "dtype": "float32", "shape": ["batch", EMBEDDING_SIZE]}
    ]
    assert settings["max_tokens"] == MAX_TOKENS == 128
    assert settings["parity_max_abs_error"] < ATOL


def test_vocab_and_settings(exported: tuple[Path, dict[str, Any]], encoder: TextEncoder) -> None:
    out, settings = exported
    vocab = (out / text_export.VOCAB_FILE).read_text(encoding="utf-8").split("\n")[:-1]
    assert (out / "vocab.txt").read_bytes() == (model_path() / "vocab.txt").read_bytes()
    assert len(vocab) == settings["vocab_size"] == 30522
    for key, entry in settings["special_tokens"].items():
        assert vocab[entry["id"]] == entry["token"], key
        assert encoder.tokenizer.convert_tokens_to_ids(entry["token"]) == entry["id"]
    assert {k: v["id"] for k, v in settings["special_tokens"].items()} == {
        "pad": 0,
        "unk": 100,
        "cls": 101,
        "sep": 102,
        "mask": 103,
    }
    for token in ("walk", "##ing", "left", "right", "both"):
        assert encoder.tokenizer.convert_tokens_to_ids(token) == vocab.index(token)
    assert settings["lower_case"] and settings["strip_accents"] and settings["normalize"]
    assert settings["pooling"] == "mean"
    json.dumps(settings)  # goes into model.json as is


@pytest.mark.parametrize(("batch", "seed"), [(1, 0), (2, 1), (5, 2), (16, 3)])
def test_onnx_matches_sentence_transformers(
    session: ort.InferenceSession, encoder: TextEncoder, batch: int, seed: int
) -> None:
    texts = _mixed_texts(batch, seed)
    want = encoder.encode(texts)
    ids, mask = encoder.tokenize_batch(texts)
    got = _run(session, ids, mask)
    assert got.shape == (batch, EMBEDDING_SIZE) and got.dtype == np.float32
    assert np.abs(got - want).max() < ATOL
    np.testing.assert_allclose(np.linalg.norm(got, axis=1), 1.0, atol=1e-5)
    # Extra padding changes nothing.
    pad = 23
    ids_padded = np.pad(ids, ((0, 0), (0, pad)))
    mask_padded = np.pad(mask, ((0, 0), (0, pad)))
    assert np.abs(_run(session, ids_padded, mask_padded) - want).max() < ATOL


def test_one_by_one_equals_batched(session: ort.InferenceSession, encoder: TextEncoder) -> None:
    texts = _mixed_texts(6, 7)
    ids, mask = encoder.tokenize_batch(texts)
    batched = _run(session, ids, mask)
    for i, text in enumerate(texts):
        row = np.array([encoder.tokenize(text)], np.int64)
        single = _run(session, row, np.ones_like(row))
        assert np.abs(single[0] - batched[i]).max() < 1e-5


def test_long_prompts_are_truncated_like_sentence_transformers(encoder: TextEncoder) -> None:
    ids = encoder.tokenize(text_export.LONG_PROMPT)
    assert len(ids) == MAX_TOKENS and ids[0] == 101 and ids[-1] == 102
    features = encoder.model.preprocess([text_export.LONG_PROMPT])
    assert features["input_ids"][0].tolist() == ids


def test_wordpiece_cases_are_fresh(cases: dict[str, Any], encoder: TextEncoder) -> None:
    fresh = text_export.wordpiece_cases(encoder=encoder)
    assert cases["settings"] == fresh["settings"]
    assert len(cases["cases"]) >= 60
    assert [c["text"] for c in cases["cases"]] == [c["text"] for c in fresh["cases"]]
    for old, new in zip(cases["cases"], fresh["cases"], strict=True):
        assert old == new, f"stale case {old['text']!r}: run `ardy-export text wordpiece-cases`"
    assert [e["text"] for e in cases["embeddings"]] == [e["text"] for e in fresh["embeddings"]]
    for old, new in zip(cases["embeddings"], fresh["embeddings"], strict=True):
        assert old["input_ids"] == new["input_ids"]
        np.testing.assert_allclose(old["embedding"], new["embedding"], atol=1e-5)
    assert any(len(c["input_ids"]) == MAX_TOKENS for c in cases["cases"])  # truncation covered
    assert any(c["input_ids"] == [101, 102] for c in cases["cases"])  # empty string covered


def test_onnx_reproduces_the_recorded_embeddings(
    cases: dict[str, Any], session: ort.InferenceSession
) -> None:
    """What the C++ runtime checks: recorded ids through the graph give recorded embeddings."""
    for entry in cases["embeddings"]:
        ids = np.array([entry["input_ids"]], np.int64)
        got = _run(session, ids, np.ones_like(ids))[0]
        assert np.abs(got - np.array(entry["embedding"], np.float32)).max() < ATOL


def test_embeddings_separate_the_labels(encoder: TextEncoder) -> None:
    labels = S.labels()
    texts: list[str] = []
    owner: list[int] = []
    for k, label in enumerate(labels):
        group = S.sentences_for(label.dataset, label.content, label.style, count=4)
        texts += group
        owner += [k] * len(group)
    emb = encoder.encode(texts)
    who = np.array(owner)
    content = np.array([labels[k].content for k in who])
    style = np.array([labels[k].style for k in who])
    dist = 1.0 - emb @ emb.T
    same_label = who[:, None] == who[None, :]
    np.fill_diagonal(same_label, False)
    other_content = content[:, None] != content[None, :]
    same_content_other_style = (content[:, None] == content[None, :]) & (
        style[:, None] != style[None, :]
    )
    intra = dist[same_label].mean()
    print(
        f"mean cosine distance: same label {intra:.3f}, other content "
        f"{dist[other_content].mean():.3f}, same content other style "
        f"{dist[same_content_other_style].mean():.3f}"
    )
    assert intra / dist[other_content].mean() < 0.75
    assert intra / dist[same_content_other_style].mean() < 0.95
    # Nearest label centroid recovers the content of most sentences.
    centroids = np.stack([emb[who == k].mean(axis=0) for k in range(len(labels))])
    nearest = np.argmax(emb @ centroids.T, axis=1)
    assert np.mean([labels[k].content for k in nearest] == content) > 0.8
    # Left and right stay apart: a left sentence is nearer its own centroid than the mirror's.
    index = {label: k for k, label in enumerate(labels)}
    wrong = 0
    total = 0
    for k, label in enumerate(labels):
        mirror = S.mirror_label(label)
        if mirror == label:
            continue
        rows = emb[who == k]
        wrong += int(np.sum(rows @ centroids[k] <= rows @ centroids[index[mirror]]))
        total += len(rows)
    assert wrong / total < 0.1, f"{wrong}/{total} sentences nearer their mirror label"


def test_embedding_cache_round_trip(tmp_path: Path, encoder: TextEncoder) -> None:
    labels = [
        S.Label("dataset-2", "wave-left-hand", "elderly"),
        S.Label("dataset-2", "wave-right-hand", "elderly"),
        S.Label("dataset-1", "walk", "normal"),
        S.Label("dataset-2", "walk", "normal"),  # same sentences: stored once
    ]
    path = tmp_path / "emb.npz"
    meta = embed_all_labels(path, encoder, labels)
    per_label = len(S.sentences_for("dataset-1", "walk", "normal"))
    assert meta["labels"] == 4 and meta["sentences"] == 3 * per_label
    cache = load_embedding_cache(path)
    texts = cache.label_texts("dataset-2", "wave-right-hand", "elderly")
    assert texts == S.sentences_for("dataset-2", "wave-right-hand", "elderly")
    vectors = cache.label_embeddings("dataset-2", "wave-right-hand", "elderly")
    assert vectors.shape == (len(texts), EMBEDDING_SIZE) and vectors.dtype == np.float32
    assert np.abs(vectors[:4] - encoder.encode(texts[:4])).max() < 1e-5
    sentence, vector = cache.sample("dataset-1", "walk", "normal", np.random.default_rng(0))
    assert sentence in S.sentences_for("dataset-1", "walk", "normal")
    np.testing.assert_array_equal(cache.lookup(sentence), vector)
    np.testing.assert_array_equal(
        cache.canonical("dataset-2", "walk", "normal"), cache.lookup("a person walks forward")
    )
    with pytest.raises(KeyError, match="not in the embedding cache"):
        cache.label_embeddings("dataset-2", "run", "normal")
    # A cache made from another grammar is refused.
    with np.load(path) as data:
        arrays = dict(data)
    stale = json.loads(str(arrays["meta"]))
    stale["grammar_sha256"] = "0" * 64
    arrays["meta"] = np.array(json.dumps(stale))
    np.savez(tmp_path / "stale.npz", **arrays)
    with pytest.raises(ValueError, match="ardy-export text embed"):
        load_embedding_cache(tmp_path / "stale.npz")
    # So is one whose sentences no longer match the expansion.
    with np.load(path) as data:
        arrays = dict(data)
    changed = arrays["sentences"].copy()
    changed[int(arrays["label_sentences"][1])] = "a person does something else"
    arrays["sentences"] = changed
    np.savez(tmp_path / "changed.npz", **arrays)
    with pytest.raises(ValueError, match="sentences of dataset-2/wave-left-hand/elderly changed"):
        load_embedding_cache(tmp_path / "changed.npz")
    assert load_embedding_cache(tmp_path / "changed.npz", check=False).meta == meta


def test_tiny_random_encoder_has_the_same_interface(tmp_path: Path) -> None:
    settings = text_export.export_text_encoder(tmp_path, tiny_random_seed=0)
    size = settings["embedding_size"]
    assert size < EMBEDDING_SIZE
    assert (tmp_path / "text_encoder.onnx").stat().st_size < 2_000_000
    assert settings["outputs"][0]["shape"] == ["batch", size]
    session = ort.InferenceSession(
        str(tmp_path / "text_encoder.onnx"), providers=["CPUExecutionProvider"]
    )
    ids = np.array([[101, 3328, 2830, 102, 0]], np.int64)
    out = _run(session, ids, (ids != 0).astype(np.int64))
    assert out.shape == (1, size)
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0, atol=1e-5)


def test_label_bank_round_trips_and_feeds_training(encoder: TextEncoder, tmp_path: Path) -> None:
    from ardy_export.text.encoder import load_label_bank, write_label_bank
    from ardy_export.text.sentences import labels, sentences_for
    from ardy_export.training.adapters import TextBank

    chosen = labels("dataset-2")[:3]
    path = tmp_path / "bank.npz"
    write_label_bank(path, sentences_per_label=4, encoder=encoder, labels=chosen)
    bank = load_label_bank(path)
    assert len(bank) == 3
    first = chosen[0]
    vectors = bank[(first.dataset, first.content, first.style)]
    expected = encoder.encode(sentences_for(first.dataset, first.content, first.style, count=4))
    assert vectors.shape == (4, 384)
    assert np.abs(vectors - expected).max() < 2e-3  # float16 storage
    keys = [(c.dataset, c.content, c.style) for c in chosen]
    training = TextBank(keys, mode="bank", embedding_cache=path)
    assert np.array_equal(training.embeddings[keys[1]], bank[keys[1]])
    with pytest.raises(ValueError, match="no embeddings for label"):
        TextBank([("dataset-1", "walk", "old")], mode="bank", embedding_cache=path)


def test_int8_encoder_is_a_quarter_the_size_and_keeps_the_embeddings(
    tmp_path: Path, session: ort.InferenceSession, encoder: TextEncoder
) -> None:
    import onnx

    settings = text_export.export_text_encoder(tmp_path, weights="int8")
    path = tmp_path / text_export.GRAPH_FILE
    assert settings["weights"] == "int8"
    assert settings["parity_min_cosine"] >= text_export.INT8_MIN_COSINE
    assert path.stat().st_size < 26_000_000  # float32: 91 MB
    graph = onnx.load(str(path)).graph
    weights = {init.name for init in graph.initializer}
    assert sum(node.op_type == "MatMulNBits" for node in graph.node) == 36  # 6 layers x 6
    # What stays float32 are the attention products of two activations.
    float_matmuls = [n for n in graph.node if n.op_type == "MatMul"]
    assert float_matmuls and not any(set(n.input) & weights for n in float_matmuls)
    int8 = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    ids, mask = encoder.tokenize_batch(_mixed_texts(120, seed=4))
    ids, mask = ids.astype(np.int64), mask.astype(np.int64)
    want, got = _run(session, ids, mask), _run(int8, ids, mask)
    cosine = (want * got).sum(axis=1)
    assert cosine.min() > 0.99 and cosine.mean() > 0.998
