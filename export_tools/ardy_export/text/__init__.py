"""Text for the motion model: label sentences, the MiniLM sentence encoder and its ONNX export.

* :mod:`.sentences`: the sentence grammar (``grammar.yaml``) expanded per label.
* :mod:`.encoder`: all-MiniLM-L6-v2 embeddings (offline) and the embedding cache for training.
* :mod:`.export`: ``text_encoder.onnx``, ``vocab.txt``, the text settings of ``model.json`` and
  the WordPiece parity cases for the C++ tokenizer.

torch, transformers and sentence-transformers are imported only when an encoder is built or a
graph exported, so importing this package stays light.
"""

from ardy_export.text.encoder import (
    EMBEDDING_SIZE,
    MAX_TOKENS,
    EmbeddingCache,
    TextEncoder,
    embed_all_labels,
    load_embedding_cache,
)
from ardy_export.text.export import export_text_encoder, text_settings, write_wordpiece_cases
from ardy_export.text.sentences import (
    Label,
    all_sentences,
    canonical_prompt,
    grammar_digest,
    labels,
    mirror_content,
    mirror_label,
    resolve_label,
    sample_sentence,
    sentences_for,
)

__all__ = [
    "EMBEDDING_SIZE",
    "MAX_TOKENS",
    "EmbeddingCache",
    "Label",
    "TextEncoder",
    "all_sentences",
    "canonical_prompt",
    "embed_all_labels",
    "export_text_encoder",
    "grammar_digest",
    "labels",
    "load_embedding_cache",
    "mirror_content",
    "mirror_label",
    "resolve_label",
    "sample_sentence",
    "sentences_for",
    "text_settings",
    "write_wordpiece_cases",
]
