"""ONNX export of the sentence encoder, its vocabulary, text settings and WordPiece parity cases.

``text_encoder.onnx``
    inputs  ``input_ids``      int64 [batch, tokens]
            ``attention_mask`` int64 [batch, tokens] (1 = real token, 0 = padding)
    output  ``embedding``      float32 [batch, 384]
    BERT (token type ids are zeros made inside the graph) -> mean over the masked tokens ->
    L2 normalization, all inside the graph: the runtime tokenizes and calls it, nothing else.
``vocab.txt``
    the WordPiece vocabulary, one token per line, token id = line number (0-based).

The runtime's tokenizer must reproduce the Hugging Face BERT tokenizer of the model exactly;
``text_settings()`` spells out its rules and ``tests/data/text/wordpiece_cases.json`` (written by
``write_wordpiece_cases``) holds the expected ids of ~70 hard strings and a few end-to-end
embeddings.
"""

from __future__ import annotations

import hashlib
import json
import logging
import shutil
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ardy_export.onnx_files import save_clean
from ardy_export.text import encoder as text_encoder
from ardy_export.text import sentences as text_sentences
from ardy_export.text.encoder import EMBEDDING_SIZE, MAX_TOKENS, MODEL_NAME

if TYPE_CHECKING:
    import onnx
    import torch

GRAPH_FILE = "text_encoder.onnx"
VOCAB_FILE = "vocab.txt"
INPUT_NAMES = ("input_ids", "attention_mask")
OUTPUT_NAME = "embedding"
BATCH_AXIS = "batch"
TOKENS_AXIS = "tokens"
# The opset the torch exporter writes natively (no version conversion); onnxruntime 1.31 runs
# it.
OPSET = 18
CASES_FORMAT = 1
# Largest error accepted between the exported graph (ONNX Runtime) and PyTorch.
PARITY_ATOL = 1e-4
# Weight formats of the exported graph. "int8": the embedding tables as int8 (per-tensor) and
# every MatMul as 8-bit weight-only blocks of 32 (MatMulNBits), activations in float32: 24 MB
# instead of 91 MB. On the 5,200 label-bank sentences its embeddings keep a cosine similarity
# of 0.998 (min) / 0.9995 (mean) to float32, and 99.1 % of them keep their nearest label
# centroid; dynamic int8 MatMuls (activations quantized too) fall to 0.97 / 0.993.
WEIGHT_FORMATS = ("float32", "int8")
INT8_BLOCK = 32
# Smallest cosine similarity accepted between the int8 graph's embeddings and PyTorch's.
INT8_MIN_COSINE = 0.995

SPECIAL_TOKENS = {"pad": "[PAD]", "unk": "[UNK]", "cls": "[CLS]", "sep": "[SEP]", "mask": "[MASK]"}

TOKENIZER_RULES = [
    "The reference is the Hugging Face `tokenizers` (Rust) BertNormalizer + BertPreTokenizer + "
    "WordPiece of the model's tokenizer.json (tokenizers 0.23), not the older pure-Python "
    "BertTokenizer, which differs in rare cases (order of lower-casing and accent stripping, "
    "final sigma, CJK ranges).",
    "Normalize, in this order. "
    "1. Clean text: drop U+0000, U+FFFD and every character of Unicode category C (Cc, Cf, Cs, "
    "Co, Cn) except tab, newline and carriage return, so U+000B, U+000C, U+001C-001F, U+0085, "
    "U+200B and U+00AD vanish (joining their neighbours); then replace every remaining "
    "White_Space character (tab, newline, carriage return, U+0020, U+00A0, U+1680, "
    "U+2000-200A, U+2028, U+2029, U+202F, U+205F, U+3000) with a space. "
    "2. CJK: put a space before and after every code point in U+4E00-9FFF, U+3400-4DBF, "
    "U+20000-2A6DF, U+2A700-2B73F, U+2B740-2B81F, U+2B920-2CEAF, U+F900-FAFF, U+2F800-2FA1F "
    "(not U+2B820-2B91F; Hiragana, Katakana and Hangul are not in these ranges). "
    "3. Strip accents: canonical decomposition (NFD, which also splits Hangul syllables into "
    "jamo), then drop every nonspacing mark (category Mn). "
    "4. Lower-case character by character with the full Unicode mapping, without context "
    "(a final capital sigma becomes the ordinary small sigma); no compatibility folding "
    "(full-width letters, ligatures and Roman numerals stay as they are).",
    "Pre-tokenize: split on whitespace (dropped) and make every punctuation character its own "
    "word: ASCII 33-47, 58-64, 91-96, 123-126 (so $ + < = > ^ ` | ~ count) and Unicode "
    "categories Pc, Pd, Pe, Pf, Pi, Po, Ps. Symbols (Sm, Sc, Sk, So: emoji, arrows, currency "
    "other than $) are not punctuation and stay inside words.",
    "WordPiece: a word longer than 100 characters (code points) becomes [UNK]; otherwise "
    "greedy longest match from the left against the vocabulary, pieces after the first "
    "looked up with the prefix '##'; if some position has no match the whole word becomes a "
    "single [UNK].",
    "Post-process: [CLS] + word pieces + [SEP]; when longer than max_tokens, keep the first "
    "max_tokens - 2 word pieces (truncation on the right, [SEP] kept last). token_type_ids "
    "are all 0 (computed inside the graph, not an input).",
    "Batching: pad on the right with [PAD] (id 0) and attention_mask 0; padding does not "
    "change an embedding (mean pooling uses the mask).",
]


def _quiet_transformers() -> None:
    from transformers.utils import logging as hf_logging

    hf_logging.disable_progress_bar()
    hf_logging.set_verbosity_error()


def load_vocab(path: Path | None = None) -> list[str]:
    """The WordPiece vocabulary in id order (one token per line of vocab.txt)."""
    path = path or text_encoder.model_path() / VOCAB_FILE
    return path.read_text(encoding="utf-8").split("\n")[:-1]


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def text_settings(
    max_tokens: int = MAX_TOKENS, embedding_size: int = EMBEDDING_SIZE
) -> dict[str, Any]:
    """The text part of ``model.json``: graph names and shapes, tokenizer rules, pooling."""
    vocab_path = text_encoder.model_path() / VOCAB_FILE
    vocab = load_vocab(vocab_path)
    ids = {key: vocab.index(token) for key, token in SPECIAL_TOKENS.items()}
    return {
        "encoder": MODEL_NAME,
        "source": text_encoder.model_version(),
        "graph": GRAPH_FILE,
        "vocab": VOCAB_FILE,
        "vocab_size": len(vocab),
        "vocab_sha256": _sha256(vocab_path),
        "inputs": [
            {"name": name, "dtype": "int64", "shape": [BATCH_AXIS, TOKENS_AXIS]}
            for name in INPUT_NAMES
        ],
        "outputs": [
            {"name": OUTPUT_NAME, "dtype": "float32", "shape": [BATCH_AXIS, embedding_size]}
        ],
        "embedding_size": embedding_size,
        "max_tokens": max_tokens,
        "truncation": "right",
        "padding": {"side": "right", "id": ids["pad"]},
        "lower_case": True,
        "strip_accents": True,
        "clean_text": True,
        "split_cjk_chars": True,
        "wordpiece_prefix": "##",
        "max_chars_per_word": 100,
        "special_tokens": {
            key: {"token": token, "id": ids[key]} for key, token in SPECIAL_TOKENS.items()
        },
        "pooling": "mean",
        "normalize": True,
        "tokenizer": "bert-uncased-wordpiece",
        "tokenizer_rules": TOKENIZER_RULES,
    }


# ---------------------------------------------------------------------------------------------
# The graph


def _pooled_encoder_class() -> type[torch.nn.Module]:
    import torch
    import torch.nn.functional as F

    class PooledEncoder(torch.nn.Module):
        """BERT + mean pooling over the mask + L2 normalization, with zero token types."""

        def __init__(self, bert: torch.nn.Module) -> None:
            super().__init__()
            self.embeddings = bert.embeddings
            self.encoder = bert.encoder

        def forward(self, input_ids: torch.Tensor, attention_mask: torch.Tensor) -> torch.Tensor:
            token_type_ids = torch.zeros_like(input_ids)
            hidden = self.embeddings(input_ids=input_ids, token_type_ids=token_type_ids)
            mask = attention_mask.to(hidden.dtype)
            # Additive attention mask [batch, 1, 1, tokens]: padded keys get the lowest float.
            additive = (1.0 - mask)[:, None, None, :] * torch.finfo(hidden.dtype).min
            hidden = self.encoder(hidden, attention_mask=additive).last_hidden_state
            weights = mask.unsqueeze(-1)
            summed = (hidden * weights).sum(dim=1)
            pooled = summed / weights.sum(dim=1).clamp(min=1e-9)
            return F.normalize(pooled, p=2.0, dim=1)

    return PooledEncoder


def build_pooled_encoder(tiny_random_seed: int | None = None) -> torch.nn.Module:
    """The module the graph is exported from (eval mode, eager attention).

    With ``tiny_random_seed`` it is a 2-layer, 8-wide BERT with random weights and the real
    vocabulary (for the tiny test package); otherwise all-MiniLM-L6-v2.
    """
    import torch
    from transformers import BertConfig, BertModel

    _quiet_transformers()
    path = text_encoder.model_path()
    if tiny_random_seed is None:
        bert = BertModel.from_pretrained(
            str(path), attn_implementation="eager", add_pooling_layer=False
        )
    else:
        config = BertConfig.from_pretrained(str(path))
        config.hidden_size = 8
        config.num_hidden_layers = 2
        config.num_attention_heads = 2
        config.intermediate_size = 16
        config.max_position_embeddings = 256
        config._attn_implementation = "eager"
        torch.manual_seed(tiny_random_seed)
        bert = BertModel(config, add_pooling_layer=False)
    module = _pooled_encoder_class()(bert)
    module.eval()
    return module


def _name_axes(model: onnx.ModelProto, embedding_size: int) -> None:
    """Make the symbolic axes exactly batch/tokens on the inputs and batch on the output."""
    for value in model.graph.input:
        dims = value.type.tensor_type.shape.dim
        dims[0].dim_param = BATCH_AXIS
        dims[1].dim_param = TOKENS_AXIS
    dims = model.graph.output[0].type.tensor_type.shape.dim
    dims[0].dim_param = BATCH_AXIS
    dims[1].dim_value = embedding_size


def _rename_value(model: onnx.ModelProto, old: str, new: str) -> None:
    for node in model.graph.node:
        node.input[:] = [new if name == old else name for name in node.input]
        node.output[:] = [new if name == old else name for name in node.output]
    for value in model.graph.value_info:
        if value.name == old:
            value.name = new


def _torch_export(
    module: torch.nn.Module,
    ids: torch.Tensor,
    mask: torch.Tensor,
    batch: torch.export.Dim,
    tokens: torch.export.Dim,
    output_name: str,
    opset: int,
) -> torch.onnx.ONNXProgram:
    import torch

    return torch.onnx.export(
        module,
        (ids, mask),
        dynamo=True,
        input_names=list(INPUT_NAMES),
        output_names=[output_name],
        dynamic_shapes={
            "input_ids": {0: batch, 1: tokens},
            "attention_mask": {0: batch, 1: tokens},
        },
        opset_version=opset,
        external_data=False,
        optimize=True,
        verbose=False,
    )


def _export_graph(module: torch.nn.Module, path: Path, embedding_size: int, opset: int) -> None:
    import onnx
    import torch

    ids = torch.tensor([[101, 1037, 2711, 7365, 2830, 102], [101, 1037, 2711, 102, 0, 0]])
    mask = (ids != 0).to(torch.int64)
    batch = torch.export.Dim(BATCH_AXIS)
    positions = int(module.embeddings.position_embeddings.num_embeddings)
    tokens = torch.export.Dim(TOKENS_AXIS, min=1, max=positions)
    # The exporter names values after their aten ops (one is "embedding"), so export the output
    # under a private name and rename it once any clash is out of the way.
    temp_output = "ardy_sentence_embedding"
    registry_log = logging.getLogger("torch.onnx._internal.exporter._registration")
    level = registry_log.level
    registry_log.setLevel(logging.ERROR)  # "torchvision is not installed" is not our concern
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            program = _torch_export(module, ids, mask, batch, tokens, temp_output, opset)
    finally:
        registry_log.setLevel(level)
    model = program.model_proto
    taken = {o for node in model.graph.node for o in node.output}
    taken |= {i.name for i in model.graph.initializer}
    if OUTPUT_NAME in taken:
        _rename_value(model, OUTPUT_NAME, "token_embedding_lookup")
    _rename_value(model, temp_output, OUTPUT_NAME)
    model.graph.output[0].name = OUTPUT_NAME
    _name_axes(model, embedding_size)
    model.doc_string = (
        f"{MODEL_NAME} sentence encoder: mean pooling over attention_mask + L2 normalization"
    )
    onnx.checker.check_model(model)
    save_clean(model, path)


def _quantize_int8(path: Path) -> None:
    """Rewrites the float32 graph at ``path`` with int8 weights (see ``WEIGHT_FORMATS``)."""
    import tempfile

    import onnx
    from onnxruntime.quantization import QuantType, quantize_dynamic
    from onnxruntime.quantization.matmul_nbits_quantizer import (
        DefaultWeightOnlyQuantConfig,
        MatMulNBitsQuantizer,
    )

    quant_log = logging.getLogger()
    level = quant_log.level
    quant_log.setLevel(logging.ERROR)  # "consider pre-processing" advice, not a problem
    try:
        with tempfile.TemporaryDirectory() as tmp:
            gathered = Path(tmp) / "gather_int8.onnx"
            quantize_dynamic(
                path, gathered, weight_type=QuantType.QInt8, op_types_to_quantize=["Gather"]
            )
            config = DefaultWeightOnlyQuantConfig(block_size=INT8_BLOCK, is_symmetric=True, bits=8)
            quantizer = MatMulNBitsQuantizer(
                onnx.load(str(gathered)),
                block_size=INT8_BLOCK,
                is_symmetric=True,
                algo_config=config,
            )
            quantizer.process()
            model = quantizer.model.model
    finally:
        quant_log.setLevel(level)
    onnx.checker.check_model(model)
    save_clean(model, path)


def _embeddings(
    module: torch.nn.Module, path: Path, texts: Sequence[str], max_tokens: int
) -> tuple[np.ndarray, np.ndarray]:
    """(ONNX Runtime, PyTorch) embeddings of ``texts`` as one padded batch."""
    import onnxruntime as ort
    import torch
    from transformers import AutoTokenizer

    tokenizer = AutoTokenizer.from_pretrained(str(text_encoder.model_path()))
    batch = tokenizer(list(texts), padding=True, truncation=True, max_length=max_tokens)
    ids = np.asarray(batch["input_ids"], np.int64)
    mask = np.asarray(batch["attention_mask"], np.int64)
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    got = session.run([OUTPUT_NAME], {"input_ids": ids, "attention_mask": mask})[0]
    with torch.inference_mode():
        want = module(torch.from_numpy(ids), torch.from_numpy(mask)).numpy()
    return got, want


def export_text_encoder(
    out_dir: str | Path,
    max_tokens: int = MAX_TOKENS,
    opset: int = OPSET,
    tiny_random_seed: int | None = None,
    check: bool = True,
    weights: str = "float32",
) -> dict[str, Any]:
    """Write ``text_encoder.onnx`` and ``vocab.txt`` into ``out_dir``; return the text settings.

    ``check`` runs the graph in ONNX Runtime against PyTorch on a padded batch and raises if
    they differ by more than ``PARITY_ATOL`` (float32) or fall below a cosine similarity of
    ``INT8_MIN_COSINE`` (int8). ``weights`` is one of ``WEIGHT_FORMATS``.
    ``tiny_random_seed`` exports a tiny random-weight encoder with the same interface and
    vocabulary instead (a few MB, for test packages).
    """
    if weights not in WEIGHT_FORMATS:
        raise ValueError(f"text encoder weights: {weights!r} is not one of {WEIGHT_FORMATS}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    module = build_pooled_encoder(tiny_random_seed)
    embedding_size = int(module.embeddings.word_embeddings.embedding_dim)
    graph_path = out / GRAPH_FILE
    _export_graph(module, graph_path, embedding_size, opset)
    if weights == "int8":
        _quantize_int8(graph_path)
    shutil.copyfile(text_encoder.model_path() / VOCAB_FILE, out / VOCAB_FILE)
    _check_vocab_order(out / VOCAB_FILE)
    settings = text_settings(max_tokens, embedding_size)
    settings["opset"] = opset
    settings["weights"] = weights
    settings["graph_bytes"] = graph_path.stat().st_size
    if tiny_random_seed is not None:
        settings["encoder"] = f"random tiny BERT (seed {tiny_random_seed}), not {MODEL_NAME}"
    if check:
        texts = [
            text_sentences.canonical_prompt("walk-turn-left", "elderly"),
            "Run!",
            "a person waves the right hand happily, looking very pleased with the result",
            "",
        ]
        got, want = _embeddings(module, graph_path, texts, max_tokens)
        if weights == "int8":
            cosine = float((got * want).sum(axis=1).min())
            if cosine < INT8_MIN_COSINE:
                raise RuntimeError(
                    f"{graph_path}: int8 embeddings reach a cosine similarity of only "
                    f"{cosine:.4f} to PyTorch's (< {INT8_MIN_COSINE}); the quantization is wrong"
                )
            settings["parity_min_cosine"] = cosine
        else:
            error = float(np.abs(got - want).max())
            if error > PARITY_ATOL:
                raise RuntimeError(
                    f"{graph_path}: ONNX Runtime differs from PyTorch by {error:.3g} "
                    f"(> {PARITY_ATOL}); the export is wrong"
                )
            settings["parity_max_abs_error"] = error
    return settings


def _check_vocab_order(vocab_path: Path) -> None:
    """vocab.txt line i must be the token the tokenizer maps to id i (the runtime relies on it)."""
    from transformers import AutoTokenizer

    tokenizer = AutoTokenizer.from_pretrained(str(text_encoder.model_path()))
    vocab = load_vocab(vocab_path)
    mapping = tokenizer.get_vocab()
    if len(mapping) != len(vocab) or any(mapping.get(t) != i for i, t in enumerate(vocab)):
        raise RuntimeError(f"{vocab_path}: line order differs from the tokenizer's token ids")


# ---------------------------------------------------------------------------------------------
# WordPiece parity cases for the C++ tokenizer

LONG_PROMPT = (
    "The tall knight in shining armour walks slowly across the castle courtyard, stops, "
    "raises both hands above the head, waves goodbye with the left hand, turns to the right, "
    "and then runs as fast as possible toward the gate while the crowd cheers loudly. "
) * 3

CASE_TEXTS: tuple[str, ...] = (
    # Grammar sentences.
    "a person walks and turns left like an elderly person",
    "a person raises the right hand up in a feminine way",
    "someone, bent with age, makes a left turn while walking",
    "a small-time gangster waves both hands bye-bye",
    "wave the left hand energetically",
    "sprinting forward at full speed as if performing in a musical",
    # Case and accents.
    "A Person WALKS Forward",
    "WAVE THE LEFT HAND",
    "Café naïve",
    "résumé, crème brûlée, façade",
    "ÀÉÎÕÜ àéîõü Åström",
    "Zoë and Björn dance",
    "İstanbul straße ǅemal",
    "Привет, мир! Йога",
    "Ελληνικά κείμενα",
    # Punctuation and ASCII symbols.
    "Walk, then run!",
    "wait... what?!",
    "(jump) [kick] {punch}",
    "\"quoted\" and 'single'",
    "a/b\\c",
    "50% faster & 2x stronger",
    "#hashtag @user",
    "~tilde^caret`backtick|pipe",
    "a+b=c<d>e",
    "$100; semi:colon",
    # Numbers.
    "walk 3 steps then turn 90 degrees",
    "3.14159 and 1,000,000",
    "2nd 3rd 4th",
    # Apostrophes and hyphens.
    "don't stop, the character's arm",
    "rock 'n' roll",
    "it\u2019s l\u2019homme",
    "walk-turn-left",
    "raise-up-both-hands / wave-right-hand",
    "well-known em\u2014dash en\u2013dash minus\u22125",
    # Unicode symbols.
    "\u2192 \u2190 \u2191 \u2193 arrows\u2192",
    "\u2605 walk \u2605",
    "\u00a92024 brand\u2122",
    "\u20ac5 \u00a33 \u00a57",
    "25\u00b0C and \u00bd speed",
    "x\u00b2 + y\u00b2 = \u221e \u00a7 \u00b6",
    # CJK and other scripts.
    "\u6b69\u304f",
    "\u8d70\u3063\u3066\u5de6\u306b\u66f2\u304c\u308b",
    "\u30ab\u30bf\u30ab\u30ca \u3072\u3089\u304c\u306a",
    "\ud55c\uad6d\uc5b4 \uac77\uae30",
    "\u0645\u0631\u062d\u0628\u0627",
    "\u0928\u092e\u0938\u094d\u0924\u0947",
    "\u16a0\u16c7\u16bb runes",
    "a\U0002b830b a\U0002b920b",
    "\u039f\u0394\u039f\u03a3 \u03bf\u03b4\u03bf\u03c2",
    "\ufb01ne \ufb02ow \u1e9e \u216b",
    "\uff37\uff21\uff2c\uff2b\u3000\uff26\uff2f\uff32\uff37\uff21\uff32\uff24",
    # Emoji.
    "\U0001f642",
    "walk \U0001f6b6\u200d\u2642\ufe0f fast",
    "thumbs \U0001f44d\U0001f3fd up \U0001f1ef\U0001f1f5",
    # Whitespace and control characters.
    "  walk   forward  ",
    "walk\tforward",
    "walk\nforward\r\n",
    "\u00a0nbsp\u00a0space\u3000ideographic",
    "zero\u200bwidth soft\u00adhyphen",
    "a\x00b bell\x07char \ufffd replacement",
    "walk\x0bforward walk\x0cforward",
    "walk\x85forward walk\x1cforward",
    "walk\u2028forward walk\u1680forward",
    # Edge cases.
    "",
    "   ",
    "!!!",
    "a" * 101,
    "b" * 100,
    "supercalifragilisticexpialidocious",
    LONG_PROMPT,
)

# Texts whose embeddings are recorded for the runtime's end-to-end check.
EMBEDDING_TEXTS: tuple[str, ...] = (
    "a person walks and turns left like an elderly person",
    "Café naïve WAVE-Right-Hand!!",
    "\u8d70\u3063\u3066 \U0001f642 walk\tforward",
    "",
    LONG_PROMPT,
)


def _float32_list(values: np.ndarray) -> list[float]:
    # Shortest decimal that reads back as the same float32.
    return [float(str(np.float32(v))) for v in values]


def wordpiece_cases(
    max_tokens: int = MAX_TOKENS, encoder: text_encoder.TextEncoder | None = None
) -> dict[str, Any]:
    """The parity document: per text the ids, mask and tokens the Python tokenizer gives."""
    encoder = encoder or text_encoder.TextEncoder(max_tokens=max_tokens)
    tokenizer = encoder.tokenizer
    cases = []
    for text in CASE_TEXTS:
        ids = encoder.tokenize(text)
        cases.append(
            {
                "text": text,
                "input_ids": ids,
                "attention_mask": [1] * len(ids),
                "tokens": tokenizer.convert_ids_to_tokens(ids),
            }
        )
    embeddings = encoder.encode(list(EMBEDDING_TEXTS))
    settings = text_settings(max_tokens)
    return {
        "format": CASES_FORMAT,
        "about": (
            "Expected WordPiece ids of the Hugging Face tokenizer of all-MiniLM-L6-v2 (input_ids "
            "include [CLS] and [SEP], truncated at max_tokens, unpadded) and expected embeddings "
            "(sentence-transformers, float32) of a few texts. Regenerate with "
            "`ardy-export text wordpiece-cases`; tests/python/test_text_export.py checks it is "
            "fresh."
        ),
        "settings": {
            key: settings[key]
            for key in (
                "encoder",
                "source",
                "vocab_size",
                "vocab_sha256",
                "max_tokens",
                "truncation",
                "padding",
                "special_tokens",
                "embedding_size",
                "pooling",
                "normalize",
            )
        },
        "cases": cases,
        "embeddings": [
            {
                "text": text,
                "input_ids": encoder.tokenize(text),
                "embedding": _float32_list(vector),
            }
            for text, vector in zip(EMBEDDING_TEXTS, embeddings, strict=True)
        ],
    }


def dumps_cases(document: dict[str, Any]) -> str:
    """JSON with one case per line (readable diffs, small file), ASCII-escaped text."""
    head = {k: v for k, v in document.items() if k not in ("cases", "embeddings")}
    lines = [json.dumps(head, indent=1, sort_keys=False)[:-2] + ","]
    for key in ("cases", "embeddings"):
        rows = [" " + json.dumps(item) for item in document[key]]
        closing = "]," if key == "cases" else "]"
        lines.append(f' "{key}": [')
        lines.append(",\n".join(rows))
        lines.append(f" {closing}")
    lines.append("}")
    return "\n".join(lines) + "\n"


def write_wordpiece_cases(
    path: str | Path,
    max_tokens: int = MAX_TOKENS,
    encoder: text_encoder.TextEncoder | None = None,
) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(dumps_cases(wordpiece_cases(max_tokens, encoder)), encoding="utf-8")
    return path


def longest_sentence_tokens(encoder: text_encoder.TextEncoder | None = None) -> tuple[int, str]:
    """Word pieces (with [CLS]/[SEP]) of the grammar's longest sentence, and that sentence."""
    encoder = encoder or text_encoder.TextEncoder()
    unique = {s for group in text_sentences.all_sentences().values() for s in group}
    return max((len(encoder.tokenize(s)), s) for s in sorted(unique))
